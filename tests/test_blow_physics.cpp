// The blow as the lab saw it (issue: every blow ends at rest in contact, rebounds are
// followed, each blow's energy is accounted for) and the fixed wall that holds what
// slides on it. Physics checks against closed-form answers; tolerances stated per test.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "SphTestUtil.hpp"
#include "core/Log.hpp"
#include "core/Output.hpp"
#include "drivers/sequence/DropSequence.hpp"

using tamp::BlockSpec;
using tamp::Config;
using tamp::DropSequence;
using tamp::Energies;
using tamp::MaterialSpec;
using tamp::Simulation;
using tamp::WallType;
using tamp::testing::column_config;
using tamp::testing::env_or;
using tamp::testing::glued_base;
namespace fs = std::filesystem;

namespace {

std::string fresh_dir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("tamp_test_" + name);
  fs::remove_all(p);
  fs::create_directories(p);
  return p.string();
}

MaterialSpec elastic(const std::string& name, double G, double nu, double unit_weight) {
  MaterialSpec m;
  m.name = name;
  m.model = "elastic";
  m.density = unit_weight / 9.81;
  m.shear_modulus = G;
  m.poisson_ratio = nu;
  return m;
}

}  // namespace

namespace {

// A flat cylinder (the lab pounder's mass and base, max_diameter = base_diameter) dropped
// 0.1 m onto an elastic layer as wide as its base, between a roller axis, a roller side
// wall at r = a and a roller base: a column in uniaxial strain. Known response: the
// static settlement under the weight W is s = W H / (M pi a^2), M = K + 4G/3 (exact for
// the linear column; the strain here is 1.5 %, so the geometric nonlinearity is below
// 0.1 %). The layer is soft (G = 0.3 MPa) so that s = 3 mm is 0.6 spacing and the step is
// long; mass-proportional damping of the layer (150 1/s, deck `damping`: about 12 % of
// critical for the pounder on the column, so that it still rebounds) lets the rebounds die
// out in under a second without changing the static answer.
struct ElasticLayerDrop {
  double a = 0.045, H = 0.2, dp = 0.005;
  double s_exact = 0, z_touch = 0, z_rest = 0, e_traj = 0;
  long steps = 0;
  tamp::BlowRecord blow;
  std::vector<std::vector<double>> pounder;  // pounder.csv: time, blow, base_z, v_z, a_z, force_z
};

ElasticLayerDrop drop_on_elastic_layer(const std::string& flight, const std::string& name) {
  ElasticLayerDrop d;
  Config cfg = column_config(d.a, d.H, d.dp);
  cfg.materials = {elastic("layer", 3.0e5, 0.31, 18.7e3)};
  cfg.blocks[0].material = "layer";
  cfg.bottom = {WallType::Roller, 0.0};
  cfg.outer = {WallType::Roller, d.a};
  cfg.gravity = 9.81;
  cfg.damping = 150.0;
  cfg.initial_stress = "geostatic";
  cfg.pounder.base_diameter = cfg.pounder.max_diameter = 2 * d.a;
  cfg.schedule.enabled = true;
  cfg.schedule.drop_heights = {0.1};
  cfg.schedule.drop_height_from = "surface";
  cfg.schedule.relax_time = 0.3;
  cfg.schedule.max_impact_time = 4.0;
  // at rest: below 5 mm/s (an oscillation of at most 0.1 mm about the rest position at the
  // pounder's 57 rad/s on this column), then 0.2 s of damped settling
  cfg.schedule.rest_speed = 0.005;
  cfg.schedule.rest_time = 0.2;
  cfg.schedule.tracer_interval = 1e-4;
  cfg.schedule.flight = flight;
  const std::string dir = fresh_dir(name);
  Simulation sim(cfg);
  DropSequence seq(sim, cfg, dir);
  seq.set_stage_files(false);
  seq.run(0);  // relax
  // reference surface: where the base touches the relaxed layer (top particle + dp/2)
  const auto relaxed = tamp::testing::host_state(sim);
  d.z_touch = *std::max_element(relaxed.z.begin(), relaxed.z.end()) + 0.5 * d.dp;
  const long steps0 = sim.steps();
  seq.run(1);  // the impact
  d.steps = sim.steps() - steps0;
  seq.write_tables(0.0);
  d.blow = seq.blows().at(0);
  const tamp::MaterialParams m = sim.materials()[0];
  d.s_exact = cfg.pounder.mass * 9.81 * d.H / (m.p_wave_modulus() * M_PI * d.a * d.a);
  d.pounder = tamp::testing::read_csv(dir + "/pounder.csv");
  REQUIRE(d.pounder.size() > 10);
  const double W = cfg.pounder.mass * 9.81;
  // first record with a contact force above 1 % of the weight
  size_t first = 0;
  while (first < d.pounder.size() && d.pounder[first][5] <= 0.01 * W) ++first;
  REQUIRE(first < d.pounder.size());
  d.z_rest = d.pounder.back()[2];
  // restitution from the trajectory: the largest upward speed after the first contact,
  // before the next landing, over the speed at the first contact
  double up = 0;
  size_t k = first;
  while (k < d.pounder.size() && d.pounder[k][5] > 0.01 * W) up = std::max(up, d.pounder[k][3]), ++k;  // in contact
  while (k < d.pounder.size() && d.pounder[k][5] <= 0.01 * W) up = std::max(up, d.pounder[k][3]), ++k;  // first flight
  d.e_traj = up / std::fabs(d.pounder[first][3]);
  const double s_sim = d.z_touch - d.z_rest;
  std::printf("[blow, elastic layer, flight %s] settlement %.4f mm (exact %.4f, %+.2f %%); contacts %.0f; restitution "
              "%.4f (trajectory %.4f); at rest in contact %.0f after %.3f s in contact, %.3f s in flight (%.3f s "
              "ballistic), %ld steps; energy residual %.4f J of %.3f J\n",
              flight.c_str(), 1e3 * s_sim, 1e3 * d.s_exact, 100 * (s_sim / d.s_exact - 1), d.blow.contacts,
              d.blow.restitution, d.e_traj, d.blow.rest_in_contact, d.blow.contact_time_s, d.blow.flight_time_s,
              d.blow.ballistic_time_s, d.steps, d.blow.residual_J, d.blow.energy_in_J);
  return d;
}

}  // namespace

TEST_CASE("Blow: a pounder dropped on a confined elastic layer rebounds, lands again and rests at its static "
          "settlement within 5 %",
          "[blow][verification]") {
  // Tolerance 5 % (issue): the particles' free-surface layer under the punch makes SPH
  // columns a few per cent softer (docs/coupling.md, the punch study).
  tamp::log::set_level(tamp::log::Level::Quiet);
  const ElasticLayerDrop d = drop_on_elastic_layer("followed", "blow_elastic");
  const tamp::BlowRecord& b = d.blow;
  const double s_sim = d.z_touch - d.z_rest;
  CHECK(b.rest_in_contact == 1.0);
  CHECK(b.contacts >= 2);  // it rebounded and landed again
  CHECK(b.flight_time_s > 0.01);
  CHECK(b.ballistic_time_s == 0.0);  // every flight followed
  CHECK(std::fabs(s_sim / d.s_exact - 1) < 0.05);
  // the pounder.csv rows are 0.1 ms apart: the recorded peak upward speed can exceed the
  // sampled one by at most (largest deceleration) x 0.1 ms; 2 % of the value covers it
  CHECK(b.restitution > 0.05);
  CHECK(d.e_traj == Approx(b.restitution).epsilon(0.02));
  // the blow table's crater depth is the same rest position (ground = top of the blocks)
  CHECK(b.crater_depth_m == Approx(d.H - d.z_rest).margin(1e-12));
  tamp::log::set_level(tamp::log::Level::Info);
}

