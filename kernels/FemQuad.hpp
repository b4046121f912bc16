// Axisymmetric 4-node quadrilateral, explicit (central difference), one-point (mean)
// quadrature with Flanagan-Belytschko hourglass control. Header-only; every kernel is a
// functor, callable on every back end. Equations, choices and verification: docs/fem.md.
//
// Conventions: coordinates (r, z), r >= 0; stress (rr, zz, tt, rz), tension positive;
// element nodes counter-clockwise in the (r, z) plane (r to the right, z up). Every
// nodal quantity is that of a ring of revolution: masses in kg, forces in N (the whole
// ring), element volumes are ring volumes (m3).
#pragma once
#include <Kokkos_Core.hpp>
#include <Kokkos_ScatterView.hpp>
#include <utility>

#include "core/Material.hpp"
#include "core/Types.hpp"
#include "models/StressUpdate.hpp"

namespace tamp::fem {

// Nodal boundary flags: the r and/or z velocity component is prescribed (FemMesh::v_bc).
enum NodeBc : int { BC_NONE = 0, BC_R = 1, BC_Z = 2 };

enum HourglassForm : int {
  HOURGLASS_VISCOUS = 0,    // force proportional to the hourglass velocity (LS-DYNA IHQ 2-like)
  HOURGLASS_STIFFNESS = 1,  // incremental elastic hourglass force (LS-DYNA IHQ 4-like)
};

// Race-free nodal assembly. ForceScatter: Kokkos' default, duplicated per thread on the host
// back ends, atomic on GPUs. AtomicForceScatter: atomic everywhere (FemOptions::assembly;
// measured against each other in perf/bench_fem.cpp, perf/RESULTS.md).
using ForceScatter =
    decltype(Kokkos::Experimental::create_scatter_view(std::declval<ViewN<double, 2>>()));
using AtomicForceScatter = decltype(Kokkos::Experimental::create_scatter_view(
    Kokkos::Experimental::ScatterSum{}, Kokkos::Experimental::ScatterNonDuplicated{},
    Kokkos::Experimental::ScatterAtomic{}, std::declval<ViewN<double, 2>>()));

// The mesh and its state, all in device views.
struct FemMesh {
  int n_nodes = 0, n_elements = 0;
  // nodes
  ViewN<double, 2> x;       // current coordinates (r, z), m
  ViewN<double, 2> x0;      // reference coordinates, m
  ViewN<double, 2> v;       // velocity at the last half step, m/s
  ViewN<double, 2> f_int;   // internal force (stress divergence + hourglass), N
  ViewN<double, 2> f_ext;   // applied external force (set by the user), N
  ViewN<double, 2> f_tie;   // force from tied particles (SPH-FEM tie, kernels/solver/Simulation.cpp), N
  ViewN<double, 2> v_bc;    // prescribed velocity of the flagged components, m/s
  View1<double> mass;       // lumped ring mass, kg
  View1<int> bc;            // NodeBc flags
  // Non-reflecting (viscous-spring) boundary nodes, per component r, z; zero elsewhere:
  ViewN<double, 2> dashpot;  // C = rho c A (c_p normal, c_s tangential), N s/m
  ViewN<double, 2> spring;   // K A (K_n = 4G/(3R) normal, K_t = 2G/(3R) tangential), N/m
  ViewN<double, 2> f_hold;   // static force of the removed far field, held, N
  // Work done on each node since the start, J (the energy account, kernels/FemModel.hpp
  // FemEnergies): 0 the non-reflecting boundary (held force, dashpots, springs), 1 the mass
  // damping, 2 the tie's force from the particles.
  ViewN<double, 3> node_work;
  // elements
  Kokkos::View<int* [4], MemSpace> conn;  // node ids, counter-clockwise
  View1<int> material;                    // index into the material table
  ViewN<double, 4> stress;                // Pa (rr, zz, tt, rz)
  ViewN<double, 4> strain_rate;           // last step's rate of deformation, 1/s
  View1<double> plastic_strain;           // accumulated equivalent plastic strain
  View1<double> compaction;               // plastic volumetric strain of effect (a), -
  ViewN<double, kHistorySlots> history;   // the model's own history slots (MaterialState::history)
  View1<double> elem_mass;                // rho0 V0, kg (constant)
  View1<double> volume;                   // current ring volume, m3
  ViewN<double, 2> hourglass_force;       // generalised hourglass force Q (r, z), N
  View1<double> internal_energy;          // work of the stress, J
  View1<double> hourglass_energy;         // work of the hourglass forces, J
  Kokkos::View<MaterialParams*, MemSpace> materials;
};

// ---------------------------------------------------------------------------------------
// Element geometry: volume-averaged ("mean") gradient operator over the ring volume.
//   V     = 2 pi Int r dA
//   br_I  = (1/V) Int dN_I/dr dV,  bz_I = (1/V) Int dN_I/dz dV,  bt_I = (1/V) Int N_I/r dV
// with dV = 2 pi r dA. All three integrands times det J are polynomials of degree <= 2 in
// each of xi, eta, so 2x2 Gauss points integrate them exactly on any convex quad.
struct QuadGeometry {
  double volume = 0;  // ring volume, m3
  double area = 0;    // meridian area, m2
  double br[4] = {0, 0, 0, 0}, bz[4] = {0, 0, 0, 0}, bt[4] = {0, 0, 0, 0};  // 1/m
};

// The bilinear quad's shape functions at (xi, eta); node order (-,-), (+,-), (+,+), (-,+)
// (counter-clockwise from (-1, -1)).
KOKKOS_INLINE_FUNCTION void bilinear(double xi, double eta, double N[4]) {
  const double xs[4] = {-1, 1, 1, -1}, es[4] = {-1, -1, 1, 1};
  for (int k = 0; k < 4; ++k) N[k] = 0.25 * (1 + xs[k] * xi) * (1 + es[k] * eta);
}

// The shape functions and their derivatives at (xi, eta).
KOKKOS_INLINE_FUNCTION void quad_shape(double xi, double eta, double N[4], double dxi[4],
                                       double deta[4]) {
  const double xs[4] = {-1, 1, 1, -1}, es[4] = {-1, -1, 1, 1};
  bilinear(xi, eta, N);
  for (int k = 0; k < 4; ++k) {
    dxi[k] = 0.25 * xs[k] * (1 + es[k] * eta);
    deta[k] = 0.25 * es[k] * (1 + xs[k] * xi);
  }
}

// Shape functions, isoparametric derivatives, Jacobian terms and radius at (xi, eta).
struct QuadPoint {
  double N[4], dxi[4], deta[4];
  double r_xi, r_eta, z_xi, z_eta, rp, detJ;
};
KOKKOS_INLINE_FUNCTION QuadPoint quad_point(double xi, double eta, const double r[4], const double z[4]) {
  QuadPoint q;
  quad_shape(xi, eta, q.N, q.dxi, q.deta);
  q.r_xi = q.r_eta = q.z_xi = q.z_eta = q.rp = 0;
  for (int k = 0; k < 4; ++k) {
    q.r_xi += q.dxi[k] * r[k]; q.r_eta += q.deta[k] * r[k];
    q.z_xi += q.dxi[k] * z[k]; q.z_eta += q.deta[k] * z[k];
    q.rp += q.N[k] * r[k];
  }
  q.detJ = q.r_xi * q.z_eta - q.z_xi * q.r_eta;
  return q;
}

// Returns false for a degenerate or inverted element (det J <= 0 at a Gauss point).
//
// In closed form (the 2x2 Gauss sums of these polynomials, done once by hand; checked
// against the Gauss sums in tests/test_fem.cpp): with the bilinear map
//   r = a0 + a1 xi + a2 eta + a3 xi eta,  z = b0 + b1 xi + b2 eta + b3 xi eta,
// det J = j0 + j1 xi + j2 eta (j0 = a1 b2 - a2 b1, j1 = a1 b3 - a3 b1, j2 = a3 b2 - a2 b3),
// and node k at (xi, eta) = (s_k, t_k):
//   V / 2 pi     = 4 a0 j0 + 4/3 (a1 j1 + a2 j2),       A = 4 j0
//   br_k V / 2pi = s_k (a0 b2 + a1 b3/3) - t_k (a0 b1 + a2 b3/3) + s_k t_k (a2 b2 - a1 b1)/3
//   bz_k V / 2pi = -[s_k (a0 a2 + a1 a3/3) - t_k (a0 a1 + a2 a3/3) + s_k t_k (a2^2 - a1^2)/3]
//   bt_k V / 2pi = j0 + (s_k j1 + t_k j2)/3
// (the element pass evaluates this twice per element and step: the Gauss loops were 15 % of
// the lab job's time, perf/RESULTS.md).
KOKKOS_INLINE_FUNCTION bool quad_geometry(const double r[4], const double z[4], QuadGeometry& g) {
  const double a0 = 0.25 * (r[0] + r[1] + r[2] + r[3]), a1 = 0.25 * (-r[0] + r[1] + r[2] - r[3]);
  const double a2 = 0.25 * (-r[0] - r[1] + r[2] + r[3]), a3 = 0.25 * (r[0] - r[1] + r[2] - r[3]);
  // (b0 does not enter: a translation in z changes nothing)
  const double b1 = 0.25 * (-z[0] + z[1] + z[2] - z[3]);
  const double b2 = 0.25 * (-z[0] - z[1] + z[2] + z[3]), b3 = 0.25 * (z[0] - z[1] + z[2] - z[3]);
  const double j0 = a1 * b2 - a2 * b1, j1 = a1 * b3 - a3 * b1, j2 = a3 * b2 - a2 * b3;
  const double third = 1.0 / 3.0;
  const double v = 4.0 * a0 * j0 + 4.0 * third * (a1 * j1 + a2 * j2);  // V / 2 pi
  g.volume = 2.0 * pi * v;
  g.area = 4.0 * j0;
  if (!(g.volume > 0)) return false;
  const double inv = 1.0 / v;
  const double br_s = a0 * b2 + third * a1 * b3, br_t = a0 * b1 + third * a2 * b3, br_st = third * (a2 * b2 - a1 * b1);
  const double bz_s = a0 * a2 + third * a1 * a3, bz_t = a0 * a1 + third * a2 * a3, bz_st = third * (a2 * a2 - a1 * a1);
  const double s[4] = {-1, 1, 1, -1}, t[4] = {-1, -1, 1, 1};
  for (int k = 0; k < 4; ++k) {
    g.br[k] = (s[k] * br_s - t[k] * br_t + s[k] * t[k] * br_st) * inv;
    g.bz[k] = -(s[k] * bz_s - t[k] * bz_t + s[k] * t[k] * bz_st) * inv;
    g.bt[k] = (j0 + third * (s[k] * j1 + t[k] * j2)) * inv;
  }
  // det J at the four Gauss points (+-1/sqrt 3, +-1/sqrt 3): the smallest is j0 - (|j1| + |j2|)/sqrt 3
  const double gp = 0.57735026918962576451;
  return j0 - gp * (math::abs(j1) + math::abs(j2)) > 0;
}

// The same by 2x2 Gauss quadrature, as the closed form above was derived from: the test's
// reference (tests/test_fem.cpp).
KOKKOS_INLINE_FUNCTION bool quad_geometry_gauss(const double r[4], const double z[4], QuadGeometry& g) {
  const double gp = 0.57735026918962576451;  // 1/sqrt(3)
  const double pts[2] = {-gp, gp};
  double V = 0, A = 0;
  double br[4] = {0, 0, 0, 0}, bz[4] = {0, 0, 0, 0}, bt[4] = {0, 0, 0, 0};
  bool ok = true;
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b) {
      const QuadPoint q = quad_point(pts[a], pts[b], r, z);
      const double *N = q.N, *dxi = q.dxi, *deta = q.deta;
      const double r_xi = q.r_xi, r_eta = q.r_eta, z_xi = q.z_xi, z_eta = q.z_eta, rp = q.rp, detJ = q.detJ;
      if (!(detJ > 0)) ok = false;
      A += detJ;
      const double w = 2.0 * pi * rp;  // dV = w detJ dxi deta
      V += w * detJ;
      for (int k = 0; k < 4; ++k) {
        // dN/dr detJ = z_eta dN/dxi - z_xi dN/deta; dN/dz detJ = r_xi dN/deta - r_eta dN/dxi
        br[k] += w * (z_eta * dxi[k] - z_xi * deta[k]);
        bz[k] += w * (r_xi * deta[k] - r_eta * dxi[k]);
        bt[k] += 2.0 * pi * N[k] * detJ;
      }
    }
  g.volume = V;
  g.area = A;
  if (!(V > 0)) return false;
  const double inv = 1.0 / V;
  for (int k = 0; k < 4; ++k) {
    g.br[k] = br[k] * inv;
    g.bz[k] = bz[k] * inv;
    g.bt[k] = bt[k] * inv;
  }
  return ok;
}

