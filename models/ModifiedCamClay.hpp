// Modified Cam-Clay (Roscoe & Burland 1968), the critical-state model Solowski et al. used
// for the soft soil of their MPM study of dynamic replacement columns (the reference
// paper's ref. 8). Elliptical yield surface in (p, q), associated flow, exponential
// volumetric hardening; linear elasticity (K and G from the deck's G and nu), so that the
// stable time step stays that of the elastic wave speed. Implicit (backward-Euler) closest-
// point return in (p, q), solved by Newton's method on (p, p_c, dgamma). Header-only; the
// device part is callable in kernels on every back end. Equations, sources and the
// verification: docs/modified-cam-clay.md.
//
// Signs: sigma tension positive (as everywhere in Tamp); p = -tr(sigma)/3 (compression
// positive), q = sqrt(3/2 s:s); the hardening variable is the plastic volumetric strain
// eps_v^p (compression positive), kept in the particle's / element's `compaction` field,
// and the equivalent plastic shear strain eps_q^p is added to `plastic_strain`.
//
//   f(p, q, p_c) = q^2 / M^2 + p (p - p_c) <= 0
//   p_c = p_c0 exp(theta eps_v^p),  theta = v0 / (lambda - kappa)
//   d eps_v^p = dgamma df/dp = dgamma (2p - p_c),  d eps_q^p = dgamma df/dq = dgamma 2q / M^2
#pragma once
#include "core/Material.hpp"
#include "core/MaterialModel.hpp"

namespace tamp {

struct ModifiedCamClay {
  static constexpr int id = 2;
  static constexpr int history_count = 0;  // the standard compaction is its hardening variable
  // Slots of MaterialParams::model_param.
  enum Slot : int { LAMBDA = 0, KAPPA = 1, M_CS = 2, PC0 = 3, V0 = 4 };

  KOKKOS_INLINE_FUNCTION static double yield(double p, double q, double pc, double M) {
    return q * q / (M * M) + p * (p - pc);
  }

  // The plastic volumetric strain increment x of a return with multiplier dgamma: the root
  // of g(x) = x - dgamma (2 p(x) - pc(x)), p = p_tr - K x, pc = pc_n exp(theta x). g is
  // increasing and convex with a root in [lo, hi]: g >= 0 at x = max(0, 2 dgamma p_tr / (1 +
  // 2 K dgamma)) (drop the exponential term) and at x = max(0, ln(2 p_tr / pc_n) / theta)
  // (the exponential term alone outweighs 2 dgamma p_tr), so hi is the smaller of the two;
  // lo follows from capping the exponential at its value at hi. Newton's method kept inside
  // the bracket (bisection when it would leave it).
  KOKKOS_INLINE_FUNCTION static double volumetric_increment(double K, double theta, double p_tr, double pc_n,
                                                            double dgamma) {
    const double den = 1.0 + 2.0 * K * dgamma;
    double hi = math::max(2.0 * dgamma * p_tr / den, 0.0);
    if (p_tr > 0.0) hi = math::min(hi, math::max(0.0, math::log(2.0 * p_tr / pc_n) / theta));
    double lo = 2.0 * dgamma * p_tr / den - dgamma * pc_n * math::exp(theta * hi) / den;
    double x = hi;
    for (int it = 0; it < 200; ++it) {
      const double e = pc_n * math::exp(theta * x);
      const double g = x - dgamma * (2.0 * (p_tr - K * x) - e);
      if (g > 0.0) hi = x; else lo = x;
      const double dg = 1.0 + dgamma * (2.0 * K + theta * e);
      double xn = x - g / dg;
      if (!(xn > lo && xn < hi)) xn = 0.5 * (lo + hi);
      if (math::abs(xn - x) <= 1e-16 * (math::abs(x) + 1e-300) || hi - lo <= 1e-16 * math::abs(hi)) return xn;
      x = xn;
    }
    return x;
  }

