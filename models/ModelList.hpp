// The registered constitutive models: one line each in TAMP_MATERIAL_MODELS, beside the
// include of the model's header. Each model is a struct with
//   static constexpr int id;                                   (its MaterialParams::model)
//   KOKKOS_INLINE_FUNCTION static int plastic_correction(params, sigma, deps,
//       plastic_strain, compaction, dt);                       (device, after the elastic predictor)
//   static std::vector<ModelDescription> describe();           (host: deck names and keys)
// The device dispatch (models/StressUpdate.hpp) and the host registry (models/ModelList.cpp)
// are generated from this list. Checklist: docs/architecture.md "Add a constitutive model".
#pragma once
#include "models/Elastic.hpp"
#include "models/MohrCoulomb.hpp"
#include "models/ModifiedCamClay.hpp"

#define TAMP_MATERIAL_MODELS(X) \
  X(Elastic)                    \
  X(MohrCoulomb)                \
  X(ModifiedCamClay)
