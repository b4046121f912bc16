// Linear (hypo-)elastic stress increment and the Jaumann co-rotational correction for
// the axisymmetric stress state (rr, zz, tt, rz), tension positive. Header-only, callable
// inside Kokkos kernels on every back end. Equations: docs/models.md.
#pragma once
#include "core/Material.hpp"
#include "core/MaterialModel.hpp"

namespace tamp {

// sigma += K tr(deps) I + 2G dev(deps).
// deps holds TENSOR strain increments (rr, zz, tt, rz); the shear entry is
// deps[RZ] = 0.5 (du_r/dz + du_z/dr) dt (half the engineering shear strain).
KOKKOS_INLINE_FUNCTION void elastic_increment(const MaterialParams& m, double sigma[4],
                                              const double deps[4]) {
  const double K = m.bulk_modulus;
  const double G2 = 2.0 * m.shear_modulus;
  const double tr = deps[RR] + deps[ZZ] + deps[TT];
  const double third = tr / 3.0;
  const double vol = K * tr;
  sigma[RR] += vol + G2 * (deps[RR] - third);
  sigma[ZZ] += vol + G2 * (deps[ZZ] - third);
  sigma[TT] += vol + G2 * (deps[TT] - third);
  sigma[RZ] += G2 * deps[RZ];
}

// Jaumann rotation: sigma += (W sigma - sigma W) dt with the only non-zero spin component
// W_rz = -W_zr = 0.5 (dv_r/dz - dv_z/dr); w_rz_dt = W_rz dt. The hoop direction does not
// rotate in axisymmetry, so sigma_tt is unchanged. All increments use the old values.
KOKKOS_INLINE_FUNCTION void jaumann_rotate(double sigma[4], double w_rz_dt) {
  const double srr = sigma[RR];
  const double szz = sigma[ZZ];
  const double srz = sigma[RZ];
  const double d_normal = 2.0 * w_rz_dt * srz;
  sigma[RR] = srr + d_normal;
  sigma[ZZ] = szz - d_normal;
  sigma[RZ] = srz + w_rz_dt * (szz - srr);
}

// The model: no plastic correction after the elastic predictor.
struct Elastic {
  static constexpr int id = MODEL_ELASTIC;
  static constexpr int history_count = 0;
  KOKKOS_INLINE_FUNCTION static int plastic_correction(const MaterialParams&, double[4], const double[4],
                                                       MaterialState&, double) {
    return 0;
  }
  static std::vector<ModelDescription> describe() {
    ModelDescription d;
    d.name = "elastic";
    d.kernel = id;
    d.summary = "linear (hypo-)elastic, Jaumann stress rate";
    d.to_params = [](const MaterialSpec&, MaterialParams&) {};
    return {d};
  }
};

}  // namespace tamp
