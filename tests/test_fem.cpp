// Axisymmetric 4-node quad FEM (kernels/FemQuad.hpp, kernels/FemModel.hpp; issue 3, "FEM
// far field"): patch test, 1D compression wave speed, hourglass energy in bending.
// Equations and measured figures: docs/fem.md.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "kernels/FemModel.hpp"
#include "drivers/sequence/LabMaterials.hpp"
#include "kernels/solver/Simulation.hpp"

using namespace tamp;
using namespace tamp::fem;

namespace {

MaterialParams lab_clay() { return make_material(lab::clay("elastic")); }

// A 4 x 4 mesh of [0, 1] x [0, 1] m with every node that is not a corner moved by up to
// 20 % of the spacing (axis nodes stay on r = 0, outer nodes on r = 1, bottom and top
// nodes on their planes; only the tangential coordinate moves there). The elements stay
// convex; four of them touch the axis.
struct DistortedMesh {
  int nr = 4, nz = 4;
  std::vector<double> r, z;
};

DistortedMesh distorted_mesh() {
  DistortedMesh m;
  const int nn = (m.nr + 1) * (m.nz + 1);
  m.r.resize(nn);
  m.z.resize(nn);
  std::mt19937 gen(12345);
  std::uniform_real_distribution<double> u(-0.2, 0.2);
  const double h = 0.25;
  for (int j = 0; j <= m.nz; ++j)
    for (int i = 0; i <= m.nr; ++i) {
      const int n = j * (m.nr + 1) + i;
      double r = i * h, z = j * h;
      const double dr = u(gen) * h, dz = u(gen) * h;
      if (i > 0 && i < m.nr) r += dr;
      if (j > 0 && j < m.nz) z += dz;
      m.r[n] = r;
      m.z[n] = z;
    }
  return m;
}

FemModel model_on(const DistortedMesh& d, bool axis_symmetry) {
  FemBlock b;
  b.r0 = 0; b.r1 = 1; b.z0 = 0; b.z1 = 1;
  b.nr = d.nr; b.nz = d.nz;
  FemOptions o;
  o.axis_symmetry = axis_symmetry;
  FemModel model(lab_clay(), b, o);
  model.set_node_positions(d.r, d.z);
  return model;
}

// Independent quadrature of f_I = Int B_I^T sigma 2 pi r dA over every element (3 x 3
// Gauss points, full bilinear element, gradients at each point).
std::vector<double> exact_nodal_forces(const DistortedMesh& d, const double s[4]) {
  const int nn = (int)d.r.size();
  std::vector<double> f(2 * nn, 0.0);
  const double gp[3] = {-std::sqrt(0.6), 0.0, std::sqrt(0.6)};
  const double gw[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
  for (int j = 0; j < d.nz; ++j)
    for (int i = 0; i < d.nr; ++i) {
      const int n[4] = {j * (d.nr + 1) + i, j * (d.nr + 1) + i + 1, (j + 1) * (d.nr + 1) + i + 1,
                        (j + 1) * (d.nr + 1) + i};
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
          double N[4], dxi[4], deta[4];
          quad_shape(gp[a], gp[b], N, dxi, deta);
          double r_xi = 0, r_eta = 0, z_xi = 0, z_eta = 0, rp = 0;
          for (int k = 0; k < 4; ++k) {
            r_xi += dxi[k] * d.r[n[k]]; r_eta += deta[k] * d.r[n[k]];
            z_xi += dxi[k] * d.z[n[k]]; z_eta += deta[k] * d.z[n[k]];
            rp += N[k] * d.r[n[k]];
          }
          const double det = r_xi * z_eta - z_xi * r_eta;
          const double dV = 2 * pi * rp * det * gw[a] * gw[b];
          for (int k = 0; k < 4; ++k) {
            const double Nr = (z_eta * dxi[k] - z_xi * deta[k]) / det;
            const double Nz = (r_xi * deta[k] - r_eta * dxi[k]) / det;
            f[2 * n[k]] += dV * (Nr * s[RR] + Nz * s[RZ]) + 2 * pi * det * gw[a] * gw[b] * N[k] * s[TT];
            f[2 * n[k] + 1] += dV * (Nr * s[RZ] + Nz * s[ZZ]);
          }
        }
    }
  return f;
}

// The literal one-point form with everything at the isoparametric centre: B from dN/dr,
// dN/dz at xi = eta = 0, hoop row N_I / r_c, V = 2 pi r_c A, r_c = mean nodal r. Its
// assembled forces for a uniform stress, to show why the code uses the mean form.
std::vector<double> centroid_form_forces(const DistortedMesh& d, const double s[4]) {
  const int nn = (int)d.r.size();
  std::vector<double> f(2 * nn, 0.0);
  for (int j = 0; j < d.nz; ++j)
    for (int i = 0; i < d.nr; ++i) {
      const int n[4] = {j * (d.nr + 1) + i, j * (d.nr + 1) + i + 1, (j + 1) * (d.nr + 1) + i + 1,
                        (j + 1) * (d.nr + 1) + i};
      double N[4], dxi[4], deta[4];
      quad_shape(0, 0, N, dxi, deta);
      double r_xi = 0, r_eta = 0, z_xi = 0, z_eta = 0, rc = 0;
      for (int k = 0; k < 4; ++k) {
        r_xi += dxi[k] * d.r[n[k]]; r_eta += deta[k] * d.r[n[k]];
        z_xi += dxi[k] * d.z[n[k]]; z_eta += deta[k] * d.z[n[k]];
        rc += N[k] * d.r[n[k]];
      }
      const double det = r_xi * z_eta - z_xi * r_eta;
      const double V = 2 * pi * rc * 4 * det;
      for (int k = 0; k < 4; ++k) {
        const double Nr = (z_eta * dxi[k] - z_xi * deta[k]) / det;
        const double Nz = (r_xi * deta[k] - r_eta * dxi[k]) / det;
        f[2 * n[k]] += V * (Nr * s[RR] + Nz * s[RZ] + N[k] / rc * s[TT]);
        f[2 * n[k] + 1] += V * (Nr * s[RZ] + Nz * s[ZZ]);
      }
    }
  return f;
}

bool on_free_boundary(const DistortedMesh& d, int n) {  // outer, bottom or top side
  const int i = n % (d.nr + 1), j = n / (d.nr + 1);
  return i == d.nr || j == 0 || j == d.nz;
}

}  // namespace