TEST_CASE("Blow: rebound flights advanced ballistically follow the free fall, and the blow rests at the same "
          "settlement as with every flight followed",
          "[blow][verification]") {
  // schedule.flight = "ballistic" (docs/drop-sequence.md): after flight_relax_time (20 ms)
  // of damped soil relaxation, each long rebound flight jumps to where the pounder's free
  // fall meets the soil. Against the same drop with every flight followed: the same first
  // rebound (the runs are identical until the first jump: restitution equal to round-off),
  // the static settlement within the 5 % of the test above (the landings are on a layer
  // relaxed by 20 ms of damping instead of one that kept vibrating: the rest positions of
  // the two runs differ by a few micrometres), and fewer steps. Through every jump the
  // pounder's rows in pounder.csv are its free fall: z and v_z of consecutive rows obey
  // v^2 - v0^2 = -2 g (z - z0) to 1e-9 m2/s2 (exact arithmetic of a parabola; the rows are
  // written from the same formula). Energy account: the jump moves no particle and keeps
  // the pounder's kinetic + potential energy, so the residual stays below 2 % of the blow.
  tamp::log::set_level(tamp::log::Level::Quiet);
  const ElasticLayerDrop f = drop_on_elastic_layer("followed", "blow_followed");
  const ElasticLayerDrop j = drop_on_elastic_layer("ballistic", "blow_ballistic");
  CHECK(j.blow.ballistic_time_s > 0.1);  // at least the first, long flight was jumped
  CHECK(j.blow.rest_in_contact == 1.0);
  CHECK(j.blow.contacts >= 2);
  CHECK(j.blow.restitution == Approx(f.blow.restitution).epsilon(1e-9));
  CHECK(std::fabs((j.z_touch - j.z_rest) / j.s_exact - 1) < 0.05);
  CHECK(j.steps < f.steps);
  CHECK(std::fabs(j.blow.residual_J) < 0.02 * j.blow.energy_in_J);
  // free fall through the jumps: the rows without contact force and with a = -g
  int fall_rows = 0;
  double worst = 0;
  for (size_t k = 1; k < j.pounder.size(); ++k) {
    const auto& p0 = j.pounder[k - 1];
    const auto& p1 = j.pounder[k];
    if (p0[5] != 0.0 || p1[5] != 0.0 || p0[4] != -9.81 || p1[4] != -9.81) continue;
    worst = std::max(worst, std::fabs(p1[3] * p1[3] - p0[3] * p0[3] + 2 * 9.81 * (p1[2] - p0[2])));
    ++fall_rows;
  }
  std::printf("[blow, ballistic] %d free-fall row pairs, worst energy mismatch %.2e m2/s2; steps %ld vs %ld followed\n",
              fall_rows, worst, j.steps, f.steps);
  CHECK(fall_rows > 100);
  CHECK(worst < 1e-9);
  tamp::log::set_level(tamp::log::Level::Info);
}

TEST_CASE("Wall: pounder dropped onto an elastic layer on a fixed base, energy balance closes within 2 %",
          "[blow][contact][verification]") {
  // The drop of test_contact.cpp ("energy balance closes within 2 %") on a fixed (rough)
  // base instead of a roller: the fixed wall is a roller mirror plus Coulomb friction
  // (kernels/WallFriction.hpp), whose work is in the account. The former no-slip mirror
  // gained ~40 J (+187 % of the blow) here. Tolerance 2 % of the blow's kinetic energy (issue).
  Simulation sim(tamp::testing::elastic_clay_layer(WallType::Fixed));
  const double worst = tamp::testing::drop_pounder_worst_imbalance(sim), blow = 0.5 * 10.55 * 2.0 * 2.0;
  std::printf("[energy, fixed base] %ld steps: blow %.3f J; wall friction %.4f J, contact %.4f J; worst imbalance "
              "%.4f J = %.3f %% of the blow\n",
              sim.steps(), blow, -sim.ledger().wall_friction_J, sim.contact_energy(), worst, 100 * worst / blow);
  CHECK(worst / blow < 0.02);
}

TEST_CASE("Wall: a cohesionless grain pushed along a fixed base stops after v0^2 / (2 g tan phi) within 5 %",
          "[blow][boundaries][verification]") {
  // One aggregate particle (phi = 47 deg, c = 0) resting on a fixed base, far from the axis
  // (r = 2 m: over the slide the hoop strain stays below 0.25 %), given a radial speed v0.
  // (Until 2026-12-07 at r = 0.5 m: there the ring's hoop strain, 0.9 % over the slide,
  // unloads the grain's support and it sinks into its mirror while it slides: +2.4 % with
  // the deck's alpha 0.5, +6.4 % with the aggregate's 0.1; at 2 m +1.7 / +2.0 %, at 5 m
  // +0.9 / +0.9 %: the excess is the hoop term's, not the wall's.)
  // The wall's Coulomb friction tan(phi) a_n with a_n = g on average stops it after
  // L = v0^2 / (2 g tan phi). Tolerance 5 %: the grain rocks on its mirror image, so the
  // normal support fluctuates about g, and the cap at stick ends the slide within a step.
  Config cfg = column_config(2.1, 0.01, 0.01);
  cfg.materials = {tamp::lab::aggregate()};
  cfg.blocks[0].material = "aggregate";
  cfg.blocks[0].r_min = 2.0;
  cfg.blocks[0].r_max = 2.01;
  cfg.bottom = {WallType::Fixed, 0.0};
  cfg.outer = {WallType::None, 0.0};
  cfg.gravity = 9.81;
  Simulation sim(cfg);
  // settle on the base first (damped), then push
  sim.set_damping(60.0);
  sim.advance_to(0.2);
  sim.set_damping(0.0);
  auto state = [&]() { return tamp::testing::host_state(sim); };
  tamp::testing::HostState s0 = state();
  REQUIRE(s0.r.size() == 1);
  const double v0 = 0.3;
  {
    auto v = sim.particles().v;
    Kokkos::parallel_for("test::push", Kokkos::RangePolicy<tamp::ExecSpace>(0, 1), KOKKOS_LAMBDA(int i) { v(i, 0) = v0; });
  }
  const double t0 = sim.time();
  double t_stop = -1;
  while (sim.time() - t0 < 0.2) {
    sim.step();
    const auto s = state();
    if (t_stop < 0 && std::fabs(s.vr[0]) < 1e-9) t_stop = sim.time() - t0;
  }
  const auto s1 = state();
  const double L = s1.r[0] - s0.r[0];
  const double L_exact = v0 * v0 / (2 * 9.81 * std::tan(47.0 * M_PI / 180.0));
  std::printf("[wall friction] grain slid %.4f mm (exact %.4f, %+.2f %%), stopped after %.4f s (exact %.4f), end "
              "speed %.2e m/s, height above base %.4f mm\n",
              1e3 * L, 1e3 * L_exact, 100 * (L / L_exact - 1), t_stop, v0 / (9.81 * std::tan(47.0 * M_PI / 180.0)),
              s1.vr[0], 1e3 * s1.z[0]);
  CHECK(std::fabs(L / L_exact - 1) < 0.05);
  CHECK(std::fabs(s1.vr[0]) < 1e-6);  // at rest
}

