// One constitutive step for a particle or element: Jaumann rotation, elastic predictor, then
// the plastic correction of its model (a switch on MaterialParams::model over the models
// of models/ModelList.hpp, no virtuals). Header-only, callable inside Kokkos kernels on
// every back end.
#pragma once
#include "core/Material.hpp"
#include "models/ModelList.hpp"

namespace tamp {

// sigma: stress (rr, zz, tt, rz), tension positive, updated in place.
// deps: tensor strain increments (rr, zz, tt, rz) over the step, deps[RZ] = 0.5 (du_r/dz +
// du_z/dr) dt. w_rz_dt: spin W_rz dt = 0.5 (dv_r/dz - dv_z/dr) dt.
// plastic_strain: accumulated equivalent plastic shear strain (see
// mohr_coulomb_equivalent_plastic_strain), incremented in place.
// compaction: plastic volumetric (compaction) strain, compression positive, incremented in
// place (effect (a) of Mohr-Coulomb; the hardening variable of Modified Cam-Clay).
// dt: the step, s (for the strain rate of effect (b); 0 = no rate effect).
// Returns the model's region code (MohrCoulombRegion for Mohr-Coulomb, 0 when elastic).
KOKKOS_INLINE_FUNCTION int update_stress(const MaterialParams& m, double sigma[4],
                                         const double deps[4], double w_rz_dt,
                                         double& plastic_strain, double& compaction, double dt) {
  jaumann_rotate(sigma, w_rz_dt);
  elastic_increment(m, sigma, deps);
  switch (m.model) {
#define TAMP_MODEL_CASE(Model) \
  case Model::id:              \
    return Model::plastic_correction(m, sigma, deps, plastic_strain, compaction, dt);
    TAMP_MATERIAL_MODELS(TAMP_MODEL_CASE)
#undef TAMP_MODEL_CASE
    default:
      return 0;
  }
}

// Without the effects' history (tests, models without compaction storage).
KOKKOS_INLINE_FUNCTION int update_stress(const MaterialParams& m, double sigma[4],
                                         const double deps[4], double w_rz_dt,
                                         double& plastic_strain) {
  double compaction = 0.0;
  return update_stress(m, sigma, deps, w_rz_dt, plastic_strain, compaction, 0.0);
}

}  // namespace tamp