// The element geometry in closed form (quad_geometry, evaluated twice per element and
// step) against the 2x2 Gauss sums it was derived from (quad_geometry_gauss): both integrate
// the same polynomials exactly, so they differ by round-off only. Tolerance 1e-12 of the
// largest gradient entry (1/m) and of the volume: about 1e4 times the double epsilon for
// sums of a dozen terms; an error in a formula would show at order 1.
TEST_CASE("FEM: the closed-form element geometry equals its Gauss quadrature", "[fem]") {
  std::mt19937 gen(2026);
  std::uniform_real_distribution<double> u(-0.3, 0.3), size(0.002, 0.2), centre(0.0, 1.0);
  int checked = 0, inverted = 0;
  double worst = 0;  // largest difference relative to its tolerance's scale
  for (int trial = 0; trial < 20000; ++trial) {
    const double L = size(gen);
    const double rc = trial % 4 == 0 ? 0.5 * L : centre(gen);  // every 4th touches the axis
    const double zc = centre(gen);
    const double xs[4] = {-1, 1, 1, -1}, es[4] = {-1, -1, 1, 1};
    double r[4], z[4];
    for (int k = 0; k < 4; ++k) {
      r[k] = std::max(0.0, rc + 0.5 * L * (xs[k] + (trial % 3 == 0 ? 3 : 1) * u(gen)));
      z[k] = zc + 0.5 * L * (es[k] + (trial % 3 == 0 ? 3 : 1) * u(gen));
    }
    if (trial % 10 == 1) {  // a bow tie: det J changes sign inside the element
      std::swap(r[2], r[3]);
      std::swap(z[2], z[3]);
    } else if (trial % 10 == 2) {  // clockwise: det J < 0 everywhere
      std::swap(r[1], r[3]);
      std::swap(z[1], z[3]);
    }
    QuadGeometry a, b;
    const bool ok_a = quad_geometry(r, z, a), ok_b = quad_geometry_gauss(r, z, b);
    // Valid or not, both must agree, away from a round-off tie at det J = 0 or V = 0.
    double det_min = 1e300;
    for (double xi : {-0.57735026918962576, 0.57735026918962576})
      for (double eta : {-0.57735026918962576, 0.57735026918962576})
        det_min = std::min(det_min, quad_point(xi, eta, r, z).detJ);
    if (std::abs(det_min) > 1e-9 * L * L && std::abs(b.volume) > 1e-9 * L * L * L) REQUIRE(ok_a == ok_b);
    if (!ok_b) {
      ++inverted;
      continue;
    }
    double scale = 0;
    for (int k = 0; k < 4; ++k) scale = std::max({scale, std::abs(b.br[k]), std::abs(b.bz[k]), std::abs(b.bt[k])});
    REQUIRE(std::abs(a.volume - b.volume) <= 1e-12 * std::abs(b.volume));
    REQUIRE(std::abs(a.area - b.area) <= 1e-12 * std::abs(b.area));
    worst = std::max({worst, std::abs(a.volume - b.volume) / std::abs(b.volume), std::abs(a.area - b.area) / std::abs(b.area)});
    for (int k = 0; k < 4; ++k) {
      worst = std::max({worst, std::abs(a.br[k] - b.br[k]) / scale, std::abs(a.bz[k] - b.bz[k]) / scale,
                        std::abs(a.bt[k] - b.bt[k]) / scale});
      REQUIRE(std::abs(a.br[k] - b.br[k]) <= 1e-12 * scale);
      REQUIRE(std::abs(a.bz[k] - b.bz[k]) <= 1e-12 * scale);
      REQUIRE(std::abs(a.bt[k] - b.bt[k]) <= 1e-12 * scale);
    }
    ++checked;
  }
  std::printf("[fem geometry] %d quads valid, %d inverted (both agree); worst relative difference %.1e\n", checked,
              inverted, worst);
  CHECK(checked > 10000);
  CHECK(inverted > 3000);  // the bow ties and clockwise quads, a fifth: both must say so
}