// ---------------------------------------------------------------------------------------
// The aggregate as a poured material (docs/drop-sequence.md). The lab's aggregate
// (cohesionless Mohr-Coulomb, phi = 47 deg, psi = 0, 10 mm particles, one per grain) on a
// fixed (rough) base, undamped, under gravity.
namespace {

// A cone of the aggregate with flank angle beta (deg) and base radius R0 (m) at zero
// stress, as a charge is created: one block per particle row.
Config aggregate_cone(double beta_deg, double R0, double dp, double domain_radius) {
  Config cfg = column_config(domain_radius, 0.01, dp);
  cfg.materials = {tamp::lab::aggregate()};
  cfg.blocks.clear();
  const double tb = std::tan(beta_deg * M_PI / 180.0);
  for (int j = 0; (j + 0.5) * dp < R0 * tb; ++j) {
    BlockSpec b;
    b.material = "aggregate";
    b.z_min = j * dp;
    b.z_max = (j + 1) * dp;
    b.r_min = 0;
    b.r_max = dp * std::round((R0 - (j + 0.5) * dp / tb) / dp);
    if (b.r_max < dp) break;
    cfg.blocks.push_back(b);
  }
  cfg.bottom = {WallType::Fixed, 0.0};
  cfg.outer = {WallType::None, 0.0};
  cfg.gravity = 9.81;
  return cfg;
}

// The heap's shape: its height, its flank angle (a least-squares line through the tops of
// the radial bands of width dp whose top lies between 20 % and 80 % of the height) and its
// fastest particle.
struct HeapShape {
  double height = 0, flank_deg = 0, vmax = 0;
  int bands = 0;
};

HeapShape heap_shape(const Simulation& sim, double dp, double domain_radius) {
  const auto s = tamp::testing::host_state(sim);
  HeapShape h;
  const int nb = static_cast<int>(domain_radius / dp);
  std::vector<double> surf(nb, 0.0);
  for (size_t i = 0; i < s.r.size(); ++i) {
    h.vmax = std::max(h.vmax, std::hypot(s.vr[i], s.vz[i]));
    h.height = std::max(h.height, s.z[i] + 0.5 * dp);
    const int k = std::min(nb - 1, static_cast<int>(s.r[i] / dp));
    surf[k] = std::max(surf[k], s.z[i] + 0.5 * dp);
  }
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (int k = 0; k < nb; ++k)
    if (surf[k] > 0.2 * h.height && surf[k] < 0.8 * h.height) {
      const double r = (k + 0.5) * dp;
      sx += r; sy += surf[k]; sxx += r * r; sxy += r * surf[k];
      ++h.bands;
    }
  const int n = h.bands;
  if (n >= 3) h.flank_deg = std::atan(-(n * sxy - sx * sy) / (n * sxx - sx * sx)) * 180.0 / M_PI;
  return h;
}

// The slope (deg) at which a Mohr-Coulomb layer (friction phi, dilation psi) flowing in simple
// shear stops: Davis (1968), tan = sin(phi) cos(psi) / (1 - sin(phi) sin(psi)); 36.2 at phi
// 47, psi 0.
double simple_shear_repose_deg(double phi_deg, double psi_deg) {
  const double sp = std::sin(phi_deg * M_PI / 180.0), psi = psi_deg * M_PI / 180.0;
  return std::atan(sp * std::cos(psi) / (1.0 - sp * std::sin(psi))) * 180.0 / M_PI;
}

// The particles of a heap as CSV (r, z, velocity, density, stress, mass), for a look: written
// where the environment variable `var` points, if it is set (docs/drop-sequence.md).
void dump_heap(const Simulation& sim, const char* var, int index = -1) {
  const char* env = std::getenv(var);
  if (!env) return;
  std::string path = env;  // with an index: heap.csv -> heap-<index>.csv
  if (index >= 0) {
    const auto dot = path.rfind('.');
    path = (dot == std::string::npos ? path : path.substr(0, dot)) + "-" + std::to_string(index) +
           (dot == std::string::npos ? "" : path.substr(dot));
  }
  const auto s = sim.snapshot();
  std::vector<std::vector<double>> rows;
  for (size_t i = 0; i < s.r.size(); ++i)
    rows.push_back({s.r[i], s.z[i], s.v_r[i], s.v_z[i], s.density[i], s.s_rr[i], s.s_zz[i], s.s_tt[i], s.s_rz[i],
                    s.mass[i]});
  tamp::write_csv(path, {"r", "z", "vr", "vz", "density", "srr", "szz", "stt", "srz", "mass"}, rows);
}

// The uniaxial strain of the separation tests: every row of the column (row j at height
// (j + 1/2) dp when unstretched, lambda times that now) moves at rate * its unstretched height.
void impose_uniaxial_strain(Simulation& sim, int rows, double dp, double rate, double lambda) {
  for (int j = 0; j < rows; ++j) {
    const double z0 = (j + 0.5) * dp, z = lambda * z0;
    sim.prescribe_velocity({0, 1, z - 0.3 * dp, z + 0.3 * dp}, 0.0, rate * z0);
  }
}

// Particle i of the stretched column is interior: initial rows 3-6, two spacings off the side.
bool in_column_interior(const tamp::ParticleSnapshot& s, size_t i, double lambda, double dp, double R) {
  const double z0 = s.z[i] / lambda;
  return z0 >= 3 * dp && z0 <= 7 * dp && s.r[i] <= R - 2 * dp;
}

}  // namespace

