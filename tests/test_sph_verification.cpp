// SPH verification against analytic solutions (issue: foundation, items 3-6).
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>

#include "SphTestUtil.hpp"

using namespace tamp;
using namespace tamp::testing;

namespace {
// Mean of a field over the particles with r < r_max and |z - z0| < tol.
template <class F>
double station_mean(const HostState& s, double r_max, double z0, double tol, F&& field) {
  double sum = 0;
  int n = 0;
  for (size_t i = 0; i < s.r.size(); ++i)
    if (s.r[i] < r_max && std::fabs(s.z[i] - z0) < tol) { sum += field(i); ++n; }
  REQUIRE(n > 0);
  return sum / n;
}
}  // namespace

TEST_CASE("SPH: 1D compression wave speed equals sqrt(M/rho)", "[sph][verification]") {
  // Column with roller side (laterally confined) -> uniaxial strain, speed sqrt(M / rho).
  // A velocity step is imposed on the top layer; the half-amplitude arrival times at two
  // stations give the speed, free of the start-up offset. Tolerance 3 % (issue): the
  // artificial viscosity spreads the front over a few h, symmetrically about its
  // half-amplitude point, so the speed measured there is unbiased to O(h/L).
  const double R = 0.02, L = 0.6, dp = 0.0025, v0 = -0.01;
  Config cfg = column_config(R, L, dp);
  cfg.sph.alpha = 0.2;
  Simulation sim(cfg);
  sim.prescribe_velocity({0, 1, L - dp, 1}, 0.0, v0);
  const MaterialParams m = sim.materials()[0];
  const double c_exact = m.wave_speed();
  const double z1 = 0.45125, z2 = 0.25125;  // particle centres (j + 1/2) dp
  double t1 = -1, t2 = -1, prev1 = 0, prev2 = 0, tprev = 0;
  while (t2 < 0 && sim.time() < 2 * L / c_exact) {
    sim.step();
    HostState s = host_state(sim);
    const double v1 = station_mean(s, R, z1, 0.5 * dp, [&](size_t i) { return s.vz[i]; });
    const double v2 = station_mean(s, R, z2, 0.5 * dp, [&](size_t i) { return s.vz[i]; });
    const double half = 0.5 * v0;
    auto crossing = [&](double prev, double now) {  // linear interpolation in time
      return tprev + (sim.time() - tprev) * (half - prev) / (now - prev);
    };
    if (t1 < 0 && v1 <= half) t1 = crossing(prev1, v1);
    if (t2 < 0 && v2 <= half) t2 = crossing(prev2, v2);
    prev1 = v1; prev2 = v2; tprev = sim.time();
  }
  REQUIRE(t1 > 0);
  REQUIRE(t2 > t1);
  const double c_sph = (z1 - z2) / (t2 - t1);
  std::printf("[wave] c_sph = %.3f m/s, sqrt(M/rho) = %.3f m/s, error %.2f %%\n", c_sph, c_exact,
              100 * (c_sph / c_exact - 1));
  CHECK(std::fabs(c_sph / c_exact - 1) < 0.03);
}

namespace {
// Elastic lab clay column, 0.4 m deep, radius 0.05 m, roller side and fixed base, loaded
// by gravity from zero stress and damped to rest (dynamic relaxation). Computed once and
// shared by the two geostatic tests below.
const HostState& relaxed_lab_clay_column() {
  static HostState state = [] {
    const double R = 0.05, L = 0.4, dp = 0.01;
    Config cfg = column_config(R, L, dp);
    cfg.gravity = 9.81;
    const double c = make_material(cfg.materials[0]).wave_speed();
    cfg.damping = 2 * pi / (4 * L / c);  // half of critical for the fundamental mode
    Simulation sim(cfg);
    sim.advance_to(25 * 4 * L / c);
    std::printf("[geostatic] relaxed: kinetic energy %.2e J after %ld steps\n", sim.energies().kinetic, sim.steps());
    return host_state(sim);
  }();
  return state;
}
constexpr double kColumnHeight = 0.4;

struct StressErrors { double worst_v = 0, worst_k = 0; int n = 0; };
// Worst relative errors of sigma_v against -gamma depth and of sigma_h/sigma_v against
// nu/(1-nu), over the particles with z in [z_lo, z_hi).
StressErrors geostatic_errors(const HostState& s, double z_lo, double z_hi) {
  const MaterialSpec clay = lab_clay_elastic();
  const double gamma = clay.density * 9.81, nu = clay.poisson_ratio;
  StressErrors e;
  for (size_t i = 0; i < s.r.size(); ++i) {
    if (s.z[i] < z_lo || s.z[i] >= z_hi) continue;
    const double sv = -gamma * (kColumnHeight - s.z[i]);
    e.worst_v = std::max(e.worst_v, std::fabs(s.szz[i] / sv - 1));
    e.worst_k = std::max(e.worst_k, std::fabs((s.srr[i] / s.szz[i]) / (nu / (1 - nu)) - 1));
    ++e.n;
  }
  return e;
}
}  // namespace