TEST_CASE("FEM: patch test on distorted quads touching the axis", "[fem]") {
  const DistortedMesh d = distorted_mesh();
  const MaterialParams mat = lab_clay();

  SECTION("a linear velocity field gives the exact element strain rates") {
    // Exact (proved in docs/fem.md): for a linear velocity field v = a + G x, the mean
    // (volume-averaged) B of every element returns d_rr, d_zz, d_rz = the constant exact
    // values, and d_tt = v_r(xc) / rc at the area centroid xc of the element, which is the
    // element's volume average of v_r / r (not v_r / r at other points: the element strain
    // is constant while v_r / r is not). Tolerance 1e-10 relative: round-off only.
    // The field is general (v_r != 0 on the axis), so the axis condition is left off here.
    FemModel model = model_on(d, false);
    const double a[2] = {0.3, -0.2};
    const double G[2][2] = {{0.7, -0.4}, {0.9, -1.1}};  // G[i][j] = dv_i/dx_j
    const int nn = (int)d.r.size();
    std::vector<double> vr(nn), vz(nn);
    for (int n = 0; n < nn; ++n) {
      vr[n] = a[0] + G[0][0] * d.r[n] + G[0][1] * d.z[n];
      vz[n] = a[1] + G[1][0] * d.r[n] + G[1][1] * d.z[n];
    }
    model.set_velocities(vr, vz);
    const double dt = 1e-3;
    model.step(dt);
    // The strain is taken on the mid-step configuration x = X + dt/2 v(X), on which the
    // velocity is linear with gradient L = G (I + dt/2 G)^-1.
    const double A11 = 1 + 0.5 * dt * G[0][0], A12 = 0.5 * dt * G[0][1];
    const double A21 = 0.5 * dt * G[1][0], A22 = 1 + 0.5 * dt * G[1][1];
    const double det = A11 * A22 - A12 * A21;
    const double I11 = A22 / det, I12 = -A12 / det, I21 = -A21 / det, I22 = A11 / det;
    const double L_rr = G[0][0] * I11 + G[0][1] * I21, L_rz = G[0][0] * I12 + G[0][1] * I22;
    const double L_zr = G[1][0] * I11 + G[1][1] * I21, L_zz = G[1][0] * I12 + G[1][1] * I22;
    auto rate = Kokkos::create_mirror_view_and_copy(HostSpace(), model.mesh().strain_rate);
    auto Q = Kokkos::create_mirror_view_and_copy(HostSpace(), model.mesh().hourglass_force);
    auto vol = Kokkos::create_mirror_view_and_copy(HostSpace(), model.mesh().volume);
    const double scale = 1.1;  // largest |G_ij|
    double worst = 0, worst_tt = 0, worst_hg = 0;
    for (int j = 0; j < d.nz; ++j)
      for (int i = 0; i < d.nr; ++i) {
        const int e = j * d.nr + i;
        const int n[4] = {j * (d.nr + 1) + i, j * (d.nr + 1) + i + 1,
                          (j + 1) * (d.nr + 1) + i + 1, (j + 1) * (d.nr + 1) + i};
        double rm[4], zm[4];
        for (int k = 0; k < 4; ++k) {
          rm[k] = d.r[n[k]] + 0.5 * dt * vr[n[k]];
          zm[k] = d.z[n[k]] + 0.5 * dt * vz[n[k]];
        }
        double A = 0, Sr = 0, Sz = 0;  // area centroid (shoelace)
        for (int k = 0; k < 4; ++k) {
          const int l = (k + 1) % 4;
          const double c = rm[k] * zm[l] - rm[l] * zm[k];
          A += 0.5 * c;
          Sr += (rm[k] + rm[l]) * c / 6;
          Sz += (zm[k] + zm[l]) * c / 6;
        }
        const double rc = Sr / A, zc = Sz / A;
        // v_r at the centroid: map back to the reference point X = A^-1 (x - dt/2 a).
        const double Xr = I11 * (rc - 0.5 * dt * a[0]) + I12 * (zc - 0.5 * dt * a[1]);
        const double Xz = I21 * (rc - 0.5 * dt * a[0]) + I22 * (zc - 0.5 * dt * a[1]);
        const double vr_c = a[0] + G[0][0] * Xr + G[0][1] * Xz;
        worst = std::max({worst, std::fabs(rate(e, RR) - L_rr) / scale,
                          std::fabs(rate(e, ZZ) - L_zz) / scale,
                          std::fabs(rate(e, RZ) - 0.5 * (L_rz + L_zr)) / scale});
        worst_tt = std::max(worst_tt, std::fabs(rate(e, TT) - vr_c / rc) / std::fabs(vr_c / rc));
        // Hourglass force relative to the stress force scale M |G| dt V / h.
        const double f_scale = mat.p_wave_modulus() * scale * dt * vol(e) / 0.25;
        worst_hg = std::max(worst_hg, std::hypot(Q(e, 0), Q(e, 1)) / f_scale);
      }
    std::printf("[fem patch] linear field: worst |d - d_exact| / |G| = %.2e (rr, zz, rz), "
                "worst relative tt error %.2e, hourglass force / force scale %.2e\n",
                worst, worst_tt, worst_hg);
    CHECK(worst < 1e-10);
    CHECK(worst_tt < 1e-10);
    CHECK(worst_hg < 1e-10);
  }

  SECTION("uniform stress: exact nodal forces, and nodal equilibrium off the free boundary") {
    // (a) For any element-wise constant stress the assembled force of every node equals
    //     Int B_I^T sigma dV exactly (the mean B integrates it without quadrature error):
    //     compared with an independent 3 x 3 Gauss quadrature of the bilinear element.
    // (b) A uniform stress is in equilibrium in axisymmetry only if s_rr = s_tt and
    //     s_rz = 0 (div sigma = ((s_rr - s_tt)/r, s_rz/r)); then the force vanishes at
    //     every node not on the outer, bottom or top side: interior nodes, the nodes next
    //     to the axis, and the axis nodes themselves (both components).
    // Tolerance 1e-10 relative to the force scale (the largest nodal force, which is on
    // the free boundary): round-off only.
    FemModel model = model_on(d, true);
    const int nn = (int)d.r.size();

    const double s_gen[4] = {-3.0e4, -5.0e4, -1.0e4, 1.5e4};
    model.set_uniform_stress(s_gen);
    model.compute_forces(0.0);
    auto f = Kokkos::create_mirror_view_and_copy(HostSpace(), model.mesh().f_int);
    const std::vector<double> fx = exact_nodal_forces(d, s_gen);
    double f_scale = 0, worst_gen = 0;
    for (int n = 0; n < nn; ++n) f_scale = std::max({f_scale, std::fabs(fx[2 * n]), std::fabs(fx[2 * n + 1])});
    for (int n = 0; n < nn; ++n)
      worst_gen = std::max({worst_gen, std::fabs(f(n, 0) - fx[2 * n]), std::fabs(f(n, 1) - fx[2 * n + 1])});
    worst_gen /= f_scale;

    const double s_eq[4] = {-3.0e4, -5.0e4, -3.0e4, 0.0};
    model.set_uniform_stress(s_eq);
    model.compute_forces(0.0);
    Kokkos::deep_copy(f, model.mesh().f_int);
    double f_scale_eq = 0, worst_eq = 0, worst_axis = 0;
    for (int n = 0; n < nn; ++n) f_scale_eq = std::max({f_scale_eq, std::fabs(f(n, 0)), std::fabs(f(n, 1))});
    for (int n = 0; n < nn; ++n) {
      if (on_free_boundary(d, n)) continue;
      const double fn = std::max(std::fabs(f(n, 0)), std::fabs(f(n, 1))) / f_scale_eq;
      worst_eq = std::max(worst_eq, fn);
      if (n % (d.nr + 1) <= 1) worst_axis = std::max(worst_axis, fn);  // axis and first ring
    }
    // The literal centroid form (N_I / r_c, V = 2 pi r_c A) on the same mesh and stress.
    const std::vector<double> fc = centroid_form_forces(d, s_eq);
    double worst_centroid = 0;
    for (int n = 0; n < nn; ++n)
      if (!on_free_boundary(d, n))
        worst_centroid = std::max({worst_centroid, std::fabs(fc[2 * n]), std::fabs(fc[2 * n + 1])});
    worst_centroid /= f_scale_eq;
    std::printf("[fem patch] uniform stress: worst |f - Int B^T s dV| / f_scale = %.2e (all nodes); "
                "equilibrium residual %.2e (off the free boundary), %.2e (axis and first ring); "
                "centroid-point form: %.2e\n",
                worst_gen, worst_eq, worst_axis, worst_centroid);
    CHECK(worst_gen < 1e-10);
    CHECK(worst_eq < 1e-10);
    CHECK(worst_axis < 1e-10);
    CHECK(worst_centroid > 1e-3);  // the reason for the mean form (docs/fem.md)
  }
}