TEST_CASE("Aggregate: grains stretched below their loosest packing carry no stress and keep it, and take load "
          "again at their first compression", "[aggregate]") {
  // Uniaxial strain imposed on every particle (v_z = rate * z0 row by row, v_r = 0; fixed
  // base, roller side): a homogeneous stretch lambda = 1 + rate t, so that, in the bulk,
  // continuity gives rho = rho_0 / lambda and the hypoelastic update sigma_zz = M ln lambda,
  // sigma_rr = sigma_tt = (K - 2G/3) ln lambda (M = K + 4G/3). Below the separation density
  // rho_c = 0.9 rho_0 (lambda_c = 1 / 0.9) the stress is zero and the density is held at
  // rho_c (a separated grain keeps its loosest packing, kernels/SphSolid.hpp); stretched to
  // lambda = 1.25 and compressed back, the grains reconnect at once (lambda_r = 1.25, rho =
  // rho_c) and then rho = rho_c lambda_r / lambda, sigma_zz = M ln(lambda / lambda_r).
  // (Until 2026-12-07 the density followed the stretch down and the stress stayed zero until
  // rho was back at rho_c: docs/drop-sequence.md.) The material is elastic (a Mohr-Coulomb
  // charge would be stress-free in tension anyway) so that the rule is what is seen.
  // Tolerance 1 % of M ln(lambda) where stressed (the strain increments are summed with
  // the rate of each step, first order in rate dt = 3e-5), 2e-3 on the density (the same),
  // and 1e-9 Pa where separated; the interior rows only (the top rows' kernel is truncated).
  tamp::log::set_level(tamp::log::Level::Quiet);
  const double dp = 0.01, R = 0.05, L = 0.12, rate = 1.0;  // m, m, m, 1/s
  Config cfg = column_config(R, L, dp);
  cfg.sph.kernel_correction = true;  // linear velocity fields differentiated exactly
  MaterialSpec agg = tamp::lab::aggregate();
  agg.model = "elastic";
  agg.name = "clay";  // the column's block material
  agg.separation_density = 0.9 * agg.density;
  agg.crush_pressure = 0;  // no compaction: the separation rule alone
  cfg.materials = {agg};
  Simulation sim(cfg);
  const auto& m = sim.materials()[0];
  const double M = m.p_wave_modulus(), lam = m.bulk_modulus - 2.0 / 3.0 * m.shear_modulus;
  const int rows = static_cast<int>(std::lround(L / dp));
  // every row moves at rate * its height at lambda = 1 (sign -1: compression)
  auto impose = [&](double lambda, double sign) { impose_uniaxial_strain(sim, rows, dp, sign * rate, lambda); };
  // interior particles (initial rows 3-6): worst relative error of sigma_zz, sigma_rr
  // against the expected values (zero strain at lambda_zero), and the mean density over
  // rho_0 against rho_expected
  auto check = [&](double lambda, double lambda_zero, bool separated, double rho_expected) {
    const tamp::ParticleSnapshot s = sim.snapshot();
    double worst = 0, rho = 0;
    int n = 0;
    for (size_t i = 0; i < s.r.size(); ++i) {
      if (!in_column_interior(s, i, lambda, dp, R)) continue;
      const double e = std::log(lambda / lambda_zero);
      if (separated) {
        worst = std::max({worst, std::fabs(s.s_zz[i]), std::fabs(s.s_rr[i]), std::fabs(s.s_tt[i])});
      } else {
        worst = std::max({worst, std::fabs(s.s_zz[i] - M * e) / (M * std::fabs(e)),
                          std::fabs(s.s_rr[i] - lam * e) / (M * std::fabs(e))});
      }
      rho += s.density[i] / m.density;
      ++n;
    }
    REQUIRE(n > 0);
    std::printf("[separation] lambda %.3f: rho/rho_0 %.4f (expected %.4f), %s %.2e\n", lambda, rho / n,
                rho_expected, separated ? "largest |stress| Pa" : "worst relative stress error", worst);
    CHECK(rho / n == Approx(rho_expected).epsilon(2e-3));
    return worst;
  };
  impose(1.0, +1.0);
  sim.advance_to(0.08);  // lambda 1.08: stretched, still in contact
  CHECK(check(1.08, 1.0, false, 1.0 / 1.08) < 0.01);
  sim.advance_to(0.25);  // lambda 1.25: separated, held at rho_c
  CHECK(check(1.25, 1.0, true, 0.9) < 1e-9);
  impose(1.25, -1.0);
  const double lambda_r = 1.25;  // reconnected at the first compression
  sim.advance_to(0.25 + 0.10);  // lambda 1.15
  CHECK(check(1.15, lambda_r, false, 0.9 * lambda_r / 1.15) < 0.01);
  sim.advance_to(0.25 + 0.25);  // lambda 1.0
  CHECK(check(1.0, lambda_r, false, 0.9 * lambda_r / 1.0) < 0.01);
  tamp::log::set_level(tamp::log::Level::Info);
}

TEST_CASE("Aggregate: a charge loosened below its loosest packing has its air voids back and compacts again "
          "under pressure", "[aggregate][effects]") {
  // The compaction cap (effect (a), docs/effects.md) on a separating material, in the
  // uniaxial strain of the test above: p_c0 = 20 kPa, H = 0, n_a = 0.05, separation at
  // rho_c = 0.9 rho_0. Mean pressure p = -(s_rr + s_zz + s_tt) / 3; continuity gives
  // rho = rho_0 / lambda until the grains separate, and a separated grain is held at rho_c
  // (the test above). Beyond the air voids the cap is spent and p = K (ln(rho/rho_0) - n_a)
  // (log volumetric strain = compaction + p / K). A grain that separates keeps no packing
  // history but its density (compaction = ln(rho_c / rho_0) < 0), so compressed back it
  // compacts on the cap again, and its densest packing is rho_0 e^n_a whatever its history.
  //   1. compressed to lambda = 0.93: p = K (ln(1/0.93) - n_a), about 207 kPa;
  //   2. stretched to lambda = 1.25: separated, p = 0, rho = rho_c;
  //   3. compressed back to lambda = 1.10: reconnected at once (lambda_r = 1.25) with
  //      compaction ln 0.9 = -0.105, so its air voids are 0.155 again, more than the log
  //      strain ln(1.25 / 1.10) = 0.128 since: p = p_c0 on the cap (if the voids spent in 1.
  //      stayed spent, the grain would load elastically: p = K 0.128 = 59 p_c0);
  //   4. compressed to lambda = 0.90: rho = rho_c lambda_r / 0.90 = 1.25 rho_0, the voids
  //      spent again, p = K (ln 1.25 - n_a).
  // Tolerances: 1 % of p where p is elastic beyond the cap (first order in the step's strain
  // increment, as above), 2 % of p_c0 on the cap, 1e-9 Pa separated; interior rows only.
  // The shear strength is made unreachable (c = 1 GPa) so that only the cap acts.
  tamp::log::set_level(tamp::log::Level::Quiet);
  const double dp = 0.01, R = 0.05, L = 0.12, rate = 1.0;  // m, m, m, 1/s
  const double pc0 = 20e3, na = 0.05;                        // Pa, -
  Config cfg = column_config(R, L, dp);
  cfg.sph.kernel_correction = true;
  MaterialSpec agg = tamp::lab::aggregate();
  agg.name = "clay";  // the column's block material
  agg.cohesion = 1e9;
  agg.separation_density = 0.9 * agg.density;
  agg.crush_pressure = pc0;
  agg.crush_hardening = 0;
  agg.air_voids = na;
  cfg.materials = {agg};
  Simulation sim(cfg);
  const double K = sim.materials()[0].bulk_modulus, rho0 = agg.density;
  const int rows = static_cast<int>(std::lround(L / dp));
  auto impose = [&](double lambda, double sign) { impose_uniaxial_strain(sim, rows, dp, sign * rate, lambda); };
  // mean pressure and density of the interior particles (initial rows 3-6)
  auto mean_p = [&](double lambda, double rho_expected) {
    const tamp::ParticleSnapshot s = sim.snapshot();
    double p = 0, rho = 0;
    int n = 0;
    for (size_t i = 0; i < s.r.size(); ++i) {
      if (!in_column_interior(s, i, lambda, dp, R)) continue;
      p += -(s.s_rr[i] + s.s_zz[i] + s.s_tt[i]) / 3.0;
      rho += s.density[i];
      ++n;
    }
    REQUIRE(n > 0);
    p /= n;
    rho /= n;
    std::printf("[recompaction] lambda %.3f: rho/rho_0 %.4f, p %.1f Pa\n", lambda, rho / rho0, p);
    CHECK(rho / rho0 == Approx(rho_expected).epsilon(2e-3));
    return p;
  };
  impose(1.0, -1.0);
  sim.advance_to(0.07);  // lambda 0.93
  const double p1 = K * (std::log(1.0 / 0.93) - na);
  CHECK(mean_p(0.93, 1.0 / 0.93) == Approx(p1).epsilon(0.01));
  impose(0.93, +1.0);
  sim.advance_to(0.07 + 0.32);  // lambda 1.25
  CHECK(std::fabs(mean_p(1.25, 0.9)) < 1e-9);
  impose(1.25, -1.0);
  const double lambda_r = 1.25;  // reconnected at the first compression
  sim.advance_to(0.07 + 0.32 + 0.15);  // lambda 1.10
  CHECK(mean_p(1.10, 0.9 * lambda_r / 1.10) == Approx(pc0).margin(0.02 * pc0));
  sim.advance_to(0.07 + 0.32 + 0.35);  // lambda 0.90
  CHECK(mean_p(0.90, 0.9 * lambda_r / 0.90) == Approx(K * (std::log(0.9 * lambda_r / 0.90) - na)).epsilon(0.01));
  tamp::log::set_level(tamp::log::Level::Info);
}

