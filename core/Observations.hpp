// Measured (or synthetic) data for the closed loop (docs/closing-the-loop.md): a TOML file
// naming the scenario deck it belongs to and a list of observations.
//
//   scenario = "../examples/lab-test.toml"     # relative to this file
//   target_material = "clay"                   # the material(s) the effects are tried on:
//                                              #   a name or a list ["clay", "aggregate"]
//   [[observations]]
//   quantity = "uplift_m"                      # a key of summary.json, or a per-blow column
//   range = [0.010, 0.014]                     #   of blows.csv with `blow = N`
//   source = "paper, test 1"
//   [[observations]]
//   quantity = "crater_depth_m"
//   blow = 3
//   value = 0.21
//   sigma = 0.005
//
// A range [a, b] is read as value (a + b)/2 with uncertainty (b - a)/2: a model inside the
// range has |normalised residual| <= 1.
#pragma once
#include <string>
#include <vector>

namespace tamp {

struct Observation {
  std::string quantity;  // summary key, or a blows.csv column with blow > 0
  int blow = 0;          // 1-based; 0 = a summary quantity
  double value = 0;      // the measured value (the midpoint of a range)
  double sigma = 0;      // its uncertainty (> 0)
  bool is_range = false;
  double lo = 0, hi = 0; // the range as given
  std::string source;    // provenance (free text)
};

struct ObservationSet {
  std::string file;             // the data file
  std::string scenario;         // path of the scenario deck (resolved against the file's folder)
  std::string scenario_as_written;
  // Overrides of the scenario deck given on the command line of calibrate / diagnose
  // (`--set KEY=VALUE`, as for `tamp run`): e.g. a coarser screening deck,
  // sph.spacing=0.02. Not read from the data file; recorded in diagnosis.json.
  std::vector<std::string> scenario_overrides;
  std::string target_material = "clay";      // the first of target_materials
  std::vector<std::string> target_materials = {"clay"};
  // Constitutive-model switches the diagnosis tries on the target materials beside the
  // effects (e.g. "modified-cam-clay"; drivers/loop/Calibration.cpp model_switch_catalogue). None by default.
  std::vector<std::string> model_switches;
  // The effects of the catalogue the diagnosis tries (e.g. ["compaction"]); all when the data
  // file does not say (has_effects false). Checked against the catalogue by the diagnosis.
  bool has_effects = false;
  std::vector<std::string> effects;
  std::vector<Observation> observations;
};

// Quantities an observation may name.
const std::vector<std::string>& summary_quantities();   // column_length_m, ...
const std::vector<std::string>& per_blow_quantities();  // crater_depth_m, ...

// Reads and validates a data file; errors (DeckError) name the file, key, value, allowed.
ObservationSet load_observations(const std::string& path);
// Writes a data file (synthetic data); the scenario path is written as given.
void write_observations(const std::string& path, const ObservationSet& set, const std::string& header_comment);

}  // namespace tamp