TEST_CASE("FEM: 1D compression wave speed equals sqrt(M/rho)", "[fem]") {
  // Laterally confined column of the elastic lab clay (axis and roller outer side, fixed
  // base), 0.6 m tall, 2.5 mm elements. A velocity step v0 is imposed on the top nodes at
  // t = 0; the half-amplitude arrival times at two node rows 0.2 m apart give the speed,
  // free of the start-up offset (as the SPH test does). Exact: sqrt((K + 4G/3) / rho).
  // Tolerance 2 % (issue). No artificial viscosity: the front rings (lumped-mass
  // dispersion, phase speed below c for short waves), and its half-amplitude point lags
  // by a distance growing like t^(1/3) (Airy front); over 0.15-0.35 m of travel this is a
  // fraction of a millimetre.
  const double R = 0.02, L = 0.6, v0 = -0.01;
  FemBlock b;
  b.r0 = 0; b.r1 = R; b.z0 = 0; b.z1 = L;
  b.nr = 2; b.nz = 240;
  FemModel model(lab_clay(), b);
  model.set_side(FemSide::Outer, FemBc::Roller);
  model.set_side(FemSide::Bottom, FemBc::Fixed);
  model.set_side(FemSide::Top, FemBc::Velocity, 0.0, v0);
  const double c_exact = lab_clay().wave_speed();
  const int j1 = 180, j2 = 100;  // z = 0.45 m and 0.25 m
  const double z1 = L * j1 / b.nz, z2 = L * j2 / b.nz;
  auto v = Kokkos::create_mirror_view(model.mesh().v);
  auto row_mean = [&](int j) {
    double s = 0;
    for (int i = 0; i <= b.nr; ++i) s += v(model.node(i, j), 1);
    return s / (b.nr + 1);
  };
  double t1 = -1, t2 = -1, prev1 = 0, prev2 = 0, tprev = 0;
  const double half = 0.5 * v0;
  while (t2 < 0 && model.time() < 2 * L / c_exact) {
    model.step();
    Kokkos::deep_copy(v, model.mesh().v);
    const double t = model.time() - 0.5 * model.last_dt();  // v is the half-step velocity
    const double v1 = row_mean(j1), v2 = row_mean(j2);
    auto crossing = [&](double p, double now) { return tprev + (t - tprev) * (half - p) / (now - p); };
    if (t1 < 0 && v1 <= half) t1 = crossing(prev1, v1);
    if (t2 < 0 && v2 <= half) t2 = crossing(prev2, v2);
    prev1 = v1; prev2 = v2; tprev = t;
  }
  REQUIRE(t1 > 0);
  REQUIRE(t2 > t1);
  const double c_fem = (z1 - z2) / (t2 - t1);
  std::printf("[fem wave] c_fem = %.3f m/s, sqrt(M/rho) = %.3f m/s, error %.3f %% (%ld steps, dt %.3e s)\n",
              c_fem, c_exact, 100 * (c_fem / c_exact - 1), model.steps(), model.last_dt());
  CHECK(std::fabs(c_fem / c_exact - 1) < 0.02);
}