TEST_CASE("Aggregate: a cone of the charge 3 deg flatter than phi stands and comes to rest, 3 deg steeper it slumps",
          "[aggregate]") {
  // A cohesionless slope is in limit equilibrium at beta = phi (infinite-slope analysis;
  // near the free surface of a cone the hoop stress is the intermediate one and does not
  // change that), so a cone flatter than phi must stand and one steeper must slump. Static
  // strength needs a static state: the cone is made at zero stress (as a charge is created),
  // settled under gravity with the lab deck's settle damping (60 1/s for 0.5 s, as every
  // backfill charge is settled, docs/drop-sequence.md "Stages"), then released undamped.
  // Measured (10 mm, the deck's aggregate): 42, 44, 45 and 46 deg stand (height -0.6 to
  // -1.9 %, every particle below 1e-9 m/s), 47 and 50 deg slump (-29 %, -34 %): the model's
  // critical slope lies between 46 and 47 deg, at phi. Asserted with 3 deg either side of
  // phi: the 44 deg cone keeps its height within 5 % and every particle is slower than
  // 1 mm/s 1 s after the release; the 50 deg cone loses more than 10 % of its height.
  // (Until 2026-12-07 the cone was released at zero stress undamped: its standing then
  // depended on how the viscosity damped the sudden load, 42 deg stood with alpha 0.5 and
  // slumped 13 % with the aggregate's 0.1; docs/drop-sequence.md.)
  tamp::log::set_level(tamp::log::Level::Quiet);
  const double dp = 0.01, R0 = 0.3, W = 0.8;
  // the cone at beta (deg) released for `time` s: its shape before and after
  const double settle = 0.5;  // s
  auto release = [&](double beta, double time) {
    Simulation sim(aggregate_cone(beta, R0, dp, W));
    const HeapShape h0 = heap_shape(sim, dp, W);
    sim.set_damping(60.0);  // the lab deck's settle damping, 1/s: as a backfill charge is settled
    sim.advance_to(settle);
    sim.set_damping(0.0);
    const HeapShape hs = heap_shape(sim, dp, W);
    std::printf("[heap] %.0f deg cone settled (damped %.1f s): height %.3f m, flank %.1f deg, fastest %.2e m/s\n", beta,
                settle, hs.height, hs.flank_deg, hs.vmax);
    sim.advance_to(settle + time);
    if (beta == 44.0) dump_heap(sim, "TAMP_CONE_DUMP");
    const HeapShape h = heap_shape(sim, dp, W);
    std::printf("[heap] %.0f deg cone: height %.3f -> %.3f m (%+.1f %%), flank %.1f deg, fastest particle %.2e m/s\n",
                beta, h0.height, h.height, 100 * (h.height / h0.height - 1), h.flank_deg, h.vmax);
    return std::make_pair(h0, h);
  };
  if (std::getenv("TAMP_CONE_BETA")) release(env_or("TAMP_CONE_BETA", 42.0), 2.0);  // a study of other slopes
  const auto [h0_stands, stands] = release(44.0, 1.0);
  CHECK(stands.height > 0.95 * h0_stands.height);
  CHECK(stands.vmax < 1e-3);
  const auto [h0_slumps, slumps] = release(50.0, 1.0);
  CHECK(slumps.height < 0.90 * h0_slumps.height);
  tamp::log::set_level(tamp::log::Level::Info);
}

