// The registered constitutive models: one name each in RegisteredModels, beside the include
// of the model's header. Each model is a struct with
//   static constexpr int id;                 (its MaterialParams::model, distinct)
//   static constexpr int history_count;      (history slots it keeps, <= kHistorySlots)
//   KOKKOS_INLINE_FUNCTION static int plastic_correction(params, sigma, deps,
//       MaterialState& state, dt);           (device, after the elastic predictor)
//   static std::vector<ModelDescription> describe();   (host: deck names, keys, history names)
// The device dispatch (ModelSet::plastic_correction, called by models/StressUpdate.hpp) and
// the host registry (models/ModelList.cpp) both read this list; kernels take the list as a
// template argument (default RegisteredModels), so that a test can run them with a model of
// its own (tests/test_toy_model.cpp). Checklist: docs/architecture.md "Add a constitutive model".
#pragma once
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/Material.hpp"
#include "core/MaterialModel.hpp"
#include "models/Elastic.hpp"
#include "models/MohrCoulomb.hpp"
#include "models/ModifiedCamClay.hpp"

namespace tamp {

// A list of models and the device dispatch over it: the plastic correction of the model whose
// id is params.model (0, elastic, when none is).
template <class... Models>
struct ModelSet {
  static_assert(((Models::history_count >= 0 && Models::history_count <= kHistorySlots) && ...),
                "a model keeps more history slots than kHistorySlots (core/Material.hpp)");
  // Whether any model of the list keeps history slots (the kernels load and store them only then).
  static constexpr bool has_history = ((Models::history_count > 0) || ...);

  KOKKOS_INLINE_FUNCTION static int plastic_correction(const MaterialParams& m, double sigma[4],
                                                       const double deps[4], MaterialState& state, double dt) {
    int region = 0;
    (void)((m.model == Models::id ? (region = Models::plastic_correction(m, sigma, deps, state, dt), true) : false) ||
           ...);
    return region;
  }
};

using RegisteredModels = ModelSet<Elastic, MohrCoulomb, ModifiedCamClay>;

// The host descriptions of a list of models, in order; throws std::logic_error when two
// models share an id, or a description names another kernel or not as many history
// variables as its model keeps.
template <class... Models>
std::vector<ModelDescription> describe_models(ModelSet<Models...>) {
  std::vector<ModelDescription> v;
  std::set<int> ids;
  auto add = [&](int id, int history_count, std::vector<ModelDescription> ds) {
    if (!ids.insert(id).second) throw std::logic_error("models/ModelList.hpp: two models have id " + std::to_string(id));
    for (auto& d : ds) {
      if (d.kernel != id)
        throw std::logic_error("model '" + d.name + "': its description names kernel " + std::to_string(d.kernel) +
                               ", its id is " + std::to_string(id));
      if (static_cast<int>(d.history.size()) != history_count)
        throw std::logic_error("model '" + d.name + "': names " + std::to_string(d.history.size()) +
                               " history variables, keeps " + std::to_string(history_count));
      v.push_back(d);
    }
  };
  (add(Models::id, Models::history_count, Models::describe()), ...);
  return v;
}

}  // namespace tamp