TEST_CASE("SPH: geostatic column of the lab clay (K0 = nu/(1-nu))", "[sph][verification]") {
  // Exact: sigma_v = -gamma d, sigma_h / sigma_v = nu / (1 - nu). Tolerances 3 % and 5 %
  // (issue), on every particle from 0.1 m above the base to 0.1 m below the surface
  // (the top 0.1 m is left out: relative errors of near-zero stresses mean nothing).
  // The base layer, next to the fixed base and its corners, is checked by the test below.
  const StressErrors e = geostatic_errors(relaxed_lab_clay_column(), 0.1, kColumnHeight - 0.1);
  std::printf("[geostatic] z in [0.10, 0.30) m, %d particles: worst sigma_v error %.2f %%, worst K0 error %.2f %%\n",
              e.n, 100 * e.worst_v, 100 * e.worst_k);
  REQUIRE(e.n > 0);
  CHECK(e.worst_v < 0.03);
  CHECK(e.worst_k < 0.05);
}

// The layer within 0.1 m (~7 h) of the fixed base, including the corner of the base and the
// outer wall, with the same exact solution and tolerances. Until the mirror-ghost fix this
// failed (61 % in sigma_v at the corner): the corner ghosts were placed from stale
// positions and went missing, so the corner particles fell through the base (docs/sph.md).
TEST_CASE("SPH: geostatic column, base layer and corners", "[sph][verification]") {
  const StressErrors e = geostatic_errors(relaxed_lab_clay_column(), 0.0, 0.1);
  std::printf("[geostatic] z in [0, 0.10) m, %d particles: worst sigma_v error %.2f %%, worst K0 error %.2f %%\n",
              e.n, 100 * e.worst_v, 100 * e.worst_k);
  CHECK(e.worst_v < 0.03);
  CHECK(e.worst_k < 0.05);
}

namespace {
// Relative error of the inner-wall radial displacement of the Lame ring at spacing dp.
double lame_inner_wall_error(double dp) {
  const double a = 0.1, b = 0.2, H = 0.04, p = 1e4;
  Config cfg;
  cfg.sph.spacing = dp;
  cfg.gravity = 0;
  MaterialSpec m;
  m.name = "stiff";
  m.model = "elastic";
  m.density = 2000;
  m.shear_modulus = 1e7;
  m.poisson_ratio = 0.3;
  cfg.materials = {m};
  BlockSpec blk;
  blk.material = m.name;
  blk.r_min = a; blk.r_max = b; blk.z_min = 0; blk.z_max = H;
  cfg.blocks = {blk};
  cfg.bottom = {WallType::Roller, 0.0};
  cfg.top = {WallType::Roller, H};
  const double c = make_material(m).wave_speed();
  cfg.damping = 2 * pi * c / (4 * (b - a));
  Simulation sim(cfg);
  sim.apply_surface_traction({a, a + dp, -1, 1}, p, 0.0, dp, a);
  const ParticleSnapshot s0 = sim.snapshot();
  sim.advance_to(40 * 4 * (b - a) / c);
  const ParticleSnapshot s1 = sim.snapshot();
  const double E = 2 * m.shear_modulus * (1 + m.poisson_ratio), nu = m.poisson_ratio;
  auto lame = [&](double r) { return (1 + nu) * p * a * a / (E * (b * b - a * a)) * ((1 - 2 * nu) * r + b * b / r); };
  double u_in = 0, u_out = 0;
  int n_in = 0, n_out = 0;
  for (size_t i = 0; i < s0.r.size(); ++i) {
    if (s0.r[i] < a + dp) { u_in += s1.r[i] - s0.r[i]; ++n_in; }
    if (s0.r[i] > b - dp) { u_out += s1.r[i] - s0.r[i]; ++n_out; }
  }
  u_in /= n_in;
  u_out /= n_out;
  const double e_in = u_in / lame(a + 0.5 * dp) - 1, e_out = u_out / lame(b - 0.5 * dp) - 1;
  std::printf("[lame] dp %.4f m: inner wall u = %.4e m (exact %.4e, error %.2f %%), outer u = %.4e (exact %.4e, %.2f %%)\n",
              dp, u_in, lame(a + 0.5 * dp), 100 * e_in, u_out, lame(b - 0.5 * dp), 100 * e_out);
  return e_in;
}
}  // namespace