// Hidden for its time (docs/drop-sequence.md "The aggregate as a poured material"); the history: poured
// with the grains separating below 1526 kg/m3, five pours stand at 28.3 deg (sample std 3.2,
// standard error 1.4) at 10 mm, 8 deg below the 36.2 deg a non-dilatant phi = 47 charge
// should reach, and their separated surface grains still slide (10-27 mm/s). Never
// separating they stand at 32.0 deg (std 3.2) and come to rest (fastest 4.1 mm/s). The flowed
// charge can stand steeper (poured with damping, then released undamped: 38-49 deg, at rest);
// it does not stop: after the last row the heap slumps for 0.5 s, its moving grains at zero
// stress (docs/findings/2026-12-07-the-aggregate-as-a-poured-material.md "After the feed stops, the heap slumps"). On a rough incline
// (the hidden test "Aggregate: a layer*" below) the never-separating charge stops between 33
// and 36 deg, and with the deck's separation it accelerates at 30 deg: the flowing layer's
// sheared basal row dilates to about 1440 kg/m3 and is read as separated. The figures above
// are with the deck's viscosity as it was (alpha 0.5 everywhere). Since 2026-12-07 the
// aggregate's share is 0.2 (alpha 0.1): the layer stops, and five pours stood at 32.1 deg
// (std 1.4, se 0.6), still 1 deg short of the band, one pour's fastest grain at 94 mm/s.
// Since a separated grain keeps its loosest packing and the charge compacts from there
// (2026-12-07, twenty-second session), every pour comes to rest (ten pours: fastest grain
// 0.09 mm/s): the rest half passes. The angle does not: ten pours 32.0 deg (std 2.2, se 0.7),
// twenty 32.8 (std 2.4, se 0.5), the test's five 32.7, short of the band's lower edge (33.2).
// Since the aggregate takes its viscosity on the head-on part of each pair's approach only
// (2026-12-07, twenty-third session; docs/sph.md "Head-on viscosity"), so that a thin
// avalanche is no longer lifted off its bed, the test passes: five pours 38.3 deg (std 3.6,
// se 1.6), fastest grain 0.98 mm/s; twenty 38.2 (std 2.7, se 0.6), fastest 4.6 mm/s (pour 8,
// at rest after 3 s). No longer a known defect; hidden for its time (about 1 minute on 2
// threads, which the CI's 20 minutes do not have to spare). Run it by name: tamp_tests
// "Aggregate: a heap*".
struct HeapEnsemble {
  double mean_flank_deg = 0, fastest = 0, repose_deg = 0;  // deg, m/s, deg
};
HeapEnsemble pour_heaps(int default_pours) {
  // Poured as a rain over a disk of radius 0.1 m: every 0.05 s one row of particles (one
  // per radial band, at rest, zero stress, the ring mass of where it lands) is placed one
  // spacing above the top of its band; 25 rows, then 1.5 s to settle. The heap grows by
  // avalanches down its flank, as a funnel-poured heap does, and the flank is what the last
  // avalanche left: a layer that flowed parallel to the slope (simple shear) and stopped.
  // A Mohr-Coulomb material with psi = 0 shearing steadily mobilises tau / sigma_n = sin(phi)
  // on the shear plane (its principal axes at 45 deg to it; Davis 1968, the simple-shear
  // relation tan(phi_ss) = sin(phi); tests/test_mohr_coulomb.cpp "update_stress composes":
  // tau = p sin(phi) on the plane of shear), so a flowing layer stops at tan(beta) = sin(phi):
  // target atan(sin 47 deg) = 36.2 deg, tolerance 3 deg (issue). Measured in the flowed
  // grains of the never-separating pour: every one at yield, major compression at 40 deg
  // (median) to the flank, tau / sigma_n on the flank's plane 0.72 (median; sin 47 = 0.73,
  // tan 47 = 1.07) (docs/drop-sequence.md). Rest: every particle slower than 5 mm/s at the end.
  // One pour is one sample of a chaotic process: with 250 particles and 14-18 surface
  // bands, the flank of a single pour moves by 2-4 deg with any change (docs/drop-sequence.md).
  // The test pours an ensemble: pour 0 drops every grain at the centre of its band (the
  // lattice rain of the earlier single-pour test); pours 1, 2, ... drop each grain at a
  // radius jittered by up to +-0.1 spacing (a fixed pseudo-random sequence per pour, so the
  // test is deterministic), as a real rain does. The flank asserted is the ensemble mean;
  // its standard error is printed.
  // For the study in docs/drop-sequence.md, the environment may change the spacing, the pour
  // radius, the friction angle, the dilation angle, the cohesion, the shear modulus, the
  // separation density (0 = never), the viscosity alpha, the smoothing length, the kernel
  // correction, the stress regularisation's interval (steps), a glued base, the damping and
  // settling time (and a release of the damping), the rows poured at once, the inner radius
  // of an annular pour (a ridge), the number of pours, print the flank while fed, and write
  // the particles of every pour (heap.csv -> heap-<pour>.csv).
  const auto knob = env_or;
  const double dp = knob("TAMP_HEAP_DP", 0.01);
  const double R_in = knob("TAMP_HEAP_RIN", 0.0);  // > 0: a ridge poured on an annulus (almost plane strain)
  const double W = 0.5 + R_in, R_pour = knob("TAMP_HEAP_RPOUR", 0.1);
  const int rows = static_cast<int>(std::lround(0.25 / dp));
  const int pours = std::max(1, static_cast<int>(knob("TAMP_HEAP_POURS", default_pours)));
  Config cfg = aggregate_cone(45.0, R_pour, dp, W);
  cfg.blocks.resize(1);  // the first row: a disk one spacing thick
  cfg.blocks[0].r_min = R_in;
  cfg.blocks[0].r_max = R_in + R_pour;
  MaterialSpec& agg = cfg.materials[0];
  agg.phi_deg = knob("TAMP_HEAP_PHI", agg.phi_deg);
  agg.psi_deg = knob("TAMP_HEAP_PSI", agg.psi_deg);
  agg.cohesion = knob("TAMP_HEAP_C", agg.cohesion);
  agg.shear_modulus = knob("TAMP_HEAP_G", agg.shear_modulus);  // Pa
  agg.separation_density = knob("TAMP_HEAP_SEPARATION", agg.separation_density);
  agg.crush_pressure = knob("TAMP_HEAP_CRUSH", agg.crush_pressure);  // Pa, effect (a) (docs/effects.md)
  agg.crush_hardening = knob("TAMP_HEAP_CRUSH_HARDENING", agg.crush_hardening);  // Pa
  agg.air_voids = knob("TAMP_HEAP_AIR_VOIDS", agg.air_voids);
  cfg.sph.kernel_correction = knob("TAMP_HEAP_KERNEL_CORRECTION", 0) != 0;
  cfg.sph.alpha = knob("TAMP_HEAP_ALPHA", cfg.sph.alpha);  // [sph] alpha: the aggregate's pairs take 0.2 of it
  cfg.sph.h_factor = knob("TAMP_HEAP_H_FACTOR", cfg.sph.h_factor);
  cfg.sph.regularise_every = static_cast<int>(knob("TAMP_HEAP_REGULARISE", cfg.sph.regularise_every));
  const double repose_deg = simple_shear_repose_deg(agg.phi_deg, agg.psi_deg);
  const int nr = static_cast<int>(std::lround(R_pour / dp)), k0 = static_cast<int>(std::lround(R_in / dp));
  const int per_pour = static_cast<int>(knob("TAMP_HEAP_ROWS_PER_POUR", 1));
  // With TAMP_HEAP_FED=1, the flank one row interval after the last row, while the heap is
  // still flowing (docs/findings/2026-12-07-the-aggregate-as-a-poured-material.md "After the feed stops, the heap slumps"); off by
  // default, because stopping there changes the step sequence and so the chaotic pours.
  // TAMP_HEAP_RELEASE = t: the damping acts for t s of the settle, then it is undamped.
  const bool fed_probe = knob("TAMP_HEAP_FED", 0) != 0;
  const double damping = knob("TAMP_HEAP_DAMPING", 0.0);  // 1/s, mass-proportional, as the lab's settle phases
  const double settle = knob("TAMP_HEAP_SETTLE", 1.5), release = knob("TAMP_HEAP_RELEASE", 0.0);
  // TAMP_HEAP_GLUED = f: the grains whose centres lie below f spacings are held at rest (a base
  // of glued grains, as sandpaper or a glued layer in a heap experiment); 0 (default): none.
  const double glued = knob("TAMP_HEAP_GLUED", 0.0) * dp;
  auto mean_of = [](const std::vector<double>& x) {
    double m = 0;
    for (double f : x) m += f / x.size();
    return m;
  };
  std::vector<double> flanks, fed_flanks;
  double fastest = 0;
  for (int pour = 0; pour < pours; ++pour) {
    Simulation sim(cfg);
    sim.set_damping(damping);
    uint64_t state = 0x9E3779B97F4A7C15ull * static_cast<uint64_t>(pour + 1);
    auto jitter = [&]() {  // in [-1, 1): a 64-bit linear congruential sequence (Knuth's MMIX constants)
      state = state * 6364136223846793005ull + 1442695040888963407ull;
      return pour == 0 ? 0.0 : static_cast<double>(state >> 11) / 4503599627370496.0 - 1.0;
    };
    const auto glue = glued_base(sim, glued);
    for (int row = 1; row < rows; row += per_pour) {
      sim.advance_to(sim.time() + 0.05 * per_pour, glue);
      const auto s = tamp::testing::host_state(sim);
      std::vector<double> top(nr, 0.0);
      for (size_t i = 0; i < s.r.size(); ++i) {
        const int k = static_cast<int>(s.r[i] / dp) - k0;
        if (k >= 0 && k < nr) top[k] = std::max(top[k], s.z[i]);
      }
      std::vector<tamp::NewParticle> add;
      for (int j = 0; j < per_pour && row + j < rows; ++j)
        for (int k = 0; k < nr; ++k) add.push_back({R_in + (k + 0.5 + 0.1 * jitter()) * dp, top[k] + (1 + j) * dp, 0});
      sim.add_particles(add);
    }
    double settled = 0;  // s of the settle already run
    if (fed_probe) {
      sim.advance_to(sim.time() + 0.05 * per_pour, glue);
      settled += 0.05 * per_pour;
      const double f = heap_shape(sim, dp, W).flank_deg;
      std::printf("[heap] pour %d: flank %.1f deg while fed\n", pour, f);
      fed_flanks.push_back(f);
    }
    if (release > 0) {
      sim.advance_to(sim.time() + release - settled, glue);
      std::printf("[heap] pour %d: flank %.1f deg after %.2f s damped\n", pour, heap_shape(sim, dp, W).flank_deg,
                  release);
      sim.set_damping(0.0);
      settled = release;
    }
    sim.advance_to(sim.time() + settle - settled, glue);
    const HeapShape h = heap_shape(sim, dp, W);
    dump_heap(sim, "TAMP_HEAP_DUMP", pours > 1 ? pour : -1);
    std::printf("[heap] pour %d: %zu particles, height %.3f m, flank %.1f deg (%d bands), fastest particle %.2e m/s\n",
                pour, sim.snapshot().r.size(), h.height, h.flank_deg, h.bands, h.vmax);
    flanks.push_back(h.flank_deg);
    fastest = std::max(fastest, h.vmax);
  }
  const double mean = mean_of(flanks);
  double var = 0;
  for (double f : flanks) var += (f - mean) * (f - mean) / std::max(1, pours - 1);
  std::printf("[heap] %d pours: flank %.1f deg (sample std %.1f, standard error %.1f), fastest particle %.2e m/s\n",
              pours, mean, std::sqrt(var), std::sqrt(var / pours), fastest);
  if (fed_probe)
    std::printf("[heap] %d pours: flank %.1f deg while fed (one row interval after the last row)\n", pours,
                mean_of(fed_flanks));
  std::printf("[heap] target (simple-shear friction of phi %.0f, psi %.0f) %.1f deg +- 3\n", agg.phi_deg, agg.psi_deg,
              repose_deg);
  return {mean, fastest, repose_deg};
}