// Row sums of the consistent ring-mass matrix per unit density: w_I = Int N_I 2 pi r dA
// (exact with 2x2 Gauss; sum_I w_I = V). Nonzero on the axis.
KOKKOS_INLINE_FUNCTION void quad_mass_weights(const double r[4], const double z[4], double w[4]) {
  const double gp = 0.57735026918962576451;
  const double pts[2] = {-gp, gp};
  for (int k = 0; k < 4; ++k) w[k] = 0;
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b) {
      const QuadPoint q = quad_point(pts[a], pts[b], r, z);
      for (int k = 0; k < 4; ++k) w[k] += 2.0 * pi * q.rp * q.N[k] * q.detJ;
    }
}

// Stable-step length of an element: L = 1 / sqrt(sum_I br_I^2 + bz_I^2 + bt_I^2); the
// lumped-mass element's highest frequency is bounded by 2 c / L (docs/fem.md).
KOKKOS_INLINE_FUNCTION double quad_stable_length(const QuadGeometry& g) {
  double s = 0;
  for (int k = 0; k < 4; ++k) s += g.br[k] * g.br[k] + g.bz[k] * g.bz[k] + g.bt[k] * g.bt[k];
  return 1.0 / math::sqrt(s);
}

// Flanagan-Belytschko hourglass shape vector: gamma = (h - (h.r) br - (h.z) bz) / 4,
// h = (1, -1, 1, -1). Orthogonal to every linear field: sum_I gamma_I (a + b r_I + c z_I) = 0.
KOKKOS_INLINE_FUNCTION void quad_hourglass_gamma(const double r[4], const double z[4],
                                                 const QuadGeometry& g, double gamma[4]) {
  const double h[4] = {1, -1, 1, -1};
  double hr = 0, hz = 0;
  for (int k = 0; k < 4; ++k) { hr += h[k] * r[k]; hz += h[k] * z[k]; }
  for (int k = 0; k < 4; ++k) gamma[k] = 0.25 * (h[k] - hr * g.br[k] - hz * g.bz[k]);
}