TEST_CASE("SPH: thick-walled cylinder under internal pressure (Lame)", "[sph][verification]") {
  // Plane strain ring a = 0.1 m, b = 0.2 m between roller walls at z = 0 and z = H;
  // internal pressure p as a traction on the inner layer; damped to rest. Exact (Lame):
  //   u(r) = (1 + nu) p a^2 / (E (b^2 - a^2)) [ (1 - 2 nu) r + b^2 / r ].
  // Tolerance 5 % on the radial displacement of the inner wall (issue), at 40 particles
  // across the wall; the error must also shrink under refinement (it is first order:
  // the traction acts on a surface layer of thickness dp whose kernel is truncated;
  // measured 5.2 % at 20 particles across, 2.8 % at 40).
  const double e_coarse = lame_inner_wall_error(0.005);
  const double e_fine = lame_inner_wall_error(0.0025);
  CHECK(std::fabs(e_fine) < 0.05);
  CHECK(std::fabs(e_fine) < std::fabs(e_coarse));
}

namespace {

// Free vibration of an elastic block of the lab clay (no walls but the axis, no gravity, no
// damping, no artificial stress) on r0..r1, z0..z1, started by the velocity field
// v_r = 0.5 v0 sin(pi (r - r_mid) / (r1 - r0)) (r0 > 0) or 0.5 v0 sin(pi r / r1) (a block
// reaching the axis, zero there), v_z = v0 sin(pi (z - z_mid) / (z1 - z0)), v0 = 0.05 m/s
// (peak strain ~ v0 / c ~ 1e-3). Returns the worst relative change of the total energy
// (kinetic + internal), read every `every` steps, over `steps` steps; with `accounted`,
// of the energy less the work of the mirror images (Simulation::accounted_energy), and
// `images_worst` (if given) gets the largest |work of the axis images| / start energy.
double vibrating_block_worst_drift(double r0, double r1, double z0, double z1, double axis_radius_factor, int steps,
                                   int every, const char* label, bool accounted = false,
                                   double* images_worst = nullptr) {
  const double dp = 0.005;
  Config cfg;
  cfg.sph.spacing = dp;
  cfg.sph.axis_radius_factor = axis_radius_factor;
  cfg.gravity = 0;
  cfg.materials = {lab_clay_elastic()};
  cfg.sph.artificial_stress = 0.0;
  BlockSpec blk;
  blk.material = "clay";
  blk.r_min = r0; blk.r_max = r1; blk.z_min = z0; blk.z_max = z1;
  cfg.blocks = {blk};
  Simulation sim(cfg);
  {
    Particles& P = sim.particles();
    auto hx = Kokkos::create_mirror_view_and_copy(HostSpace(), P.x);
    auto hv = Kokkos::create_mirror_view_and_copy(HostSpace(), P.v);
    const double v0 = 0.05;
    for (int i = 0; i < P.n_real; ++i) {
      const double sr = r0 > 0 ? (hx(i, 0) - 0.5 * (r0 + r1)) / (r1 - r0) : hx(i, 0) / r1;
      hv(i, 0) = 0.5 * v0 * std::sin(pi * sr);
      hv(i, 1) = v0 * std::sin(pi * (hx(i, 1) - 0.5 * (z0 + z1)) / (z1 - z0));
    }
    Kokkos::deep_copy(P.v, hv);
  }
  auto energy = [&] { return accounted ? sim.accounted_energy() : sim.energies().total(); };
  const double e0 = energy();
  double worst = 0, images = 0;
  for (int k = 0; k < steps; ++k) {
    sim.step();
    if (k % every == every - 1) {
      worst = std::max(worst, std::fabs(energy() / e0 - 1));
      images = std::max(images, std::fabs(sim.image_work().axis_J / e0));
    }
  }
  const Energies e = sim.energies();
  std::printf("[%s] after %ld steps: kinetic %.4e J, internal %.4e J, axis images %.4e J, drift %.3f %% "
              "(worst %.3f %%)\n", label, sim.steps(), e.kinetic, e.internal, sim.image_work().axis_J,
              100 * (energy() / e0 - 1), 100 * worst);
  if (images_worst) *images_worst = images;
  return worst;
}

}  // namespace

