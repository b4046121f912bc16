// The loop's catalogue of what a model may lack (docs/effects.md, docs/closing-the-loop.md):
// the effects the diagnosis tries on a material (compaction, rate, remoulding) and the model
// switches a data file may ask for (Modified Cam-Clay for a Tresca clay), each with the keys
// it fixes at typical values, the keys it fits with their starting values, and the physical
// range of each fitted key with its source. Constitutive knowledge, so it lives with the
// models; the loop (drivers/loop/Calibration.cpp) reads it.
#pragma once
#include <string>
#include <utility>
#include <vector>

namespace tamp {

// One entry of the effect catalogue, as the diagnosis tries it: an effect composed with the
// material's model, or a constitutive-model switch (`model` set), which replaces the model.
struct EffectCandidate {
  std::string name;                          // "compaction", "rate", "remoulding", "modified-cam-clay"
  std::vector<std::pair<std::string, double>> fixed;  // keys set before the fit (material-relative)
  std::vector<std::pair<std::string, double>> fitted; // keys fitted, with starting values
  std::vector<double> grid;                  // profile: values of the (first) fitted key tried in turn
  // A model switch: the material's model becomes `model`; its key `strength` takes the place
  // of the material's baseline strength (the parameter the profile refits), started at
  // strength_per_su times the material's current Su (c). Empty for an effect.
  std::string model;
  std::string strength;
  double strength_per_su = 0;
  // The effect scales the material's strength c (rate, remoulding: c = c0 F): on a material
  // with c0 = 0 (a cohesionless charge) it has nothing to act on and is not a candidate.
  bool scales_strength = false;
  // The physical range of each fitted key (and of `strength`, per Su), with its source: the
  // box of the candidate's emulator design.
  struct KeyRange {
    std::string key;
    double lo, hi;
    std::string source;
    bool linear = false;  // designed in the value (ParameterRange::linear)
    double off = -1;      // the value that switches the effect off, where it is in [lo, hi]
  };
  std::vector<KeyRange> ranges;
};
const std::vector<EffectCandidate>& effect_catalogue();
// The constitutive-model switches a data file may ask for (`model_switches`).
const std::vector<EffectCandidate>& model_switch_catalogue();
// The catalogue's range of key (any candidate's fitted key, or crush_hardening), or nullptr.
const EffectCandidate::KeyRange* catalogue_range(const std::string& key);

}  // namespace tamp