namespace {
struct PlateResult { double e_int, e_hg, e_kin, w_centre, w_mindlin; };

// Clamped circular plate (radius 1 m, thickness 0.1 m, elastic lab clay) under a uniform
// body force of 0.1 m/s2 (small enough that the centre deflection, about 1 % of the
// thickness, stays in the linear regime), nr x nz elements, relaxed with mass-proportional
// damping at half the critical value of the fundamental mode for 6 of its periods.
PlateResult sagging_plate(int hourglass_form, int nr, int nz) {
  const double a = 1.0, t = 0.1, g = 0.1;
  const MaterialParams m = lab_clay();
  FemBlock b;
  b.r0 = 0; b.r1 = a; b.z0 = 0; b.z1 = t;
  b.nr = nr; b.nz = nz;
  const double G = m.shear_modulus, K = m.bulk_modulus;
  const double E = 9 * K * G / (3 * K + G), nu = (3 * K - 2 * G) / (2 * (3 * K + G));
  const double D = E * t * t * t / (12 * (1 - nu * nu));
  const double omega = 10.2158 / (a * a) * std::sqrt(D / (m.density * t));  // clamped plate
  FemOptions o;
  o.hourglass = hourglass_form;
  o.gravity = g;
  o.damping = omega;
  FemModel model(m, b, o);
  model.set_side(FemSide::Outer, FemBc::Fixed);
  model.advance_to(6 * 2 * pi / omega);
  const FemEnergies e = model.energies();
  auto x = Kokkos::create_mirror_view_and_copy(HostSpace(), model.mesh().x);
  auto x0 = Kokkos::create_mirror_view_and_copy(HostSpace(), model.mesh().x0);
  const int mid = model.node(0, nz / 2);
  const double q = m.density * g * t;
  const double w_mindlin = q * std::pow(a, 4) / (64 * D) + q * a * a / (4 * (5.0 / 6.0) * G * t);
  return {e.internal, e.hourglass, e.kinetic, x0(mid, 1) - x(mid, 1), w_mindlin};
}
}  // namespace