  // Return of the trial state (p_tr, q_tr) with preconsolidation pc_n before the step.
  // Out: p, q, pc, dgamma. Newton's method on (p, pc, dgamma) first (a few iterations from
  // the trial state in the usual case); if it fails or leaves the admissible set (dgamma < 0,
  // p < 0), the scalar equation f(dgamma) = 0 with p, pc from volumetric_increment, solved
  // by bracketing and the Illinois (modified regula falsi) method, which always converges:
  // f(0) > 0 and f -> -p^2 < 0 for large dgamma. Returns false only if that fails too.
  KOKKOS_INLINE_FUNCTION static bool return_pq(double K, double G, double M, double theta, double p_tr,
                                               double q_tr, double pc_n, double& p, double& q, double& pc,
                                               double& dgamma) {
    const double a = 6.0 * G / (M * M);
    const double scale = pc_n * pc_n;
    p = p_tr;
    pc = pc_n;
    dgamma = 0.0;
    q = q_tr;
    for (int it = 0; it < 30; ++it) {
      const double den = 1.0 + a * dgamma;
      q = q_tr / den;
      const double dq = -a * q_tr / (den * den);
      const double dev = dgamma * (2.0 * p - pc);  // plastic volumetric strain increment
      const double E = pc_n * math::exp(theta * dev);
      const double r1 = p - p_tr + K * dev;
      const double r2 = pc - E;
      const double r3 = yield(p, q, pc, M);
      if (it > 0 && math::abs(r3) <= 1e-14 * scale && math::abs(r1) <= 1e-14 * pc_n && math::abs(r2) <= 1e-14 * pc_n) {
        if (dgamma >= 0.0 && p >= 0.0 && pc > 0.0) return true;
        break;
      }
      // Jacobian d(r1, r2, r3)/d(p, pc, dgamma)
      const double J11 = 1.0 + 2.0 * K * dgamma, J12 = -K * dgamma, J13 = K * (2.0 * p - pc);
      const double J21 = -E * theta * 2.0 * dgamma, J22 = 1.0 + E * theta * dgamma, J23 = -E * theta * (2.0 * p - pc);
      const double J31 = 2.0 * p - pc, J32 = -p, J33 = 2.0 * q * dq / (M * M);
      const double det = J11 * (J22 * J33 - J23 * J32) - J12 * (J21 * J33 - J23 * J31) + J13 * (J21 * J32 - J22 * J31);
      if (!(math::abs(det) > 0.0)) break;
      // Cramer's rule for J d = -r
      const double b1 = -r1, b2 = -r2, b3 = -r3;
      const double d1 = (b1 * (J22 * J33 - J23 * J32) - J12 * (b2 * J33 - J23 * b3) + J13 * (b2 * J32 - J22 * b3)) / det;
      const double d2 = (J11 * (b2 * J33 - J23 * b3) - b1 * (J21 * J33 - J23 * J31) + J13 * (J21 * b3 - b2 * J31)) / det;
      const double d3 = (J11 * (J22 * b3 - b2 * J32) - J12 * (J21 * b3 - b2 * J31) + b1 * (J21 * J32 - J22 * J31)) / det;
      p += d1;
      pc += d2;
      dgamma += d3;
      if (!(math::abs(p) < 1e30 * pc_n)) break;
    }
    // The robust path: f(dgamma) with p, pc, q from dgamma.
    auto f_of = [&](double dg, double& p_, double& q_, double& pc_) {
      const double x = volumetric_increment(K, theta, p_tr, pc_n, dg);
      p_ = p_tr - K * x;
      pc_ = pc_n * math::exp(theta * x);
      q_ = q_tr / (1.0 + a * dg);
      return yield(p_, q_, pc_, M);
    };
    double lo = 0.0, f_lo = yield(p_tr, q_tr, pc_n, M);
    double hi = 1.0 / (K + G), f_hi = f_of(hi, p, q, pc);
    for (int k = 0; k < 200 && f_hi > 0.0; ++k) {
      lo = hi;
      f_lo = f_hi;
      hi *= 4.0;
      f_hi = f_of(hi, p, q, pc);
    }
    if (!(f_hi <= 0.0) || !(f_lo > 0.0)) return false;
    int side = 0;
    for (int it = 0; it < 300; ++it) {
      double dg = (lo * f_hi - hi * f_lo) / (f_hi - f_lo);
      if (!(dg > lo && dg < hi)) dg = 0.5 * (lo + hi);
      const double f = f_of(dg, p, q, pc);
      dgamma = dg;
      if (math::abs(f) <= 1e-14 * pc * pc) return true;
      if (hi - lo <= 1e-15 * hi) return math::abs(f) <= 1e-10 * pc * pc;
      if (f > 0.0) {
        lo = dg;
        f_lo = f;
        if (side == +1) f_hi *= 0.5;
        side = +1;
      } else {
        hi = dg;
        f_hi = f;
        if (side == -1) f_lo *= 0.5;
        side = -1;
      }
    }
    return false;
  }