// ---------------------------------------------------------------------------------------
// Node update, the first half of a central-difference step (x holds x^n, v holds
// v^{n-1/2}, f_int holds f_int(x^n)):
//   a^n        = (f_ext - f_int) / m - g e_z
//   v^{n+1/2}  = [(1 - zeta dt_kick/2) v^{n-1/2} + dt_kick a^n] / (1 + zeta dt_kick/2)
//   (prescribed components are then overwritten by v_bc)
//   x^{n+1}    = x^n + dt v^{n+1/2}
// dt_kick = (dt^{n-1/2} + dt^{n+1/2}) / 2 (dt/2 on the first step), zeta = mass damping.
struct QuadNodeUpdate {
  ViewN<double, 2> x, x0, v, f_int, f_ext, f_tie, v_bc;
  ViewN<double, 2> dashpot, spring, f_hold;  // viscous-spring boundary (zero off it)
  ViewN<double, 3> node_work;                // accumulated (FemMesh::node_work)
  View1<double> mass;
  View1<int> bc;
  double gravity = 0, damping = 0, dt_kick = 0, dt = 0;
  KOKKOS_INLINE_FUNCTION void operator()(const int i) const {
    const double inv_m = 1.0 / mass(i);
    // Boundary force from the last half-step velocity (explicit dashpot) and the
    // displacement from the reference configuration.
    double fb[2], ft[2];
    for (int c = 0; c < 2; ++c) {
      fb[c] = f_hold(i, c) - dashpot(i, c) * v(i, c) - spring(i, c) * (x(i, c) - x0(i, c));
      ft[c] = f_tie(i, c);
    }
    const double a_r = (f_ext(i, 0) + fb[0] + ft[0] - f_int(i, 0)) * inv_m;
    const double a_z = (f_ext(i, 1) + fb[1] + ft[1] - f_int(i, 1)) * inv_m - gravity;
    const double c0 = 1.0 - 0.5 * damping * dt_kick, c1 = 1.0 / (1.0 + 0.5 * damping * dt_kick);
    const double v_old[2] = {v(i, 0), v(i, 1)};
    double vr = (c0 * v_old[0] + dt_kick * a_r) * c1;
    double vz = (c0 * v_old[1] + dt_kick * a_z) * c1;
    const int flags = bc(i);
    if (flags & BC_R) vr = v_bc(i, 0);
    if (flags & BC_Z) vz = v_bc(i, 1);
    v(i, 0) = vr;
    v(i, 1) = vz;
    // The work of this kick, with the mean of the velocities before and after it (the
    // kinetic energy changes by exactly the sum of these over all forces; the damping
    // term is -d (v_old + v_new)/2 per unit mass in the form above). A prescribed
    // component does no work here: its reaction is not a force of the node update.
    const double v_new[2] = {vr, vz};
    const int fixed[2] = {flags & BC_R, flags & BC_Z};
    for (int c = 0; c < 2; ++c) {
      if (fixed[c]) continue;
      const double u = 0.5 * (v_old[c] + v_new[c]);
      node_work(i, 0) += dt_kick * fb[c] * u;
      node_work(i, 1) -= dt_kick * mass(i) * damping * u * u;
      node_work(i, 2) += dt_kick * ft[c] * u;
    }
    x(i, 0) += dt * vr;
    x(i, 1) += dt * vz;
  }
};