// The heap tests' assertions on `pours` pours: the mean flank within 3 deg of atan(sin phi)
// (the tolerance), every grain slower than 5 mm/s at the end.
void check_heap_stands(int pours) {
  tamp::log::set_level(tamp::log::Level::Quiet);
  const HeapEnsemble e = pour_heaps(pours);
  CHECK(std::fabs(e.mean_flank_deg - e.repose_deg) < 3.0);
  CHECK(e.fastest < 5e-3);
  tamp::log::set_level(tamp::log::Level::Info);
}

TEST_CASE("Aggregate: a heap of the charge poured on a rough base stands at its angle of repose, and comes to rest",
          "[.][long][aggregate]") {
  check_heap_stands(5);
}

// The CI's small version of the test above: its first three pours (the lattice rain and two
// jittered ones), the same assertions. Three pours are a coarser ensemble (a standard error
// of about 1.5-2 deg against the band's 3); the five-pour test and the twenty-pour figures
// (docs/findings/2026-12-07-the-aggregate-as-a-poured-material.md "The head-on viscosity") stay the measurement. Measured 2026-12-07:
// 37.4 / 35.7 / 35.5, mean 36.2 deg, fastest grain 0.98 mm/s.
TEST_CASE("Aggregate: three pours of the charge stand within 3 deg of atan(sin phi) and come to rest",
          "[aggregate]") {
  check_heap_stands(3);
}

// The incline of the two tests below (docs/drop-sequence.md "A layer of the charge on a
// rough incline"): a layer of the lab deck's aggregate, `layers` spacings thick and 1 m long,
// lies on a rough base (a fixed wall, and every grain whose centre is below 0.6 spacings held
// at rest: a glued layer) far from the axis (r = 1-2 m, so that the hoop terms are about
// 1 %). The incline is a body force: gravity g cos(theta) normal to the base and g sin(theta)
// along it (+r). Protocol of Pouliquen (1999, Phys. Fluids 11, 542), who measured
// h_stop(theta) by letting a flowing layer stop: the layer settles (damped, 0.3 s), is set
// flowing at a steeper angle (TAMP_INCLINE_START, for TAMP_INCLINE_KICK s), then runs undamped
// at theta for `run` s, reported every 0.25 s: the middle 0.4 m's mean speed along the base
// (its glued row left out) and whether any of it is left (it can run off).
struct InclineReport {
  double middle_v = 0;
  bool middle_left = true;
};
std::vector<InclineReport> incline_layer(double theta_deg, double layers, double run) {
  const auto knob = env_or;
  const double dp = knob("TAMP_INCLINE_DP", 0.01), g = 9.81, deg = M_PI / 180.0;
  const double R_in = 1.0, L = 1.0, H = layers * dp;
  const double start = knob("TAMP_INCLINE_START", 50.0) * deg, kick = knob("TAMP_INCLINE_KICK", 0.2);
  const double theta = theta_deg * deg;
  Config cfg = column_config(R_in + L, H, dp);
  cfg.materials = {tamp::lab::aggregate()};
  MaterialSpec& agg = cfg.materials[0];
  agg.separation_density = knob("TAMP_INCLINE_SEPARATION", agg.separation_density);
  cfg.sph.alpha = knob("TAMP_INCLINE_ALPHA", cfg.sph.alpha);  // [sph] alpha; the aggregate takes 0.2 of it
  cfg.blocks[0].material = agg.name;
  cfg.blocks[0].r_min = R_in;
  cfg.outer = {WallType::None, 0.0};
  cfg.gravity = g * std::cos(theta);
  Simulation sim(cfg);
  auto body_force = [&](double a_r, double a_z) {  // on every real particle, m/s2
    const auto reals = std::make_pair(0, sim.particle_count());
    Kokkos::deep_copy(Kokkos::subview(sim.particles().a_ext, reals, 0), a_r);
    Kokkos::deep_copy(Kokkos::subview(sim.particles().a_ext, reals, 1), a_z);
  };
  const auto glue = glued_base(sim, 0.6 * dp);
  std::vector<InclineReport> trace;
  auto report = [&](const char* phase) {
    const auto s = tamp::testing::host_state(sim);
    double v = 0, top = 0, vmax = 0;
    int n = 0;
    for (size_t i = 0; i < s.r.size(); ++i) {
      vmax = std::max(vmax, std::hypot(s.vr[i], s.vz[i]));
      if (s.r[i] < R_in + 0.3 || s.r[i] > R_in + 0.7) continue;
      top = std::max(top, s.z[i] + 0.5 * dp);
      if (s.z[i] < 0.6 * dp) continue;
      v += s.vr[i];
      ++n;
    }
    InclineReport r;
    r.middle_v = n ? v / n : 0.0;
    r.middle_left = n > 0;
    trace.push_back(r);
    std::printf("[incline] theta %.1f deg, %.0f mm, %s t = %.2f s: middle mean v_r %.4f m/s, thickness %.3f m, fastest "
                "%.3f m/s\n",
                theta_deg, 1e3 * H, phase, sim.time(), r.middle_v, top, vmax);
  };
  sim.set_damping(20.0);
  sim.advance_to(0.3, glue);
  sim.set_damping(0.0);
  body_force(g * std::sin(start), g * (std::cos(theta) - std::cos(start)));  // normal: g cos(start) in all
  sim.advance_to(0.3 + kick, glue);
  report("kicked");
  body_force(g * std::sin(theta), 0.0);
  for (double t = 0.25; t <= run + 1e-9; t += 0.25) {
    sim.advance_to(0.3 + kick + t, glue);
    report("running");
  }
  dump_heap(sim, "TAMP_INCLINE_DUMP", static_cast<int>(std::lround(theta_deg)));
  return trace;
}