TEST_CASE("FEM: hourglass energy stays small in plate bending", "[fem]") {
  // Bending-dominated: a clamped circular plate (a/t = 10) sagging under a body force, on
  // a mesh coarse through the thickness (4 elements), damped to rest. Within each element
  // the bending strain varies linearly through the thickness, which is exactly what a
  // one-point quad sees as an hourglass mode. Criterion (issue): hourglass energy below
  // 1 % of the internal energy, for both hourglass forms at the default coefficient 0.1,
  // on square elements (40 x 4). The centre deflection must be within 10 % of thick-plate
  // (Mindlin) theory: measured +5.5 % here, +0.9 % on 80 x 8 (coarse-mesh error).
  // Elements 4 times longer than thick (10 x 4) are printed, not checked: the FB
  // stiffness scales with the shortest side, so the stiffness form then stores about 4 %
  // (docs/fem.md, limitations).
  for (int nr : {40, 10})
    for (int form : {HOURGLASS_STIFFNESS, HOURGLASS_VISCOUS}) {
      const PlateResult p = sagging_plate(form, nr, 4);
      const char* name = form == HOURGLASS_STIFFNESS ? "stiffness" : "viscous";
      std::printf("[fem hourglass] %d x 4, %s form: E_hg / E_int = %.3f %% (E_int %.4e J, "
                  "E_kin / E_int %.1e); centre deflection %.4e m, Mindlin plate %.4e m (%+.1f %%)\n",
                  nr, name, 100 * p.e_hg / p.e_int, p.e_int, p.e_kin / p.e_int, p.w_centre,
                  p.w_mindlin, 100 * (p.w_centre / p.w_mindlin - 1));
      CHECK(p.e_int > 0);
      CHECK(p.e_hg >= 0);
      CHECK(p.e_kin < 1e-6 * p.e_int);  // at rest
      if (nr == 40) {
        CHECK(p.e_hg < 0.01 * p.e_int);
        CHECK(std::fabs(p.w_centre / p.w_mindlin - 1) < 0.10);
      }
    }
}

TEST_CASE("FEM: energy balance of a free vibration, hourglass work included", "[fem]") {
  // Elastic block [0, 0.1] x [0, 0.1] m on the axis, 8 x 8 elements, no loads, set moving
  // by a smooth field plus 30 % random nodal noise (which excites hourglass modes); 10^4
  // steps. Conserved by central differences for a linear system: the time-centred kinetic
  // energy (1/2) v^{n-1/2}.M v^{n+1/2} plus the internal energy at x^n plus the hourglass
  // work. Stiffness form: its stored energy at x^n; tolerance 1e-4 relative, worst over the
  // run (what is left is geometric nonlinearity and the Jaumann rotation; measured 1.7e-5).
  // Viscous form: the heat is booked for the kick at t^n in the next element pass, while
  // the centred kinetic energy has taken only half of that kick, so the mean of the heat
  // before and after that pass is paired; the residual is O(dt^2) (measured 1.2e-4 at
  // cfl 0.8, 6e-6 at 0.2); tolerance 5e-4.
  for (int form : {HOURGLASS_STIFFNESS, HOURGLASS_VISCOUS}) {
    FemBlock b;
    b.r0 = 0; b.r1 = 0.1; b.z0 = 0; b.z1 = 0.1;
    b.nr = 8; b.nz = 8;
    FemOptions o;
    o.hourglass = form;
    FemModel model(lab_clay(), b, o);
    const int nn = model.mesh().n_nodes;
    auto x = Kokkos::create_mirror_view_and_copy(HostSpace(), model.mesh().x);
    std::mt19937 gen(7);
    std::uniform_real_distribution<double> u(-1, 1);
    std::vector<double> vr(nn), vz(nn);
    for (int n = 0; n < nn; ++n) {
      vr[n] = x(n, 0) > 0 ? 0.01 * x(n, 0) / 0.1 + 0.003 * u(gen) : 0.0;
      vz[n] = 0.01 * std::sin(pi * x(n, 1) / 0.1) + 0.003 * u(gen);
    }
    model.set_velocities(vr, vz);
    const double E0 = model.energies().kinetic;
    auto mass = Kokkos::create_mirror_view_and_copy(HostSpace(), model.mesh().mass);
    auto v_old = Kokkos::create_mirror(HostSpace(), model.mesh().v);  // always a copy
    auto v_new = Kokkos::create_mirror(HostSpace(), model.mesh().v);
    model.step();
    Kokkos::deep_copy(v_old, model.mesh().v);
    FemEnergies e_old = model.energies();
    double worst = 0, hg_share = 0;
    for (int s = 0; s < 10000; ++s) {
      model.step();
      Kokkos::deep_copy(v_new, model.mesh().v);
      const FemEnergies e_new = model.energies();
      double kc = 0;
      for (int n = 0; n < nn; ++n)
        kc += 0.5 * mass(n) * (v_old(n, 0) * v_new(n, 0) + v_old(n, 1) * v_new(n, 1));
      const double hg = form == HOURGLASS_STIFFNESS ? e_old.hourglass
                                                    : 0.5 * (e_old.hourglass + e_new.hourglass);
      worst = std::max(worst, std::fabs((kc + e_old.internal + hg) / E0 - 1));
      hg_share = hg / E0;
      e_old = e_new;
      Kokkos::deep_copy(v_old, v_new);
    }
    std::printf("[fem energy] %s form: worst |E / E0 - 1| = %.2e over 10^4 steps; hourglass "
                "work at the end %.2f %% of E0\n",
                form == HOURGLASS_STIFFNESS ? "stiffness" : "viscous", worst, 100 * hg_share);
    CHECK(worst < (form == HOURGLASS_STIFFNESS ? 1e-4 : 5e-4));
  }
}