// Element pass, the second half of a step (x holds x^{n+1}, v holds v^{n+1/2}):
//   mid configuration x^{n+1/2} = x^{n+1} - dt/2 v:  D = B(x^{n+1/2}) v,  spin W_rz
//   sigma^{n+1} = update_stress(sigma^n, D dt, W_rz dt)                 (models.md)
//   internal energy += V^{n+1/2} (sigma^n + sigma^{n+1})/2 : D dt
//   f_int,I = V^{n+1} B_I(x^{n+1})^T sigma^{n+1} + Q gamma_I            (hourglass)
// Reduces the smallest stable step L / c over the elements (0 for an inverted element).
// With dt = 0 it only re-evaluates the forces of the current stress.
// Models: the constitutive models it dispatches over (models/ModelList.hpp).
template <class Scatter, class Models = RegisteredModels>
struct QuadElementPassT {
  ViewN<double, 2> x, v;
  Kokkos::View<int* [4], MemSpace> conn;
  View1<int> material;
  Kokkos::View<MaterialParams*, MemSpace> materials;
  ViewN<double, 4> stress, strain_rate;
  View1<double> plastic_strain, compaction, elem_mass, volume, internal_energy, hourglass_energy;
  ViewN<double, kHistorySlots> history;
  ViewN<double, 2> hourglass_force;
  Scatter f_scatter;
  double dt = 0;       // this step, x^n -> x^{n+1}
  double dt_kick = 0;  // the kick that preceded this pass (QuadNodeUpdate::dt_kick)
  int hourglass_form = HOURGLASS_STIFFNESS;
  double hourglass_coef = 0.1;