  KOKKOS_INLINE_FUNCTION static int plastic_correction(const MaterialParams& m, double sigma[4], const double[4],
                                                       MaterialState& state, double) {
    double& plastic_strain = state.plastic_strain;
    double& compaction = state.compaction;
    const double M = m.model_param[M_CS];
    const double theta = m.model_param[V0] / (m.model_param[LAMBDA] - m.model_param[KAPPA]);
    const double pc_n = m.model_param[PC0] * math::exp(theta * compaction);
    const double p_tr = -(sigma[RR] + sigma[ZZ] + sigma[TT]) / 3.0;
    const double s_rr = sigma[RR] + p_tr, s_zz = sigma[ZZ] + p_tr, s_tt = sigma[TT] + p_tr, s_rz = sigma[RZ];
    const double q_tr = math::sqrt(1.5 * (s_rr * s_rr + s_zz * s_zz + s_tt * s_tt + 2.0 * s_rz * s_rz));
    if (!(yield(p_tr, q_tr, pc_n, M) > 0.0)) return 0;
    double p, q, pc, dgamma;
    if (!return_pq(m.bulk_modulus, m.shear_modulus, M, theta, p_tr, q_tr, pc_n, p, q, pc, dgamma)) return 0;
    const double ratio = q_tr > 0.0 ? q / q_tr : 0.0;
    sigma[RR] = s_rr * ratio - p;
    sigma[ZZ] = s_zz * ratio - p;
    sigma[TT] = s_tt * ratio - p;
    sigma[RZ] = s_rz * ratio;
    compaction += dgamma * (2.0 * p - pc);
    plastic_strain += dgamma * 2.0 * q / (M * M);
    return 1;
  }

  static std::vector<ModelDescription> describe() {
    using namespace ranges;
    ModelDescription d;
    d.name = "modified-cam-clay";
    d.kernel = id;
    d.summary = "Modified Cam-Clay: elliptical yield surface, associated flow, volumetric hardening";
    // model_params keys (no MaterialSpec members: stored in MaterialSpec::params)
    d.keys = {{"lambda", "", gt(0), std::nullopt, "slope of the normal compression line in v - ln p"},
              {"kappa", "", gt(0), std::nullopt, "slope of the swelling line (plastic compressibility lambda - kappa)"},
              {"M", "", gt_lt(0, 3), std::nullopt, "slope of the critical state line in p - q"},
              {"p_c0", "Pa", gt(0), std::nullopt, "initial preconsolidation pressure"},
              {"v0", "", gt(1), std::nullopt, "initial specific volume 1 + e0", nullptr, false}};
    d.state = {"plastic_strain", "compaction"};
    d.rule = [](const MaterialSpec& s) -> std::optional<RuleBreak> {
      const double lambda = model_param(s, "lambda"), kappa = model_param(s, "kappa");
      if (!(kappa < lambda)) return RuleBreak{"kappa", "is out of range", "0 < kappa < lambda (= " + fmt_num(lambda) + ")"};
      return std::nullopt;
    };
    d.to_params = [](const MaterialSpec& s, MaterialParams& m) {
      m.model_param[LAMBDA] = model_param(s, "lambda");
      m.model_param[KAPPA] = model_param(s, "kappa");
      m.model_param[M_CS] = model_param(s, "M");
      m.model_param[PC0] = model_param(s, "p_c0");
      m.model_param[V0] = model_param(s, "v0");
    };
    return {d};
  }
};

}  // namespace tamp
