// Elastic-perfectly plastic Mohr-Coulomb (Tresca when phi = 0) with the exact return
// mapping in principal stresses, plus a mean-stress tension cap. Tension positive.
// Header-only; every function is callable inside Kokkos kernels on every back end
// (plain fixed-size arrays, no exceptions, no I/O, no virtual calls).
//
// Sources: E. A. de Souza Neto, D. Peric, D. R. J. Owen, "Computational Methods for
// Plasticity", Wiley 2008, section 8.2, Boxes 8.4/8.5 (perfectly plastic case);
// J. Clausen, L. Damkilde, L. Andersen, "Efficient return algorithms for associated
// plasticity with multiple yield planes", IJNME 66 (2006) 1036-1059.
// Equations and region definitions: docs/models.md.
#pragma once
#include "core/Material.hpp"
#include "models/Effects.hpp"
#include "core/MaterialModel.hpp"

namespace tamp {

// Which part of the yield surface the return mapping went to.
enum MohrCoulombRegion : int {
  MC_ELASTIC = 0,     // trial state admissible, stress untouched
  MC_FACE = 1,        // main plane (s1, s3), s1 > s2 > s3 kept
  MC_EDGE_LEFT = 2,   // edge s1 = s2 (the two larger, i.e. less compressive, stresses
                      // equal: triaxial-compression-type state, e.g. axial most compressive)
  MC_EDGE_RIGHT = 3,  // edge s2 = s3 (the two smaller stresses equal: triaxial-extension-type)
  MC_APEX = 4,        // apex, isotropic stress c cot(phi) (phi > 0 only)
  MC_TENSION = 5,     // Mohr-Coulomb trial admissible, only the tension cap acted
};

// ---------------------------------------------------------------------------------------
// Principal values of an axisymmetric stress (rr, zz, tt, rz).
// The hoop stress tt is always principal; the in-plane pair comes from the 2x2 (rr, zz, rz)
// block: s = m +- R, m = (rr + zz)/2, R = sqrt(((rr - zz)/2)^2 + rz^2). The in-plane major
// direction makes the angle theta with the r axis: cos 2theta = (rr - zz)/(2R),
// sin 2theta = rz/R (theta = 0 when R = 0).
struct AxiPrincipal {
  double s[3];   // principal values sorted s[0] >= s[1] >= s[2]
  int slot[3];   // where s[k] came from: 0 in-plane major, 1 in-plane minor, 2 hoop
  double cos2t;  // cos(2 theta) of the in-plane major direction
  double sin2t;  // sin(2 theta)
};

KOKKOS_INLINE_FUNCTION void axi_principal_decompose(const double sigma[4], AxiPrincipal& pd) {
  const double mid = 0.5 * (sigma[RR] + sigma[ZZ]);
  const double d = 0.5 * (sigma[RR] - sigma[ZZ]);
  const double rz = sigma[RZ];
  const double R = math::sqrt(d * d + rz * rz);
  if (R > 0.0) {
    pd.cos2t = d / R;
    pd.sin2t = rz / R;
  } else {
    pd.cos2t = 1.0;
    pd.sin2t = 0.0;
  }
  const double a = mid + R;  // in-plane major
  const double b = mid - R;  // in-plane minor (a >= b always)
  const double t = sigma[TT];
  if (t > a) {
    pd.s[0] = t; pd.s[1] = a; pd.s[2] = b;
    pd.slot[0] = 2; pd.slot[1] = 0; pd.slot[2] = 1;
  } else if (t > b) {
    pd.s[0] = a; pd.s[1] = t; pd.s[2] = b;
    pd.slot[0] = 0; pd.slot[1] = 2; pd.slot[2] = 1;
  } else {
    pd.s[0] = a; pd.s[1] = b; pd.s[2] = t;
    pd.slot[0] = 0; pd.slot[1] = 1; pd.slot[2] = 2;
  }
}

// Rebuild (rr, zz, tt, rz) from new principal values s_new[k] (same ordering/slots as pd)
// with the unchanged principal directions of pd.
KOKKOS_INLINE_FUNCTION void axi_principal_reconstruct(const AxiPrincipal& pd,
                                                      const double s_new[3], double sigma[4]) {
  double v[3] = {0.0, 0.0, 0.0};
  for (int k = 0; k < 3; ++k) v[pd.slot[k]] = s_new[k];
  const double mid = 0.5 * (v[0] + v[1]);
  const double r = 0.5 * (v[0] - v[1]);
  sigma[RR] = mid + r * pd.cos2t;
  sigma[ZZ] = mid - r * pd.cos2t;
  sigma[RZ] = r * pd.sin2t;
  sigma[TT] = v[2];
}

// Sorted principal stresses s[0] >= s[1] >= s[2] of an axisymmetric stress.
KOKKOS_INLINE_FUNCTION void axi_principal_stresses(const double sigma[4], double s[3]) {
  AxiPrincipal pd;
  axi_principal_decompose(sigma, pd);
  s[0] = pd.s[0];
  s[1] = pd.s[1];
  s[2] = pd.s[2];
}

// ---------------------------------------------------------------------------------------
// Yield function f = (s1 - s3) + (s1 + s3) sin(phi) - 2 c cos(phi) on sorted principal values.
KOKKOS_INLINE_FUNCTION double mohr_coulomb_yield_principal(const MaterialParams& m,
                                                           const double s[3]) {
  return (s[0] - s[2]) + (s[0] + s[2]) * math::sin(m.phi) -
         2.0 * m.cohesion * math::cos(m.phi);
}

// f on an axisymmetric stress (principal values computed and sorted first).
KOKKOS_INLINE_FUNCTION double mohr_coulomb_yield(const MaterialParams& m, const double sigma[4]) {
  double s[3];
  axi_principal_stresses(sigma, s);
  return mohr_coulomb_yield_principal(m, s);
}

// Largest admissible mean stress: T = min(tension_cutoff, c cot(phi)) (phi > 0),
// T = tension_cutoff (phi = 0).
KOKKOS_INLINE_FUNCTION double mohr_coulomb_tension_limit(const MaterialParams& m) {
  double T = m.tension_cutoff;
  const double sphi = math::sin(m.phi);
  if (sphi > 0.0) T = math::min(T, m.cohesion * math::cos(m.phi) / sphi);
  return T;
}

// Mohr-Coulomb part of the return on sorted principal values s[0] >= s[1] >= s[2]
// (overwritten in place, the result is again sorted), without the tension cap. Returns
// MC_ELASTIC (s untouched), MC_FACE, MC_EDGE_LEFT, MC_EDGE_RIGHT or MC_APEX.
KOKKOS_INLINE_FUNCTION int mohr_coulomb_surface_return(const MaterialParams& m, double s[3]) {
  const double K = m.bulk_modulus;
  const double G = m.shear_modulus;
  const double sphi = math::sin(m.phi);
  const double cphi = math::cos(m.phi);
  const double spsi = math::sin(m.psi);
  const double two_c_cos = 2.0 * m.cohesion * cphi;

  int region = MC_ELASTIC;
  // Same expression as mohr_coulomb_yield, so callers see the same elastic/plastic decision.
  const double f = mohr_coulomb_yield_principal(m, s);
  if (f > 0.0) {
    // Elastic image D n of a plane potential gradient n; D = (K - 2G/3) 1x1 + 2G I, and
    // every gradient here has trace 2 sin(psi).
    const double lv = (K - 2.0 * G / 3.0) * 2.0 * spsi;
    const double up = 2.0 * G * (1.0 + spsi);  // 2G times the +(1 + sin psi) entry
    const double dn = 2.0 * G * (1.0 - spsi);  // 2G times the -(1 - sin psi) entry
    // Main plane: n_a = (1 + sin psi, 0, -(1 - sin psi)); D n_a = (lv + up, lv, lv - dn).
    const double A = 4.0 * G * (1.0 + sphi * spsi / 3.0) + 4.0 * K * sphi * spsi;
    const double dg = f / A;
    double t0 = s[0] - dg * (lv + up);
    double t1 = s[1] - dg * lv;
    double t2 = s[2] - dg * (lv - dn);
    if (t0 >= t1 && t1 >= t2) {
      region = MC_FACE;
    } else {
      // Edge return: two planes active. The ray of the face return leaves the sextant first
      // through s2 = s3 (right) when (1 - sin psi) s1 - 2 s2 + (1 + sin psi) s3 > 0.
      const bool right = (1.0 - spsi) * s[0] - 2.0 * s[1] + (1.0 + spsi) * s[2] > 0.0;
      double fb, B;
      double Dnb[3];
      if (right) {
        // Plane b: (s1, s2) pair. n_b = (1 + sin psi, -(1 - sin psi), 0).
        fb = (s[0] - s[1]) + (s[0] + s[1]) * sphi - two_c_cos;
        B = 2.0 * G * (1.0 + sphi + spsi - sphi * spsi / 3.0) + 4.0 * K * sphi * spsi;
        Dnb[0] = lv + up; Dnb[1] = lv - dn; Dnb[2] = lv;
      } else {
        // Plane b: (s2, s3) pair. n_b = (0, 1 + sin psi, -(1 - sin psi)).
        fb = (s[1] - s[2]) + (s[1] + s[2]) * sphi - two_c_cos;
        B = 2.0 * G * (1.0 - sphi - spsi - sphi * spsi / 3.0) + 4.0 * K * sphi * spsi;
        Dnb[0] = lv; Dnb[1] = lv + up; Dnb[2] = lv - dn;
      }
      // [A B; B A] (dga, dgb) = (f, fb); det = (A - B)(A + B) > 0 for phi, psi < 90 deg.
      const double det = A * A - B * B;
      const double dga = (A * f - B * fb) / det;
      const double dgb = (A * fb - B * f) / det;
      t0 = s[0] - dga * (lv + up) - dgb * Dnb[0];
      t1 = s[1] - dga * lv - dgb * Dnb[1];
      t2 = s[2] - dga * (lv - dn) - dgb * Dnb[2];
      // The two equal values are equal analytically; remove the round-off difference.
      if (right) {
        t1 = t2 = 0.5 * (t1 + t2);
      } else {
        t0 = t1 = 0.5 * (t0 + t1);
      }
      region = right ? MC_EDGE_RIGHT : MC_EDGE_LEFT;
      // Past the apex the edge solution has s1 < s3: return to the apex instead.
      if (sphi > 0.0 && t0 < t2) {
        t0 = t1 = t2 = m.cohesion * cphi / sphi;
        region = MC_APEX;
      } else if (t0 < t2) {
        // Tresca with c = 0: the edge solution is isotropic up to round-off.
        t0 = t1 = t2 = (t0 + t1 + t2) / 3.0;
      }
    }
    s[0] = t0;
    s[1] = t1;
    s[2] = t2;
  }
  return region;
}

// Tension cap on principal values: if the mean exceeds T = mohr_coulomb_tension_limit(m),
// shift all three down equally so that the mean equals T. Returns true if it acted.
KOKKOS_INLINE_FUNCTION bool mohr_coulomb_tension_cap(const MaterialParams& m, double s[3]) {
  // Shifting all principal values equally keeps s1 - s3 and lowers s1 + s3, so a state on
  // or inside the Mohr-Coulomb surface stays inside it.
  const double T = mohr_coulomb_tension_limit(m);
  const double mean = (s[0] + s[1] + s[2]) / 3.0;
  if (mean > T) {
    const double shift = mean - T;
    s[0] -= shift;
    s[1] -= shift;
    s[2] -= shift;
    return true;
  }
  return false;
}

// Full return on sorted principal values (overwritten in place): the Mohr-Coulomb return
// (face / edge / apex), then the tension cap. Returns the MohrCoulombRegion: the surface
// region if the Mohr-Coulomb return acted (whether or not the cap acted too), MC_TENSION if
// only the cap acted, MC_ELASTIC (s untouched) if neither did.
KOKKOS_INLINE_FUNCTION int mohr_coulomb_return_principal(const MaterialParams& m, double s[3]) {
  int region = mohr_coulomb_surface_return(m, s);
  if (mohr_coulomb_tension_cap(m, s) && region == MC_ELASTIC) region = MC_TENSION;
  return region;
}

// Equivalent plastic shear strain increment of a return from principal trial values s_tr to
// s (same principal directions): the plastic strain increment is D^-1 (s_tr - s); its
// deviatoric part is e_p = dev(s_tr - s) / (2G), and the value returned is the von Mises
// equivalent sqrt(2/3 e_p : e_p). The tension cap shifts all principal stresses equally,
// i.e. it is purely volumetric, and adds nothing.
KOKKOS_INLINE_FUNCTION double mohr_coulomb_equivalent_plastic_strain(const MaterialParams& m,
                                                                     const double s_tr[3],
                                                                     const double s[3]) {
  if (!(m.shear_modulus > 0.0)) return 0.0;
  const double d0 = s_tr[0] - s[0];
  const double d1 = s_tr[1] - s[1];
  const double d2 = s_tr[2] - s[2];
  const double mean = (d0 + d1 + d2) / 3.0;
  const double e0 = d0 - mean;
  const double e1 = d1 - mean;
  const double e2 = d2 - mean;
  return math::sqrt(2.0 / 3.0 * (e0 * e0 + e1 * e1 + e2 * e2)) / (2.0 * m.shear_modulus);
}

// Return mapping of an axisymmetric trial stress (rr, zz, tt, rz), in place. Principal
// directions are kept; the hoop value stays the hoop stress. Sets
// plastic_strain_increment = mohr_coulomb_equivalent_plastic_strain (0 when elastic) and
// returns the MohrCoulombRegion. For MC_ELASTIC sigma is not touched (bit for bit).
KOKKOS_INLINE_FUNCTION int mohr_coulomb_return(const MaterialParams& m, double sigma[4],
                                               double& plastic_strain_increment) {
  plastic_strain_increment = 0.0;
  AxiPrincipal pd;
  axi_principal_decompose(sigma, pd);
  double s[3] = {pd.s[0], pd.s[1], pd.s[2]};
  int region = mohr_coulomb_surface_return(m, s);
  // The cap is purely volumetric: the equivalent (deviatoric) plastic strain comes from the
  // Mohr-Coulomb part alone (computing it after the cap would only add round-off).
  if (region != MC_ELASTIC)
    plastic_strain_increment = mohr_coulomb_equivalent_plastic_strain(m, pd.s, s);
  if (mohr_coulomb_tension_cap(m, s) && region == MC_ELASTIC) region = MC_TENSION;
  if (region == MC_ELASTIC) return region;
  axi_principal_reconstruct(pd, s, sigma);
  return region;
}

// ---------------------------------------------------------------------------------------
// The model: Mohr-Coulomb with the effects of models/Effects.hpp composed by operator split:
// the strength c is scaled by the rate and remoulding factors of this step, the compaction
// cap acts on the mean pressure first, then the Mohr-Coulomb return. Deck names
// "mohr-coulomb" (c, phi, psi) and "tresca" (Su; phi = psi = 0).
struct MohrCoulomb {
  static constexpr int id = MODEL_MOHR_COULOMB;
  static constexpr int history_count = 0;  // the standard plastic_strain and compaction only
  KOKKOS_INLINE_FUNCTION static int plastic_correction(const MaterialParams& m, double sigma[4],
                                                       const double deps[4], MaterialState& state, double dt) {
    double& plastic_strain = state.plastic_strain;
    compaction_return(m, sigma, state.compaction);
    double dep = 0.0;
    int region;
    if (m.rate_coefficient > 0 || m.remoulded_ratio < 1.0) {
      MaterialParams mm = m;
      mm.cohesion = m.cohesion * rate_factor(m, shear_strain_rate(deps, dt)) * remoulding_factor(m, plastic_strain);
      region = mohr_coulomb_return(mm, sigma, dep);
    } else {
      region = mohr_coulomb_return(m, sigma, dep);
    }
    plastic_strain += dep;
    return region;
  }

