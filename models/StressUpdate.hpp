// One constitutive step for a particle or element: Jaumann rotation, elastic predictor, then
// the plastic correction of its model (a dispatch on MaterialParams::model over a list of
// models, models/ModelList.hpp; no virtuals). Header-only, callable inside Kokkos kernels on
// every back end.
#pragma once
#include "core/Material.hpp"
#include "models/ModelList.hpp"

namespace tamp {

// sigma: stress (rr, zz, tt, rz), tension positive, updated in place.
// deps: tensor strain increments (rr, zz, tt, rz) over the step, deps[RZ] = 0.5 (du_r/dz +
// du_z/dr) dt. w_rz_dt: spin W_rz dt = 0.5 (dv_r/dz - dv_z/dr) dt.
// state: the particle's or element's MaterialState (core/Material.hpp), updated in place:
// plastic_strain, the accumulated equivalent plastic shear strain (see
// mohr_coulomb_equivalent_plastic_strain); compaction, the plastic volumetric strain,
// compression positive (effect (a) of Mohr-Coulomb; the hardening variable of Modified
// Cam-Clay); the model's own history slots.
// dt: the step, s (for the strain rate of effect (b); 0 = no rate effect).
// Returns the model's region code (MohrCoulombRegion for Mohr-Coulomb, 0 when elastic).
template <class Models = RegisteredModels>
KOKKOS_INLINE_FUNCTION int update_stress(const MaterialParams& m, double sigma[4], const double deps[4],
                                         double w_rz_dt, MaterialState& state, double dt) {
  jaumann_rotate(sigma, w_rz_dt);
  elastic_increment(m, sigma, deps);
  return Models::plastic_correction(m, sigma, deps, state, dt);
}

// The standard variables only (tests; models without history slots).
KOKKOS_INLINE_FUNCTION int update_stress(const MaterialParams& m, double sigma[4], const double deps[4],
                                         double w_rz_dt, double& plastic_strain, double& compaction,
                                         double dt) {
  MaterialState state;
  state.plastic_strain = plastic_strain;
  state.compaction = compaction;
  const int region = update_stress(m, sigma, deps, w_rz_dt, state, dt);
  plastic_strain = state.plastic_strain;
  compaction = state.compaction;
  return region;
}

// Without the effects' history (tests).
KOKKOS_INLINE_FUNCTION int update_stress(const MaterialParams& m, double sigma[4], const double deps[4],
                                         double w_rz_dt, double& plastic_strain) {
  double compaction = 0.0;
  return update_stress(m, sigma, deps, w_rz_dt, plastic_strain, compaction, 0.0);
}

}  // namespace tamp
