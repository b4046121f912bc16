#include "models/EffectCatalogue.hpp"

namespace tamp {

// The ranges of the catalogue's parameters, with their sources (docs/effects.md "Ranges"):
// the boxes of the emulators' designs.
namespace {
const EffectCandidate::KeyRange kCrushPressure{
    "crush_pressure", 2e3, 400e3,
    "apparent preconsolidation of a soft clay near the surface to a stiff fill, 2-400 kPa (the lab clay: Su 10 kPa)"};
const EffectCandidate::KeyRange kAirVoids{
    "air_voids", 0.0, 0.35,
    "air voids of a saturated to a loosely placed unsaturated soil, 0-35 % (the lab charge: 1526 -> 1835 kg/m3, 17 %)",
    true, 0.0};
const EffectCandidate::KeyRange kRateCoefficient{
    "rate_coefficient", 0.0, 1.0,
    "strength gain per log cycle of strain rate, 0.05-0.2 in clays (Biscontin & Pestana 2001; Einav & Randolph 2005), "
    "widened to 0-1 for impact rates",
    true, 0.0};
const EffectCandidate::KeyRange kRemouldedRatio{
    "remoulded_ratio", 0.1, 1.0, "1 / sensitivity, St 1-10: insensitive to medium-sensitive clays (Skempton & Northey 1952)",
    true, 1.0};
const EffectCandidate::KeyRange kRemouldingStrain{
    "remoulding_strain", 0.1, 20.0,
    "plastic shear strain to 95 % of the loss: 10-50 in cyclic T-bar tests (Einav & Randolph 2005), down to 0.1 for a "
    "brittle clay"};
const EffectCandidate::KeyRange kCrushHardening{
    "crush_hardening", 0.0, 1e6,
    "0-1 MPa per unit compaction strain (the lab charge's chosen 82 kPa: 4.9 to 20 kPa over its 5 % of air voids)", true};
const EffectCandidate::KeyRange kLambda{"lambda", 0.05, 0.6,
                                        "slope of the normal compression line, 0.1-0.5 for soft clays (Wood 1990)"};
const EffectCandidate::KeyRange kPc0PerSu{"p_c0", 0.5 * 4.0 / 0.9, 2.0 * 4.0 / 0.9,
                                          "4 Su / M (q = 2 Su at the yield surface's top) within a factor 2"};
}  // namespace

const std::vector<EffectCandidate>& effect_catalogue() {
  // Each effect fits the parameters the data can constrain (docs/effects.md "What each
  // effect fits"): compaction its crush pressure and air voids (the hardening fixed at 0),
  // rate its coefficient (the reference rate fixed at 1/s: above it, a reference 10^a times
  // higher is a strength (1 - beta a) times lower, so the two are one parameter), remoulding
  // its ratio and strain. Started where the effect is active; the profile grid (method
  // "profile") from nearly off to strong.
  static const std::vector<EffectCandidate> c{
      {"compaction", {{"crush_hardening", 0.0}}, {{"crush_pressure", 60e3}, {"air_voids", 0.15}},
       {400e3, 160e3, 60e3, 25e3, 10e3}, "", "", 0, false, {kCrushPressure, kAirVoids}},
      {"rate", {{"reference_strain_rate", 1.0}}, {{"rate_coefficient", 0.1}}, {0.02, 0.06, 0.15, 0.35, 0.8}, "", "", 0,
       true, {kRateCoefficient}},
      {"remoulding", {}, {{"remoulded_ratio", 0.7}, {"remoulding_strain", 0.5}}, {0.95, 0.85, 0.7, 0.5, 0.3}, "", "", 0,
       true, {kRemouldedRatio, kRemouldingStrain}},
  };
  return c;
}

const std::vector<EffectCandidate>& model_switch_catalogue() {
  // Modified Cam-Clay for a Tresca clay (docs/modified-cam-clay.md): the clay compacts and
  // hardens with the plastic volume it loses, and its strength grows with the mean stress.
  // Fitted: lambda (how much it compacts, profiled from little to much above kappa) and the
  // preconsolidation p_c0 in place of Su, started where the yield surface's top, q = M p_c0
  // / 2, is the Tresca strength in triaxial compression (q = 2 Su): p_c0 = 4 Su / M.
  // Fixed at typical values of a soft clay: kappa 0.04, M 0.9 (phi_cs about 23 deg), v0 2.2.
  static const std::vector<EffectCandidate> c{
      {"modified-cam-clay", {{"kappa", 0.04}, {"M", 0.9}, {"v0", 2.2}}, {{"lambda", 0.2}},
       {0.06, 0.1, 0.2, 0.35, 0.6}, "modified-cam-clay", "p_c0", 4.0 / 0.9, false, {kLambda, kPc0PerSu}},
  };
  return c;
}

const EffectCandidate::KeyRange* catalogue_range(const std::string& key) {
  const EffectCandidate::KeyRange* found = key == kCrushHardening.key ? &kCrushHardening : nullptr;
  for (const auto& e : effect_catalogue())
    for (const auto& r : e.ranges)
      if (r.key == key) found = &r;
  return found;
}

}  // namespace tamp
