// Input decks: TOML text -> validated Config, and Config -> TOML text.
//
// Deck layout (every key optional unless stated; defaults are those of Config.hpp):
//
//   gravity = 9.81                 # m/s2, >= 0, acting in -z
//   damping = 0.0                  # 1/s, >= 0
//   [run]   name, end_time, output_interval, cfl, progress_interval, max_steps
//   [sph]   spacing (REQUIRED), h_factor, alpha, beta, artificial_stress, artificial_stress_n,
//           regularise_every, kernel_correction, neighbour_skin, axis_radius_factor
//   [[materials]]  name, model ("elastic" | "mohr-coulomb" | "tresca"), density or unit_weight,
//                  G, nu, c (Su for tresca), phi_deg, psi_deg, tension_cutoff
//   [[blocks]]     material, r = [r_min, r_max], z = [z_min, z_max], velocity = [v_r, v_z]
//   [boundaries]   bottom = { type = "fixed", z = 0.0 }, top = { type, z }, outer = { type, r }
//
// The whole deck is validated before anything is returned. Any unknown key, wrong type or
// out-of-range value throws DeckError with a message of the form
//   deck.toml: materials[1].nu = 0.6 is out of range; allowed: 0 <= nu < 0.5
// (array-of-tables indices are 0-based, in the order the entries appear in the deck).
#pragma once
#include <stdexcept>
#include <string>
#include <vector>

#include "core/Config.hpp"

namespace tamp {

struct DeckError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// An input file is opened only when it is a regular file: a FIFO would block, a device never
// end. Throws DeckError naming the path and `what` it should be ("deck file", "data file")
// when it is missing, a folder, or not a regular file.
void require_regular_file(const std::string& path, const std::string& what);

// Reads and validates the deck at `path`; Config::source_file is set to `path`.
// `overrides` are command-line KEY=VALUE settings (`tamp run --set`), applied to the parsed
// TOML before validation, so that an overridden value is checked like a written one:
//   KEY   a dotted path of tables and a key: sph.spacing, fem.enabled, schedule.relax_time,
//         boundaries.bottom.type, gravity; or <material name>.<key>: clay.Su, aggregate.phi_deg
//   VALUE a TOML value: 0.005, true, "fill", [0.3, 0.5]; nothing (KEY=) removes the key
//         (refused when the deck has no such key)
// A KEY=VALUE that is not of this form, a path through a value that is not a table, or a
// value the deck does not allow there throws DeckError naming the deck, the setting and
// what is allowed.
Config load_deck(const std::string& path, const std::vector<std::string>& overrides = {});

// Validates TOML text; `file_label` prefixes every error message and becomes
// Config::source_file. `overrides` as for load_deck.
Config parse_deck(const std::string& toml_text, const std::string& file_label,
                  const std::vector<std::string>& overrides = {});

// A complete deck (every value written out, doubles with round-trip precision) that
// parse_deck() turns back into the same Config, apart from source_file.
std::string to_toml(const Config& config);

}  // namespace tamp
