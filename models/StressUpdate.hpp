// One constitutive step for a particle: Jaumann rotation, elastic predictor, then the
// plastic correction of the material model (switch on MaterialParams::model, no virtuals).
// Header-only, callable inside Kokkos kernels on every back end.
#pragma once
#include "core/Material.hpp"
#include "models/Elastic.hpp"
#include "models/MohrCoulomb.hpp"

namespace tamp {

// sigma: stress (rr, zz, tt, rz), tension positive, updated in place.
// deps: tensor strain increments (rr, zz, tt, rz) over the step, deps[RZ] = 0.5 (du_r/dz +
// du_z/dr) dt. w_rz_dt: spin W_rz dt = 0.5 (dv_r/dz - dv_z/dr) dt.
// plastic_strain: accumulated equivalent plastic shear strain (see
// mohr_coulomb_equivalent_plastic_strain), incremented in place.
// Returns the MohrCoulombRegion (MC_ELASTIC for the elastic model).
KOKKOS_INLINE_FUNCTION int update_stress(const MaterialParams& m, double sigma[4],
                                         const double deps[4], double w_rz_dt,
                                         double& plastic_strain) {
  jaumann_rotate(sigma, w_rz_dt);
  elastic_increment(m, sigma, deps);
  int region = MC_ELASTIC;
  switch (m.model) {
    case MODEL_MOHR_COULOMB: {
      double dep = 0.0;
      region = mohr_coulomb_return(m, sigma, dep);
      plastic_strain += dep;
      break;
    }
    case MODEL_ELASTIC:
    default:
      break;
  }
  return region;
}

}  // namespace tamp
