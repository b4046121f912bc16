// What a constitutive model declares about itself, once, on the host (the types here, in core/
// because the deck reader reads them; each model's description in its own header under models/,
// the registry filled by models/ModelList.cpp): its deck name, the
// deck keys it reads (unit, allowed range, default, which calibration may fit), how they
// become the plain-data MaterialParams the kernels use, its cross-key rules and the history
// variables it updates. The deck reader and writer (core/Deck.cpp), make_material, the plan
// that `tamp check` prints and calibration's parameter table (drivers/loop/Calibration.cpp) all read
// these descriptions; the device update of each model lives in its own header and is
// dispatched by MaterialParams::model (models/StressUpdate.hpp). Adding a model: its header
// (device update + describe()), one line in models/ModelList.hpp, its test, its docs page
// (docs/architecture.md "Add a constitutive model").
#pragma once
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/Config.hpp"
#include "core/Range.hpp"

namespace tamp {

// core/Material.hpp (device plain data); not included here so that the deck reader, which
// is compiled without Kokkos in CUDA builds, can read the descriptions.
struct MaterialParams;

struct ModelKey {
  std::string key;                    // deck key ("phi_deg")
  std::string unit;                   // SI unit as the deck gives it ("Pa", "deg", "" = none)
  Range range;                        // allowed values
  std::optional<double> fallback;     // default when the deck leaves it out; none = required
  std::string meaning;                // short text for the plan and error messages
  double MaterialSpec::*field = nullptr;  // where it is stored; nullptr: MaterialSpec::params[key]
  bool fittable = true;               // calibration may fit it (drivers/loop/Calibration.cpp)
  bool shown_at_default = true;       // false: written and printed only when set (keeps decks short)
};

// A rule between keys, checked after all keys are read; when broken, the key to blame,
// what is wrong ("is out of range") and what is allowed.
struct RuleBreak {
  std::string key, problem, allowed;
};
using KeyRule = std::optional<RuleBreak> (*)(const MaterialSpec&);

// A history variable a model keeps in a slot of MaterialState::history (core/Material.hpp):
// particles and elements carry and checkpoint the slots; it starts at 0.
struct StateVariable {
  std::string name;     // "back_stress", for the plan and the docs
  std::string unit;     // SI unit ("Pa", "" = none)
  std::string meaning;  // one line
};

struct ModelDescription {
  std::string name;                   // deck name: model = "<name>"
  int kernel = 0;                     // MaterialParams::model (ModelId): the device update it runs
  std::string summary;                // one line for the plan and the docs
  std::vector<ModelKey> keys;         // its own deck keys (density, G, nu are common)
  bool effects = false;               // takes the effect keys of models/Effects.hpp
  std::vector<std::string> state;     // the standard variables it updates (MaterialState:
                                      // "plastic_strain", "compaction")
  std::vector<StateVariable> history; // its own history slots, in slot order: as many as the
                                      // model's history_count (checked by the registry)
  KeyRule rule = nullptr;             // cross-key rule (e.g. psi <= phi), or none
  // Its keys (already in spec) into the kernel parameters; the common ones are set before.
  void (*to_params)(const MaterialSpec& spec, MaterialParams& params) = nullptr;
};

// Every registered model (models/ModelList.hpp), in registration order.
const std::vector<ModelDescription>& material_models();
// The description of deck model name `name`, or nullptr.
const ModelDescription* find_material_model(const std::string& name);
// The description of spec.model; throws std::invalid_argument naming the registered models.
const ModelDescription& material_model(const MaterialSpec& spec);
// The keys every material has (density, G, nu, separation_density) and the effect keys
// (models/Effects.hpp).
const std::vector<ModelKey>& common_material_keys();
const std::vector<ModelKey>& effect_material_keys();
// A model key kept in MaterialSpec::params; throws std::invalid_argument naming the
// material and the key when it is not set (a MaterialSpec built in code without it).
double model_param(const MaterialSpec& spec, const std::string& key);
// Whether key k is written and printed only when it differs from its default (the effect
// keys and the optional common keys).
bool omitted_at_default(const ModelKey& k);
// Where key k of spec is stored, and the value (its fallback when unset).
double& key_value(MaterialSpec& spec, const ModelKey& k);
double key_value(const MaterialSpec& spec, const ModelKey& k);
// The keys spec's model reads, in order: common, its own, effects (when it takes them).
std::vector<const ModelKey*> keys_of(const ModelDescription& d);
// "mohr-coulomb", "tresca", ...: the registered names, each quoted, comma-separated.
std::string material_model_names();

// Kernel parameters of a deck material (throws std::invalid_argument for an unknown model).
MaterialParams make_material(const MaterialSpec& spec);

// The keys of every registered model as Markdown, from their declarations (key, unit, default,
// allowed range, meaning, whether calibration may fit it; the history slots): `tamp keys`, and
// the generated part of docs/input-deck.md (a test fails when the page is stale).
std::string material_keys_markdown();

}  // namespace tamp