  static std::vector<ModelDescription> describe() {
    using namespace ranges;
    const ModelKey tension{"tension_cutoff", "Pa", ge(0), 0.0, "largest mean stress (tension positive)",
                           &MaterialSpec::tension_cutoff};
    const std::vector<std::string> state = {"plastic_strain", "compaction"};
    ModelDescription mc;
    mc.name = "mohr-coulomb";
    mc.kernel = id;
    mc.summary = "elastic-perfectly plastic Mohr-Coulomb, exact principal-stress return";
    mc.keys = {{"c", "Pa", ge(0), 0.0, "cohesion", &MaterialSpec::cohesion},
               {"phi_deg", "deg", ge_lt(0, 90), 0.0, "friction angle", &MaterialSpec::phi_deg},
               {"psi_deg", "deg", ge(0), 0.0, "dilation angle", &MaterialSpec::psi_deg, false},
               tension};
    mc.effects = true;
    mc.state = state;
    mc.rule = [](const MaterialSpec& s) -> std::optional<RuleBreak> {
      if (s.psi_deg > s.phi_deg)
        return RuleBreak{"psi_deg", "is out of range", "0 <= psi_deg <= phi_deg (= " + fmt_num(s.phi_deg) + ") (deg)"};
      return std::nullopt;
    };
    mc.to_params = [](const MaterialSpec& s, MaterialParams& m) {
      m.cohesion = s.cohesion;
      m.phi = s.phi_deg * pi / 180.0;
      m.psi = s.psi_deg * pi / 180.0;
      m.tension_cutoff = s.tension_cutoff;
    };
    ModelDescription tr;
    tr.name = "tresca";
    tr.kernel = id;
    tr.summary = "Tresca (undrained, Mohr-Coulomb with phi = 0)";
    tr.keys = {{"Su", "Pa", gt(0), std::nullopt, "undrained shear strength", &MaterialSpec::cohesion}, tension};
    tr.effects = true;
    tr.state = state;
    tr.to_params = [](const MaterialSpec& s, MaterialParams& m) {
      m.cohesion = s.cohesion;
      m.phi = 0.0;
      m.psi = 0.0;
      m.tension_cutoff = s.tension_cutoff;
    };
    return {mc, tr};
  }
};

}  // namespace tamp
