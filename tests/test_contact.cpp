// Rigid bodies and penalty contact (issue: main job, verification 1-3): the exact distance
// to a body of revolution, a rigid punch on Tresca clay, a block sliding on a rough particle
// surface, and the energy balance of a pounder dropped onto an elastic layer.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>

#include "SphTestUtil.hpp"

using namespace tamp;
using namespace tamp::testing;

TEST_CASE("Rigid profile: exact signed distance and outward normal of the barrel pounder", "[contact]") {
  // Tolerance 1e-12 m: the distance is computed in closed form from the polygon.
  const RigidProfile p = barrel_profile(0.09, 0.10, 0.2, 16);
  double nr, nz;
  // below the base on the axis: distance to the base face, normal down
  CHECK(p.signed_distance(0.0, -0.01, nr, nz) == Approx(0.01).margin(1e-12));
  CHECK(nz == Approx(-1.0).margin(1e-12));
  // beside the widest point (mid-height, r = 0.05): normal outward in r
  CHECK(p.signed_distance(0.06, 0.1, nr, nz) == Approx(0.01).margin(1e-12));
  CHECK(nr == Approx(1.0).margin(1e-12));
  // inside, near the base: negative, normal still outward (down)
  CHECK(p.signed_distance(0.01, 0.002, nr, nz) == Approx(-0.002).margin(1e-12));
  CHECK(nz == Approx(-1.0).margin(1e-12));
  // near the axis inside: the axis is not a surface (closest surface is the base, 5 mm)
  CHECK(p.signed_distance(1e-4, 0.005, nr, nz) == Approx(-0.005).margin(1e-12));
  // above the top face on the axis
  CHECK(p.signed_distance(0.0, 0.23, nr, nz) == Approx(0.03).margin(1e-12));
  CHECK(nz == Approx(1.0).margin(1e-12));
  // outside the base corner: distance to the corner point (0.045, 0)
  CHECK(p.signed_distance(0.048, -0.004, nr, nz) == Approx(0.005).margin(1e-12));
  CHECK(nr == Approx(0.6).margin(1e-12));
  CHECK(nz == Approx(-0.8).margin(1e-12));
}

namespace {

// Mean contact pressure (Pa) of a rigid circular punch of radius a pushed at constant
// speed into Tresca lab clay without gravity, averaged over settlements 0.1a..0.2a.
double punch_pressure(bool rough, double* su_out) {
  const double dp = 0.005, a = 0.05, R = 5 * a, H = 4 * a;
  Config cfg = column_config(R, H, dp);
  cfg.materials = {lab::clay("tresca")};
  cfg.gravity = 0.0;
  cfg.damping = 20.0;  // 1/s: quiet the elastic waves (mass-proportional; v = 0.05 m/s)
  cfg.contact.static_friction = cfg.contact.dynamic_friction = rough ? 10.0 : 0.0;
  Simulation sim(cfg);
  *su_out = cfg.materials[0].cohesion;
  const double v = 0.05;  // m/s, 0.1 % of the P-wave speed: quasi-static
  sim.set_rigid_body(rectangle_profile(0.0, a, 0.0, 0.05), 1.0);
  sim.set_body_kinematic(true);
  sim.place_body(0.0, H, 0.0, -v);
  std::vector<double> p;
  double last_print = 0;
  while (true) {
    sim.step();
    const double s = H - sim.body().z0;
    const double pressure = -sim.body().contact.force_z / (pi * a * a);
    if (s >= 0.1 * a) p.push_back(pressure);
    if (s - last_print >= 0.025 * a) {
      std::printf("[punch] %s s/a = %.3f  p/Su = %.3f\n", rough ? "rough" : "smooth", s / a, pressure / *su_out);
      last_print = s;
    }
    if (s >= 0.2 * a) break;
  }
  return std::accumulate(p.begin(), p.end(), 0.0) / p.size();
}

}  // namespace

TEST_CASE("Contact: rough rigid punch on Tresca clay reaches 6.05 Su within 10 %", "[contact][verification]") {
  // Eason & Shield (1960): limit pressure of a rough circular punch on a Tresca half-space
  // 6.05 Su (smooth: 5.69 Su). Tolerance 10 % (issue): the SPH punch has 10 particles
  // across its radius and the plateau is read at 0.1-0.2 a of settlement, where the
  // heave beside the punch has begun to add to the load.
  double su = 0;
  const double p_rough = punch_pressure(true, &su);
  std::printf("[punch] rough: mean p = %.4g Pa = %.3f Su (Eason-Shield 6.05 Su, error %+.1f %%)\n", p_rough, p_rough / su,
              100 * (p_rough / (6.05 * su) - 1));
  CHECK(std::fabs(p_rough / (6.05 * su) - 1) < 0.10);
}

TEST_CASE("Contact: smooth rigid punch on Tresca clay reaches 5.69 Su within 10 %", "[contact][verification]") {
  double su = 0;
  const double p_smooth = punch_pressure(false, &su);
  std::printf("[punch] smooth: mean p = %.4g Pa = %.3f Su (Eason-Shield 5.69 Su, error %+.1f %%)\n", p_smooth,
              p_smooth / su, 100 * (p_smooth / (5.69 * su) - 1));
  CHECK(std::fabs(p_smooth / (5.69 * su) - 1) < 0.10);
}