TEST_CASE("SPH: elastic block free vibration conserves energy", "[sph][verification]") {
  // Free elastic block (no walls but the axis, no gravity, no damping) set vibrating by
  // a smooth velocity field; 10^4 steps. The total energy (kinetic + internal, the
  // latter including the heat of the artificial viscosity) must stay within 1 % of its
  // start (issue): the leapfrog scheme has no secular drift, so only the mismatch between
  // the discrete stress power and the discrete force work remains. The artificial stress
  // is off: it is a non-conservative stabiliser against tensile instability (with it on,
  // measured: 0.2 % final, 3 % worst drift), and the kernel correction is off (default)
  // for the same reason.
  CHECK(vibrating_block_worst_drift(0.05, 0.15, 0.0, 0.1, 0.25, 10000, 100, "energy") < 0.01);
}

TEST_CASE("SPH: elastic block at the axis, inside the regularised radius, conserves energy", "[sph][verification]") {
  // The same free vibration on a block that reaches the axis, with the regularised radius
  // c h (axis_radius_factor 0.6: 0.9 dp) beyond the first column of particles (0.5 dp), so
  // that the pair terms of particles inside c h and the axis ghosts are exercised. The
  // semi-discrete equations conserve energy exactly only if the pair term m_b sigma_b /
  // (2 pi r~_b rho_b^2) uses the same r~_b as b's strain rate (docs/sph.md, condition 3);
  // until 2026-12-01 it used max(r, 1e-3 dp). Tolerance 0.2 % of the start over 4000
  // steps: the time integration alone drifts the off-axis block above by 0.145 %, and with
  // the real pairs conjugate nothing else should add to it. Measured: 0.139 % (the former
  // floor: 0.291 %). Not covered: the pairs with axis ghosts are one-sided and not
  // conjugate inside c h; with c h = 2.25 dp (factor 1.5) the block drifts 2.9 % (2.2 % with
  // the former floor), so the default factor stays small (0.25) - docs/sph.md.
  CHECK(vibrating_block_worst_drift(0.0, 0.1, 0.0, 0.1, 0.6, 4000, 50, "energy, axis") < 0.002);
}

TEST_CASE("SPH: the work of the axis images closes the energy of a block at the axis", "[sph][verification]") {
  // The pairs of real particles with axis images are one-sided: their stress terms are not
  // the conjugates of the strain rates, and they feed or take energy (docs/sph.md, "Energy
  // of the image pairs"). With a regularised radius of 2.25 dp (axis_radius_factor 1.5)
  // the free vibration of the block at the axis drifts by ~3 % in total energy; the energy
  // account sums that work per pair (Acceleration's image_power), so the total energy less
  // the images' work must hold to the time integration's level: tolerance 0.2 % over 4000
  // steps, as for the block above (time integration alone: 0.145 % in 10^4 steps). The
  // images' work itself must be the larger part of the uncorrected drift (above 1 % of the
  // start energy), or the test would not exercise it.
  double images = 0;
  const double raw = vibrating_block_worst_drift(0.0, 0.1, 0.0, 0.1, 1.5, 4000, 50, "energy, axis, raw");
  const double closed = vibrating_block_worst_drift(0.0, 0.1, 0.0, 0.1, 1.5, 4000, 50, "energy, axis, accounted", true, &images);
  CHECK(raw > 0.01);
  CHECK(images > 0.01);
  CHECK(closed < 0.002);
}

