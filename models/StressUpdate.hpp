// One constitutive step for a particle: Jaumann rotation, elastic predictor, then the
// plastic correction of the material model (switch on MaterialParams::model, no virtuals).
// Header-only, callable inside Kokkos kernels on every back end.
#pragma once
#include "core/Material.hpp"
#include "models/Elastic.hpp"
#include "models/Effects.hpp"
#include "models/MohrCoulomb.hpp"

namespace tamp {

// sigma: stress (rr, zz, tt, rz), tension positive, updated in place.
// deps: tensor strain increments (rr, zz, tt, rz) over the step, deps[RZ] = 0.5 (du_r/dz +
// du_z/dr) dt. w_rz_dt: spin W_rz dt = 0.5 (dv_r/dz - dv_z/dr) dt.
// plastic_strain: accumulated equivalent plastic shear strain (see
// mohr_coulomb_equivalent_plastic_strain), incremented in place.
// compaction: plastic volumetric (compaction) strain of effect (a), incremented in place.
// dt: the step, s (for the strain rate of effect (b); 0 = no rate effect).
// Returns the MohrCoulombRegion (MC_ELASTIC for the elastic model).
// Effects (models/Effects.hpp) compose by operator split: the strength c is scaled by the
// rate and remoulding factors of this step, the compaction cap acts on the mean pressure
// first, then the Mohr-Coulomb return.
KOKKOS_INLINE_FUNCTION int update_stress(const MaterialParams& m, double sigma[4],
                                         const double deps[4], double w_rz_dt,
                                         double& plastic_strain, double& compaction, double dt) {
  jaumann_rotate(sigma, w_rz_dt);
  elastic_increment(m, sigma, deps);
  int region = MC_ELASTIC;
  switch (m.model) {
    case MODEL_MOHR_COULOMB: {
      compaction_return(m, sigma, compaction);
      double dep = 0.0;
      if (m.rate_coefficient > 0 || m.remoulded_ratio < 1.0) {
        MaterialParams mm = m;
        mm.cohesion = m.cohesion * rate_factor(m, shear_strain_rate(deps, dt)) * remoulding_factor(m, plastic_strain);
        region = mohr_coulomb_return(mm, sigma, dep);
      } else {
        region = mohr_coulomb_return(m, sigma, dep);
      }
      plastic_strain += dep;
      break;
    }
    case MODEL_ELASTIC:
    default:
      break;
  }
  return region;
}

// Without the effects' history (tests, models without compaction storage).
KOKKOS_INLINE_FUNCTION int update_stress(const MaterialParams& m, double sigma[4],
                                         const double deps[4], double w_rz_dt,
                                         double& plastic_strain) {
  double compaction = 0.0;
  return update_stress(m, sigma, deps, w_rz_dt, plastic_strain, compaction, 0.0);
}

}  // namespace tamp