TEST_CASE("Contact: a rigid block sliding on a rough particle surface decelerates at mu_d g within 5 %",
          "[contact][verification]") {
  // The block is a ring (rectangular section 0.1 x 0.03 m) at radius R0 = 5 m, so that over
  // its 0.1 m width the axisymmetric surface is flat to 1 %; it slides outwards in r with
  // two free degrees of freedom (r, z) on three rows of stiff elastic particles on a fixed
  // base. Friction FS 0.5, FD 0.4 with DC = 1000 s/m: at the sliding speeds here (> 0.1 m/s)
  // mu = FD to 1e-40. Expected deceleration mu_d g = 3.924 m/s2; tolerance 5 % (issue).
  const double R0 = 5.0, dp = 0.01, g = 9.81;
  Config cfg;
  cfg.sph.spacing = dp;
  cfg.gravity = g;
  MaterialSpec m;
  m.name = "base";
  m.model = "elastic";
  m.density = 2000;
  m.shear_modulus = 40e6;
  m.poisson_ratio = 0.2;
  cfg.materials = {m};
  BlockSpec b;
  b.material = "base";
  b.r_min = R0 - 0.15; b.r_max = R0 + 0.45; b.z_min = 0; b.z_max = 0.03;
  cfg.blocks = {b};
  cfg.bottom = {WallType::Fixed, 0.0};
  cfg.initial_stress = "geostatic";
  cfg.contact.static_friction = 0.5;
  cfg.contact.dynamic_friction = 0.4;
  cfg.contact.decay = 1000.0;
  Simulation sim(cfg);
  const double w = 0.1, h = 0.03, rho_block = 7800;
  const double mass = rho_block * 2 * pi * R0 * w * h;  // ring mass
  sim.set_rigid_body(rectangle_profile(-0.5 * w, 0.5 * w, 0.0, h), mass, true, true);
  const double v0 = 0.6;
  sim.place_body(R0, 0.03, v0, 0.0);  // base on the top of the particle cells
  // fit v_r(t) by least squares while 0.5 > v_r > 0.15 (after the first contact transient)
  double st = 0, sv = 0, stt = 0, stv = 0;
  int n = 0;
  while (sim.body().v_r > 0.1 && sim.time() < 0.5) {
    sim.step();
    const double vr = sim.body().v_r, t = sim.time();
    if (vr < 0.5 && vr > 0.15) {
      st += t; sv += vr; stt += t * t; stv += t * vr; ++n;
    }
  }
  REQUIRE(n > 100);
  const double slope = (n * stv - st * sv) / (n * stt - st * st);
  const double expected = 0.4 * g;
  std::printf("[sliding] deceleration %.4f m/s2 (mu_d g = %.4f), error %+.2f %%, %d steps fitted\n", -slope, expected,
              100 * (-slope / expected - 1), n);
  CHECK(std::fabs(-slope / expected - 1) < 0.05);
}

TEST_CASE("Contact: pounder dropped onto an elastic layer, energy balance closes within 2 %", "[contact][verification]") {
  // Potential + kinetic + strain (and viscous heat) of the particles, kinetic + potential
  // of the pounder, and the energy taken by the contact (penalty springs, friction,
  // contact damping) must stay constant; tolerance 2 % of the blow's kinetic energy
  // (issue). Roller side and roller base: no energy leaves the model. (The same drop on a
  // fixed base, whose friction takes energy out, is in test_blow_physics.cpp.)
  Config cfg = column_config(0.3, 0.2, 0.01);
  cfg.bottom = {WallType::Roller, 0.0};
  cfg.materials = {lab::clay("elastic")};
  cfg.gravity = 9.81;
  cfg.initial_stress = "geostatic";
  Simulation sim(cfg);
  sim.set_rigid_body(barrel_profile(0.09, 0.1, 0.2, 16), 10.55);
  const double v0 = 2.0;
  sim.place_body(0.0, 0.2 + 0.001, 0.0, -v0);  // 1 mm above the top of the particle cells
  auto total = [&]() {
    const Energies e = sim.energies();
    return e.total() + sim.body_energy() + sim.contact_energy();
  };
  const double e0 = total(), blow = 0.5 * 10.55 * v0 * v0;
  double worst = 0;
  while (sim.time() < 0.06) {
    sim.step();
    worst = std::max(worst, std::fabs(total() - e0));
  }
  const Energies e = sim.energies();
  std::printf("[energy] %ld steps: blow %.3f J; end: particles KE %.3f, strain+heat %.3f, pounder %.3f (rel. start), "
              "contact %.4f J; worst imbalance %.4f J = %.3f %% of the blow\n",
              sim.steps(), blow, e.kinetic, e.internal, sim.body_energy() - (0.5 * 10.55 * v0 * v0 + 10.55 * 9.81 * 0.201),
              sim.contact_energy(), worst, 100 * worst / blow);
  CHECK(worst / blow < 0.02);
}