TEST_CASE("SPH: geostatic initial stress of layered blocks", "[sph]") {
  // initial_stress = "geostatic": sigma_zz is minus the weight per area of the blocks
  // above each particle, sigma_h = nu/(1-nu) sigma_zz of the particle's material. Exact
  // arithmetic: tolerance 1e-12 relative.
  Config cfg = column_config(0.05, 0.4, 0.01);
  cfg.gravity = 9.81;
  cfg.initial_stress = "geostatic";
  MaterialSpec sand = lab_clay_elastic();
  sand.name = "sand";
  sand.density = 18.0e3 / 9.81;
  sand.poisson_ratio = 0.2;
  cfg.materials.push_back(sand);
  cfg.blocks[0].z_min = 0.2;  // clay 0.2-0.4 m over sand 0-0.2 m
  BlockSpec lower = cfg.blocks[0];
  lower.material = "sand";
  lower.z_min = 0.0;
  lower.z_max = 0.2;
  cfg.blocks.push_back(lower);
  Simulation sim(cfg);
  const HostState s = host_state(sim);
  double worst = 0;
  for (size_t i = 0; i < s.r.size(); ++i) {
    const double z = s.z[i];
    const double sv = z >= 0.2 ? -18.7e3 * (0.4 - z) : -18.7e3 * 0.2 - 18.0e3 * (0.2 - z);
    const double k0 = z >= 0.2 ? 0.31 / 0.69 : 0.2 / 0.8;
    worst = std::max({worst, std::fabs(s.szz[i] / sv - 1), std::fabs(s.srr[i] / (k0 * sv) - 1),
                      std::fabs(s.stt[i] / (k0 * sv) - 1)});
  }
  CHECK(worst < 1e-12);
}

TEST_CASE("SPH: geostatic initial stress of 20 layers (no limit on the number of blocks)", "[sph]") {
  // Issue 13: 17 blocks with initial_stress = "geostatic" were refused ("more than 16
  // blocks", a limit no document named). The layers now live in a view of any length
  // (kernels/Geostatic.hpp). 20 layers of 0.02 m alternating the lab clay and a lighter
  // copy of it: sigma_zz = -sum of gamma_k h_k above, exact arithmetic (1e-12 relative).
  Config cfg = column_config(0.05, 0.4, 0.01);
  cfg.gravity = 9.81;
  cfg.initial_stress = "geostatic";
  MaterialSpec light = lab_clay_elastic();
  light.name = "light";
  light.density = 15.0e3 / 9.81;
  cfg.materials.push_back(light);
  const BlockSpec proto = cfg.blocks[0];
  cfg.blocks.clear();
  for (int k = 0; k < 20; ++k) {
    BlockSpec b = proto;
    b.material = k % 2 ? "light" : "clay";
    b.z_min = 0.02 * k;
    b.z_max = 0.02 * (k + 1);
    cfg.blocks.push_back(b);
  }
  Simulation sim(cfg);
  const HostState s = host_state(sim);
  double worst = 0;
  for (size_t i = 0; i < s.r.size(); ++i) {
    double sv = 0;
    for (int k = 0; k < 20; ++k) {
      const double lo = std::max(s.z[i], 0.02 * k), hi = 0.02 * (k + 1);
      if (hi > lo) sv -= (k % 2 ? 15.0e3 : 18.7e3) * (hi - lo);
    }
    worst = std::max(worst, std::fabs(s.szz[i] / sv - 1));
  }
  std::printf("[sph] 20 geostatic layers: worst sigma_zz error %.1e\n", worst);
  CHECK(worst < 1e-12);
}

