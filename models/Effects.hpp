// The effect catalogue: what an elastic-perfectly plastic Mohr-Coulomb / Tresca soil lacks,
// each a deck option of a material with 1-3 parameters, off by default (docs/effects.md).
//   (a) compaction of a porous soil: plastic volumetric strain when the mean pressure
//       exceeds a crush pressure that hardens with compaction, bounded by the air voids
//   (b) strain-rate dependence of the strength
//   (c) strength loss by remoulding with plastic shear strain
// Header-only, callable in kernels on every back end; composed with Mohr-Coulomb in
// update_stress (models/StressUpdate.hpp), so SPH and FEM share them.
#pragma once
#include "core/Material.hpp"

namespace tamp {

// (b) Rate factor: 1 + beta log10(gdot / gdot_ref) above the reference rate, 1 below
// (semi-logarithmic law, e.g. Einav & Randolph 2005, IJNME 63:1991; Biscontin & Pestana
// 2001 for vane tests). gdot is the engineering shear strain rate, 1/s.
KOKKOS_INLINE_FUNCTION double rate_factor(const MaterialParams& m, double gdot) {
  if (m.rate_coefficient <= 0 || !(gdot > m.reference_strain_rate)) return 1.0;
  return 1.0 + m.rate_coefficient * math::log(gdot / m.reference_strain_rate) / math::log(10.0);
}

// (c) Remoulding factor: delta + (1 - delta) exp(-3 eps_p / eps_95) (Einav & Randolph 2005):
// 1 when intact, delta when fully remoulded, 95 % of the loss at eps_p = eps_95.
KOKKOS_INLINE_FUNCTION double remoulding_factor(const MaterialParams& m, double plastic_strain) {
  if (m.remoulded_ratio >= 1.0) return 1.0;
  return m.remoulded_ratio + (1.0 - m.remoulded_ratio) * math::exp(-3.0 * plastic_strain / m.remoulding_strain);
}

// Engineering shear strain rate 2 sqrt(J2(D)) of an axisymmetric strain increment over dt.
KOKKOS_INLINE_FUNCTION double shear_strain_rate(const double deps[4], double dt) {
  if (!(dt > 0)) return 0.0;
  const double e = (deps[RR] + deps[ZZ] + deps[TT]) / 3.0;
  const double a = deps[RR] - e, b = deps[ZZ] - e, c = deps[TT] - e;
  const double j2 = 0.5 * (a * a + b * b + c * c) + deps[RZ] * deps[RZ];
  return 2.0 * math::sqrt(j2) / dt;
}

// (a) Compaction: a volumetric cap on the mean pressure p = -tr(sigma)/3 (compression
// positive). If p > p_c = p_c0 + H eps_v, the excess is returned by plastic volumetric
// compaction d eps_v = (p - p_c) / (K + H), at most the air voids left (n_a - eps_v);
// sigma_ii += K d eps_v. Returns d eps_v (>= 0); eps_v grows by it. The density follows
// from the kinematics (SPH continuity, FEM volume): the lost volume is the air expelled.
// A cap model in the spirit of the crushable-foam / P-alpha models (Herrmann 1969) with a
// linear crush curve; one surface, exact return for the linear hardening.
KOKKOS_INLINE_FUNCTION double compaction_return(const MaterialParams& m, double sigma[4], double& eps_v) {
  if (m.crush_pressure <= 0 || eps_v >= m.air_voids) return 0.0;
  const double p = -(sigma[RR] + sigma[ZZ] + sigma[TT]) / 3.0;
  // (eps_v < 0: a grain loosened below its placed density, kernels/SphSolid.hpp)
  const double pc = math::max(0.0, m.crush_pressure + m.crush_hardening * eps_v);
  if (p <= pc) return 0.0;
  double de = (p - pc) / (m.bulk_modulus + m.crush_hardening);
  if (de > m.air_voids - eps_v) de = m.air_voids - eps_v;
  const double dp = m.bulk_modulus * de;
  sigma[RR] += dp;
  sigma[ZZ] += dp;
  sigma[TT] += dp;
  eps_v += de;
  return de;
}

}  // namespace tamp