namespace {
// Wave energy of the FEM column: kinetic (half-step velocities) + stress work + hourglass.
double fem_wave_energy(const FemModel& m) {
  const FemEnergies e = m.energies();
  return e.kinetic + e.internal + e.hourglass;
}

// A 2 ms compression pulse driven into the top of a laterally confined FEM column of the lab
// clay (0.6 m, 2.5 mm elements, roller side) as in the particle test (test_boundaries.cpp);
// returns the energy left once the pulse has met the base, relative to the incident energy.
double fem_reflected_fraction(bool non_reflecting) {
  const double R = 0.02, L = 0.6, v0 = -0.01, pulse = 0.002;
  FemBlock b;
  b.r0 = 0; b.r1 = R; b.z0 = 0; b.z1 = L;
  b.nr = 8; b.nz = 240;
  FemModel model(lab_clay(), b);
  model.set_side(FemSide::Outer, FemBc::Roller);
  if (non_reflecting) model.set_non_reflecting(FemSide::Bottom, L);
  else model.set_side(FemSide::Bottom, FemBc::Roller);
  const double c = lab_clay().wave_speed();
  model.set_side(FemSide::Top, FemBc::Velocity, 0.0, v0);
  model.advance_to(pulse);
  model.set_side(FemSide::Top, FemBc::Velocity, 0.0, 0.0);  // held from now on
  model.advance_to((L - 0.15) / c);
  const double e_incident = fem_wave_energy(model);
  model.advance_to(L / c + pulse + 0.2 / c);
  const double e_left = fem_wave_energy(model);
  std::printf("[fem boundary] %s base (%ld steps): incident %.4e J, left after reflection %.4e J, ratio %.2f %%\n",
              non_reflecting ? "non-reflecting" : "roller", model.steps(), e_incident, e_left, 100 * e_left / e_incident);
  return e_left / e_incident;
}
}  // namespace

TEST_CASE("FEM: a pulse reaching a non-reflecting base leaves < 5 % of its energy", "[fem][boundaries][verification]") {
  // Tolerance 5 % (issue 3, test 5). The roller base beside it reflects the pulse: without
  // viscosity nearly all the energy stays.
  const double absorbed = fem_reflected_fraction(true);
  const double reflected = fem_reflected_fraction(false);
  CHECK(absorbed < 0.05);
  CHECK(reflected > 0.9);
}

TEST_CASE("FEM: a non-reflecting base with springs carries a lasting load (static settlement)", "[fem][boundaries][verification]") {
  // Step pressure q on the top of a laterally confined column on a viscous-spring base,
  // left to come to rest through the base dashpots alone. Exact: q L / M (column, uniform
  // strain: linear elements are exact) + q / K_n (base springs). Tolerance 0.5 %: the
  // mesh is exact for this state; what remains is the decay of the motion after 0.3 s.
  const double R = 0.02, L = 0.3, q = 1000.0;
  FemBlock b;
  b.r0 = 0; b.r1 = R; b.z0 = 0; b.z1 = L;
  b.nr = 4; b.nz = 60;
  FemModel model(lab_clay(), b);
  model.set_side(FemSide::Outer, FemBc::Roller);
  model.set_non_reflecting(FemSide::Bottom, L);
  // Consistent nodal forces of the pressure on the top face: q Int N_I 2 pi r dr.
  auto fext = Kokkos::create_mirror_view(model.mesh().f_ext);
  Kokkos::deep_copy(fext, 0.0);
  for (int i = 0; i < b.nr; ++i) {
    const double ra = R * i / b.nr, rb = R * (i + 1) / b.nr, len = rb - ra;
    fext(model.node(i, b.nz), 1) -= q * 2 * pi * len * (2 * ra + rb) / 6;
    fext(model.node(i + 1, b.nz), 1) -= q * 2 * pi * len * (ra + 2 * rb) / 6;
  }
  Kokkos::deep_copy(model.mesh().f_ext, fext);
  model.advance_to(0.3);
  auto x = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), model.mesh().x);
  auto v = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), model.mesh().v);
  double u = 0, vz = 0;
  for (int i = 0; i <= b.nr; ++i) {
    u += L - x(model.node(i, b.nz), 1);
    vz += v(model.node(i, b.nz), 1);
  }
  u /= b.nr + 1;
  vz /= b.nr + 1;
  const MaterialParams m = lab_clay();
  const double kn = 4 * m.shear_modulus / (3 * L), exact = q * L / m.p_wave_modulus() + q / kn;
  std::printf("[fem boundary] step load %.0f Pa on a spring base: settlement %.4e m, exact %.4e m, error %+.3f %%, "
              "top velocity %.1e m/s\n", q, u, exact, 100 * (u / exact - 1), vz);
  CHECK(std::fabs(u / exact - 1) < 0.005);
}