// The head-on viscosity (docs/sph.md "Head-on viscosity") on one pair of particles far from
// the axis (r = 5 m, so that the two rings weigh the same), no walls, no gravity, zero stress:
// particle a approaches b at speed U with its velocity at an angle gamma to the line of
// centres. The viscous heating of the pair (kernels/SphSolid.hpp: each particle books half
// of Pi_ab v_ab . grad W_ab) with the materials' viscosity_head_on s_a, s_b, relative to
// Monaghan's (both 0), must be 1 - s (1 - cos gamma), s = (s_a + s_b) / 2: 1 head on, cos
// gamma for two granular particles, (1 + cos gamma) / 2 for a mixed pair. One step of 1e-6 s
// at U = 0.1 m/s: the geometry moves by 1e-5 of the spacing, and cos gamma is taken from the
// positions after it; tolerance 1e-9 relative (round-off of the pair sums).
TEST_CASE("SPH: the head-on viscosity damps a pair's approach by the cosine of its angle to the line of centres",
          "[sph]") {
  const double dp = 0.01, U = 0.1, r0 = 5.0, z0 = 0.5;
  // the heat rate of particle a (W/kg) and cos gamma after one step, the pair at angle theta
  // (to the r axis) approaching at gamma, with head-on shares s_a (the added particle), s_b
  auto heat = [&](double theta, double gamma, double s_a, double s_b) {
    Config cfg = column_config(r0 + dp, dp, dp);
    cfg.blocks[0].r_min = r0;
    cfg.blocks[0].z_min = z0;
    cfg.blocks[0].z_max = z0 + dp;
    cfg.bottom = {WallType::None, 0.0};
    cfg.outer = {WallType::None, 0.0};
    MaterialSpec a = lab_clay_elastic(), b = lab_clay_elastic();
    b.viscosity_head_on = s_b;
    a.name = "moving";
    a.viscosity_head_on = s_a;
    cfg.materials = {b, a};
    Simulation sim(cfg);
    REQUIRE(sim.particle_count() == 1);
    const double rb = r0 + 0.5 * dp, zb = z0 + 0.5 * dp;
    sim.add_particles({{rb + dp * std::cos(theta), zb + dp * std::sin(theta), 1}});
    auto v = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), sim.particles().v);
    auto x = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), sim.particles().x);
    const int ia = x(0, 0) > rb + 0.1 * dp || x(0, 1) > zb + 0.1 * dp ? 0 : 1;  // the added one
    v(ia, 0) = -U * std::cos(theta + gamma);
    v(ia, 1) = -U * std::sin(theta + gamma);
    Kokkos::deep_copy(sim.particles().v, v);
    sim.step(1e-6);
    Kokkos::deep_copy(x, sim.particles().x);
    auto q = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), sim.particles().du_visc);
    const double dr = x(ia, 0) - x(1 - ia, 0), dz = x(ia, 1) - x(1 - ia, 1);
    const double cos_gamma = (U * std::cos(theta + gamma) * dr + U * std::sin(theta + gamma) * dz) /
                             (U * std::hypot(dr, dz));
    REQUIRE(q(ia) > 0);
    return std::make_pair(q(ia), cos_gamma);
  };
  const double deg = M_PI / 180.0;
  for (double theta : {30.0 * deg, 120.0 * deg}) {
    const auto [h0, c0] = heat(theta, 0.0, 0.0, 0.0);
    const auto [h1, c1] = heat(theta, 0.0, 1.0, 1.0);
    std::printf("[sph] head-on viscosity, head on: heat %.6e (Monaghan) %.6e (s = 1)\n", h0, h1);
    CHECK(h1 == Approx(h0).epsilon(1e-9));
    for (double gamma : {60.0 * deg, 80.0 * deg}) {
      const auto [m, cm] = heat(theta, gamma, 0.0, 0.0);
      const auto [g, cg] = heat(theta, gamma, 1.0, 1.0);
      const auto [mixed, cx] = heat(theta, gamma, 1.0, 0.0);
      std::printf("[sph] head-on viscosity at %.0f deg: granular %.6f (cos %.6f), mixed %.6f (%.6f)\n", gamma / deg,
                  g / m, cg, mixed / m, 0.5 * (1 + cx));
      CHECK(g / m == Approx(cg).epsilon(1e-9));
      CHECK(mixed / m == Approx(0.5 * (1.0 + cx)).epsilon(1e-9));
    }
  }
}