  KOKKOS_INLINE_FUNCTION void operator()(const int e, double& dt_min) const {
    int n[4];
    double r[4], z[4], vr[4], vz[4];
    for (int k = 0; k < 4; ++k) {
      n[k] = conn(e, k);
      vr[k] = v(n[k], 0);
      vz[k] = v(n[k], 1);
      r[k] = x(n[k], 0);
      z[k] = x(n[k], 1);
    }
    const MaterialParams& m = materials(material(e));
    bool ok = true;

    // Strain increment and spin at the mid-step configuration.
    if (dt > 0) {
      double rm[4], zm[4];
      for (int k = 0; k < 4; ++k) {
        rm[k] = r[k] - 0.5 * dt * vr[k];
        zm[k] = z[k] - 0.5 * dt * vz[k];
      }
      QuadGeometry gm;
      ok = quad_geometry(rm, zm, gm) && ok;
      double d_rr = 0, d_zz = 0, d_tt = 0, l_rz = 0, l_zr = 0;
      for (int k = 0; k < 4; ++k) {
        d_rr += gm.br[k] * vr[k];
        d_zz += gm.bz[k] * vz[k];
        d_tt += gm.bt[k] * vr[k];
        l_rz += gm.bz[k] * vr[k];  // dv_r/dz
        l_zr += gm.br[k] * vz[k];  // dv_z/dr
      }
      const double d_rz = 0.5 * (l_rz + l_zr);
      const double deps[4] = {d_rr * dt, d_zz * dt, d_tt * dt, d_rz * dt};
      double s[4], s_old[4];
      for (int c = 0; c < 4; ++c) s[c] = s_old[c] = stress(e, c);
      MaterialState state;
      state.plastic_strain = plastic_strain(e);
      state.compaction = compaction(e);
      if constexpr (Models::has_history)
        for (int k = 0; k < kHistorySlots; ++k) state.history[k] = history(e, k);
      update_stress<Models>(m, s, deps, 0.5 * (l_rz - l_zr) * dt, state, dt);
      compaction(e) = state.compaction;
      double work = 0;
      for (int c = 0; c < 3; ++c) work += 0.5 * (s_old[c] + s[c]) * deps[c];
      work += (s_old[RZ] + s[RZ]) * deps[RZ];
      internal_energy(e) += gm.volume * work;
      for (int c = 0; c < 4; ++c) stress(e, c) = s[c];
      plastic_strain(e) = state.plastic_strain;
      if constexpr (Models::has_history)
        for (int k = 0; k < kHistorySlots; ++k) history(e, k) = state.history[k];
      strain_rate(e, RR) = d_rr;
      strain_rate(e, ZZ) = d_zz;
      strain_rate(e, TT) = d_tt;
      strain_rate(e, RZ) = d_rz;
    }

    // Forces at the end-of-step configuration.
    QuadGeometry g;
    ok = quad_geometry(r, z, g) && ok;
    volume(e) = g.volume;
    const double s_rr = stress(e, RR), s_zz = stress(e, ZZ), s_tt = stress(e, TT),
                 s_rz = stress(e, RZ);
    double fr[4], fz[4];
    for (int k = 0; k < 4; ++k) {
      fr[k] = g.volume * (g.br[k] * s_rr + g.bz[k] * s_rz + g.bt[k] * s_tt);
      fz[k] = g.volume * (g.br[k] * s_rz + g.bz[k] * s_zz);
    }

    // Hourglass control (Flanagan & Belytschko 1981), volume weighted.
    double gamma[4];
    quad_hourglass_gamma(r, z, g, gamma);
    double q_r = 0, q_z = 0, bb = 0;
    for (int k = 0; k < 4; ++k) {
      q_r += gamma[k] * vr[k];
      q_z += gamma[k] * vz[k];
      bb += g.br[k] * g.br[k] + g.bz[k] * g.bz[k];
    }
    const double rho = elem_mass(e) / g.volume;
    const double M = m.p_wave_modulus();
    double Q_r = 0, Q_z = 0;
    if (hourglass_form == HOURGLASS_VISCOUS) {
      const double c = math::sqrt(M / rho);
      const double C = hourglass_coef * rho * c * g.volume * math::sqrt(2.0 * bb);
      // Work of the previous force Q^n over the kick that just used it, with the centred
      // rate (q^{n-1/2} + q^{n+1/2}) / 2, q^{n-1/2} = Q^n / C (docs/fem.md).
      const double Q0_r = hourglass_force(e, 0), Q0_z = hourglass_force(e, 1);
      if (C > 0)
        hourglass_energy(e) +=
            0.5 * dt_kick * (Q0_r * (Q0_r / C + q_r) + Q0_z * (Q0_z / C + q_z));
      Q_r = C * q_r;
      Q_z = C * q_z;
      hourglass_force(e, 0) = Q_r;
      hourglass_force(e, 1) = Q_z;
    } else {
      const double C = 0.5 * hourglass_coef * M * g.volume * bb;
      const double Q0_r = hourglass_force(e, 0), Q0_z = hourglass_force(e, 1);
      Q_r = Q0_r + C * q_r * dt;
      Q_z = Q0_z + C * q_z * dt;
      hourglass_force(e, 0) = Q_r;
      hourglass_force(e, 1) = Q_z;
      hourglass_energy(e) += 0.5 * ((Q0_r + Q_r) * q_r + (Q0_z + Q_z) * q_z) * dt;
    }
    auto f = f_scatter.access();
    for (int k = 0; k < 4; ++k) {
      f(n[k], 0) += fr[k] + Q_r * gamma[k];
      f(n[k], 1) += fz[k] + Q_z * gamma[k];
    }

    double dt_e = 0;
    if (ok) dt_e = quad_stable_length(g) / math::sqrt(M / rho);
    if (!(dt_e == dt_e)) dt_e = 0;
    dt_min = math::min(dt_min, dt_e);
  }
};
using QuadElementPass = QuadElementPassT<ForceScatter>;

}  // namespace tamp::fem
