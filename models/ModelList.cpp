// The host registry of the constitutive models (models/ModelList.hpp) and what every
// material shares: density, G and nu, and the effect keys of models/Effects.hpp.
#include "models/ModelList.hpp"

#include "core/Format.hpp"

#include <set>
#include <stdexcept>

namespace tamp {
const std::vector<ModelDescription>& material_models() {
  static const std::vector<ModelDescription> all = [] {
    const std::vector<ModelDescription> v = describe_models(RegisteredModels{});
    std::set<std::string> names;
    for (const auto& d : v)
      if (!names.insert(d.name).second) throw std::logic_error("models/ModelList.hpp: model name '" + d.name + "' twice");
    return v;
  }();
  return all;
}

const ModelDescription* find_material_model(const std::string& name) {
  for (const auto& d : material_models())
    if (d.name == name) return &d;
  return nullptr;
}

std::string material_model_names() {
  std::string s;
  for (const auto& d : material_models()) s += (s.empty() ? "\"" : ", \"") + d.name + "\"";
  return s;
}

const ModelDescription& material_model(const MaterialSpec& spec) {
  const ModelDescription* d = find_material_model(spec.model);
  if (!d)
    throw std::invalid_argument("material '" + spec.name + "': model '" + spec.model +
                                "' is not a registered model; allowed: " + material_model_names());
  return *d;
}

const std::vector<ModelKey>& common_material_keys() {
  using namespace ranges;
  static const std::vector<ModelKey> keys = {
      {"density", "kg/m3", gt(0), std::nullopt, "density (or unit_weight in N/m3)", &MaterialSpec::density},
      {"G", "Pa", gt(0), std::nullopt, "shear modulus", &MaterialSpec::shear_modulus},
      {"nu", "", ge_lt(0, 0.5), std::nullopt, "Poisson's ratio", &MaterialSpec::poisson_ratio},
      // A granular material's loosest packing: below it the grains have no contacts and
      // carry no stress (models/StressUpdate.hpp, docs/models.md "Separated grains").
      {"separation_density", "kg/m3", ge(0), 0.0, "grains separate (no stress) below this density; 0 = never",
       &MaterialSpec::separation_density, false, false},
      // Mass scaling of a stiff material that sets the stable step (docs/models.md "Mass
      // scaling"): its inertia times this, its weight and stiffness as they are.
      {"mass_scaling", "", ge_le(1, 100), 1.0, "inertia / mass (weight and stiffness unscaled); 1 = none",
       &MaterialSpec::mass_scaling, false, false},
      // The material's share of the Monaghan viscosity (docs/sph.md "Artificial viscosity
      // per material"): a flowing granular charge needs less than the impact's shock.
      {"viscosity", "", ge_le(0, 10), 1.0, "artificial viscosity / [sph] alpha and beta (pair: the mean); 1 = as [sph]",
       &MaterialSpec::viscosity, false, false},
      // Grains that slide past each other are not pushed apart (docs/sph.md "Head-on
      // viscosity"): the viscosity weighted by the head-on part of each pair's approach.
      {"viscosity_head_on", "", ge_le(0, 1), 0.0,
       "0..1: the viscosity on the head-on part of a pair's approach only (pair: the mean); 0 = Monaghan's",
       &MaterialSpec::viscosity_head_on, false, false},
  };
  return keys;
}

const std::vector<ModelKey>& effect_material_keys() {
  using namespace ranges;
  static const std::vector<ModelKey> keys = {
      {"crush_pressure", "Pa", ge(0), 0.0, "(a) compaction: mean pressure where crushing starts",
       &MaterialSpec::crush_pressure},
      {"crush_hardening", "Pa", ge(0), 0.0, "(a) hardening per unit compaction strain", &MaterialSpec::crush_hardening},
      {"air_voids", "", ge_lt(0, 1), 0.0, "(a) largest compaction strain", &MaterialSpec::air_voids},
      {"rate_coefficient", "", ge(0), 0.0, "(b) strength gain per decade of strain rate",
       &MaterialSpec::rate_coefficient},
      {"reference_strain_rate", "1/s", gt(0), 1.0, "(b) reference shear strain rate",
       &MaterialSpec::reference_strain_rate},
      {"remoulded_ratio", "", gt_le(0, 1), 1.0, "(c) remoulded / intact strength", &MaterialSpec::remoulded_ratio},
      {"remoulding_strain", "", gt(0), 1.0, "(c) plastic shear strain at 95 % of the loss",
       &MaterialSpec::remoulding_strain},
  };
  return keys;
}

double model_param(const MaterialSpec& spec, const std::string& key) {
  const auto it = spec.params.find(key);
  if (it == spec.params.end())
    throw std::invalid_argument("material '" + spec.name + "' (model \"" + spec.model + "\"): " + key + " is not set");
  return it->second;
}

bool omitted_at_default(const ModelKey& k) {
  if (!k.shown_at_default) return true;
  for (const auto& e : effect_material_keys())
    if (e.key == k.key) return true;
  return false;
}

double& key_value(MaterialSpec& spec, const ModelKey& k) {
  if (k.field) return spec.*(k.field);
  auto it = spec.params.find(k.key);
  if (it == spec.params.end()) it = spec.params.emplace(k.key, k.fallback.value_or(0.0)).first;
  return it->second;
}

double key_value(const MaterialSpec& spec, const ModelKey& k) {
  if (k.field) return spec.*(k.field);
  const auto it = spec.params.find(k.key);
  return it == spec.params.end() ? k.fallback.value_or(0.0) : it->second;
}

std::vector<const ModelKey*> keys_of(const ModelDescription& d) {
  std::vector<const ModelKey*> out;
  for (const auto& k : common_material_keys()) out.push_back(&k);
  for (const auto& k : d.keys) out.push_back(&k);
  if (d.effects)
    for (const auto& k : effect_material_keys()) out.push_back(&k);
  return out;
}

MaterialParams make_material(const MaterialSpec& s) {
  const ModelDescription& d = material_model(s);
  MaterialParams m;
  m.model = d.kernel;
  m.density = s.density;
  m.shear_modulus = s.shear_modulus;
  m.bulk_modulus = bulk_from_shear(s.shear_modulus, s.poisson_ratio);
  m.separation_density = s.separation_density;
  m.inertia = s.mass_scaling;
  m.viscosity = s.viscosity;
  m.viscosity_head_on = s.viscosity_head_on;
  if (d.to_params) d.to_params(s, m);
  if (d.effects) {
    m.crush_pressure = s.crush_pressure;
    m.crush_hardening = s.crush_hardening;
    m.air_voids = s.air_voids;
    m.rate_coefficient = s.rate_coefficient;
    m.reference_strain_rate = s.reference_strain_rate;
    m.remoulded_ratio = s.remoulded_ratio;
    m.remoulding_strain = s.remoulding_strain;
  }
  return m;
}

std::string material_keys_markdown() {
  auto row = [](const ModelKey& k) {
    const std::string def = k.fallback ? fmt_num(*k.fallback) : std::string("**required**");
    return "| `" + k.key + "` | " + (k.unit.empty() ? std::string("-") : k.unit) + " | " + def + " | `" +
           k.range.text(k.key, "") + "` | " + k.meaning + (k.fittable ? "" : " (not fitted by the loop)") + " |\n";
  };
  const std::string head = "| key | unit | default | allowed | meaning |\n|---|---|---|---|---|\n";
  std::string o = "Every material (any model):\n\n" + head;
  for (const auto& k : common_material_keys()) o += row(k);
  o += "\nThe effects (docs/effects.md), with the models that take them; each off at its default:\n\n" + head;
  for (const auto& k : effect_material_keys()) o += row(k);
  for (const auto& d : material_models()) {
    o += "\n`model = \"" + d.name + "\"`: " + d.summary + (d.effects ? "; takes the effects" : "") + ".";
    if (!d.history.empty()) {
      o += " History slots:";
      for (const auto& h : d.history) o += " `" + h.name + "` (" + h.meaning + ")";
      o += ".";
    }
    o += "\n";
    if (d.keys.empty()) {
      o += "No keys of its own.\n";
      continue;
    }
    o += "\n" + head;
    for (const auto& k : d.keys) o += row(k);
  }
  return o;
}

}  // namespace tamp