TEST_CASE("FEM: the energy account closes with gravity, mass damping and a viscous-spring base", "[fem][boundaries]") {
  // A laterally confined column of the lab clay, released without stress under gravity
  // onto a viscous-spring base (dashpots and springs, no held force), with a random
  // initial velocity and mass damping 20 1/s: it sags, rings and comes to rest. Every
  // energy goes somewhere the account books (FemEnergies, FemMesh::node_work): kinetic +
  // gravitational + stress work + hourglass work - boundary work - damping work stays at
  // its initial value. Tolerance 0.5 % of the energy that moved through the model
  // (gravity's release + the initial kinetic energy): while the column moves, the kinetic
  // energy (half steps) and the gravitational and stress energies (whole steps) are not
  // at the same time level. Measured (2026-12-03): worst 0.225 % at the default CFL 0.8,
  // 0.140 % at CFL 0.4 (it falls with the step), 0.04 % at rest at the end.
  const double R = 0.05, L = 0.3, g = 9.81;
  FemBlock b;
  b.r0 = 0; b.r1 = R; b.z0 = 0; b.z1 = L;
  b.nr = 5; b.nz = 30;
  FemOptions o;
  o.gravity = g;
  o.damping = 20.0;
  o.hourglass = HOURGLASS_VISCOUS;
  FemModel model(lab_clay(), b, o);
  model.set_side(FemSide::Outer, FemBc::Roller);
  model.set_non_reflecting(FemSide::Bottom, L);
  const int nn = model.mesh().n_nodes;
  auto x = Kokkos::create_mirror_view_and_copy(HostSpace(), model.mesh().x);
  std::mt19937 gen(11);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> vr(nn), vz(nn);
  for (int n = 0; n < nn; ++n) {
    vr[n] = x(n, 0) > 0 ? 0.01 * u(gen) : 0.0;
    vz[n] = 0.02 * u(gen);
  }
  model.set_velocities(vr, vz);
  auto account = [&] {
    const FemEnergies e = model.energies();
    return e.kinetic + model.potential_energy(g) + e.internal + e.hourglass - e.boundary_work - e.damping_work;
  };
  const double A0 = account(), P0 = model.potential_energy(g), K0 = model.energies().kinetic;
  double worst = 0;
  while (model.time() < 0.5) {
    model.step();
    worst = std::max(worst, std::fabs(account() - A0));
  }
  const FemEnergies e = model.energies();
  const double moved = (P0 - model.potential_energy(g)) + K0;
  std::printf("[fem account] released %.4e J (gravity %.4e, initial kinetic %.4e); at 0.5 s: kinetic %.2e, stress "
              "work %.4e, hourglass %.2e, boundary work %.4e, damping work %.4e J; worst |account - start| %.2e J "
              "(%.3f %%) over %ld steps, at the end %.2e J\n",
              moved, P0 - model.potential_energy(g), K0, e.kinetic, e.internal, e.hourglass, e.boundary_work,
              e.damping_work, worst, 100 * worst / moved, model.steps(), account() - A0);
  CHECK(e.damping_work < 0);
  CHECK(e.boundary_work < 0);
  CHECK(worst < 0.005 * moved);
}

TEST_CASE("FEM: atomic and scatter-view assembly give the same motion", "[fem]") {
  // Both race-free assemblies (FemOptions::assembly) must give the same forces; only the
  // order of the additions differs, so agreement to round-off (1e-12 of the motion) is the
  // tolerance.
  FemBlock b;
  b.r0 = 0; b.r1 = 0.2; b.z0 = 0; b.z1 = 0.2;
  b.nr = 12; b.nz = 12;
  std::vector<double> xs[2];
  for (int mode = 0; mode < 2; ++mode) {
    FemOptions o;
    o.gravity = 9.81;
    o.assembly = mode == 0 ? ASSEMBLY_SCATTER : ASSEMBLY_ATOMIC;
    FemModel model(lab_clay(), b, o);
    model.set_side(FemSide::Bottom, FemBc::Fixed);
    model.set_side(FemSide::Outer, FemBc::Roller);
    for (int k = 0; k < 200; ++k) model.step();
    auto x = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), model.mesh().x);
    auto x0 = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), model.mesh().x0);
    for (int i = 0; i < model.mesh().n_nodes; ++i) xs[mode].push_back(x(i, 1) - x0(i, 1));
  }
  double worst = 0, scale = 0;
  for (size_t i = 0; i < xs[0].size(); ++i) {
    worst = std::max(worst, std::fabs(xs[0][i] - xs[1][i]));
    scale = std::max(scale, std::fabs(xs[0][i]));
  }
  std::printf("[fem assembly] largest settlement %.4e m, largest difference scatter/atomic %.2e m\n", scale, worst);
  REQUIRE(scale > 0);
  CHECK(worst <= 1e-12 * scale);
}