// Hidden for its time: the stopping angle of the discretised charge where the geometry is
// simple (the incline above, 8 spacings = 8 cm at 10 mm). A Mohr-Coulomb layer with psi = 0
// flowing in simple shear mobilises tau / sigma_n = sin(phi) on planes parallel to the base
// (Davis 1968; the heap test above): below atan(sin phi) = 36.2 deg it decelerates at
// g (sin(phi) cos(theta) - sin(theta)) (1.3 m/s2 at 30 deg) and must stop. Asserted, with a
// margin of 3 deg either side of 36.2 for the discretisation (the heap's tolerance): at
// 30 deg the middle 0.4 m of the layer is at rest after 1.5 s (mean speed along the base
// below 1 cm/s); at 40 deg it still flows (above 0.1 m/s, or has run off the middle). Until
// 2026-12-07 it failed as the lab deck was (alpha 0.5): the layer accelerated at 30 deg,
// because the viscosity dilated the sheared basal row below the separation density. It
// passes with the aggregate's viscosity share 0.2 (alpha 0.1; docs/sph.md "Artificial
// viscosity per material"): at rest at 30 deg within 1.25 s, flowing at 40 deg. With the
// head-on viscosity (2026-12-07, twenty-third session): 0.010 m/s at 30 deg 0.5 s after the
// kick, 0.0008 at 1.0 s; 0.44 m/s at 40 deg 1.0 s after the kick. Hidden for its time (45-67 s
// on 2 threads; the CI's 20 minutes have about half a minute to spare).
// Knobs: TAMP_INCLINE_THETA (a list of angles), TAMP_INCLINE_LAYERS, TAMP_INCLINE_TIME, and
// those of incline_layer.
// Run it by name: tamp_tests "Aggregate: a layer*".
TEST_CASE("Aggregate: a layer of the charge on a rough incline stops below atan(sin phi) and flows above it",
          "[.][long][aggregate]") {
  tamp::log::set_level(tamp::log::Level::Quiet);
  const double layers = env_or("TAMP_INCLINE_LAYERS", 8), run = env_or("TAMP_INCLINE_TIME", 1.5);
  std::vector<double> angles;
  {
    std::stringstream ss(std::getenv("TAMP_INCLINE_THETA") ? std::getenv("TAMP_INCLINE_THETA") : "30,40");
    for (std::string item; std::getline(ss, item, ',');) angles.push_back(std::atof(item.c_str()));
  }
  const MaterialSpec agg = tamp::lab::aggregate();
  const double repose_deg = simple_shear_repose_deg(agg.phi_deg, agg.psi_deg);
  for (const double theta_deg : angles) {
    const auto trace = incline_layer(theta_deg, layers, run);
    const InclineReport& last = trace.back();
    if (theta_deg < repose_deg - 3.0) {
      CHECK(last.middle_left);
      CHECK(std::fabs(last.middle_v) < 0.01);
    } else if (theta_deg > repose_deg + 3.0) {
      CHECK((!last.middle_left || last.middle_v > 0.1));
    }
  }
  tamp::log::set_level(tamp::log::Level::Info);
}

// The same charge in a layer 3 cm thick (3 spacings at 10 mm, the lowest glued) must stop at
// 30 deg as the 8 cm layer does: Mohr-Coulomb has no length scale, so the stopping angle
// does not depend on the thickness (and real layers stop at steeper angles when thin,
// Pouliquen 1999, not shallower). Asserted: from the kick's speed (about 0.55 m/s) the
// middle decelerates (slower 0.25 s after the kick than at it) and has nearly stopped (below
// 5 cm/s) 0.5 s after the kick; at 1.3 m/s2 of deceleration it would stop within 0.45 s, and
// the 8 cm layer does both (0.26 m/s at 0.25 s, 0.012 at 0.5 s). Later reports are not
// asserted: a layer that ran on piles up in the middle (the speed falls for that reason).
// Measured 2026-12-07: it accelerates, 0.55 -> 0.70 -> 0.87 m/s, and piles up 0.75 s after the
// kick (at 5 mm the same 3 cm: 0.61 -> 0.66 -> 0.62, stopping at 1.0 s); it floats
// off its glued row, which dilates to 1400 kg/m3 and separates, lifted by the viscosity's
// push on the pairs that approach as the layer slides over the base's grains. The heap's
// avalanches are such thin layers, which is where the poured heap's missing degrees are
// looked for. With the aggregate's alpha at 0.02 (TAMP_INCLINE_ALPHA=0.1) it decelerates,
// 0.63 -> 0.41 -> 0.07 m/s, still short of the second assertion. Since a separated grain
// keeps its loosest packing and the charge compacts (2026-12-07, twenty-second session):
// 0.555 -> 0.617 -> 0.229 m/s, slowing within 0.5 s but not within the first 0.25 s. It was
// a hidden known defect until the aggregate took its viscosity on the head-on part of each
// pair's approach only (2026-12-07, twenty-third session; docs/sph.md "Head-on viscosity"):
// 0.428 -> 0.078 -> 0.000 m/s, and the 3 cm layer stops at 33 and 36 deg as well and runs off
// at 40 (docs/findings/2026-12-07-the-aggregate-as-a-poured-material.md "The head-on viscosity"). 4 s on 2 threads.
TEST_CASE("Aggregate: a thin layer of the charge (3 cm) on a rough incline stops at 30 deg, as a thick one does",
          "[aggregate]") {
  tamp::log::set_level(tamp::log::Level::Quiet);
  const auto trace = incline_layer(30.0, 3, 0.5);
  REQUIRE(trace.size() == 3);  // kicked, then 0.25 and 0.5 s after the kick
  CHECK(trace[1].middle_v < trace[0].middle_v);
  CHECK(trace[2].middle_left);
  CHECK(std::fabs(trace[2].middle_v) < 0.05);
  tamp::log::set_level(tamp::log::Level::Info);
}
