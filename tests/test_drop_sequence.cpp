// The staged drop sequence (issue: main job, verification 4 and 5) on the CI-sized
// scenario examples/ci-drop.toml: 3 blows and 1 backfill of the lab pounder.
#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>
#include <cmath>
#include <cstdlib>
#include <iterator>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <algorithm>
#include <array>
#include <sstream>

#include "SphTestUtil.hpp"
#include "core/Deck.hpp"
#include "core/Log.hpp"
#include "drivers/sequence/DropSequence.hpp"

// Using-declarations, not `using namespace tamp`: tamp::log would clash with ::log in the
// CUDA math headers (nvcc).
using tamp::BlowRecord;
using tamp::Config;
using tamp::DropSequence;
using tamp::ParticleSnapshot;
using tamp::Simulation;
using tamp::load_deck;
using tamp::read_checkpoint_h5;
using tamp::testing::read_csv;
namespace fs = std::filesystem;

namespace {

const std::string deck_path = std::string(TAMP_SOURCE_DIR) + "/examples/ci-drop.toml";

std::string fresh_dir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("tamp_test_" + name);
  fs::remove_all(p);
  fs::create_directories(p);
  return p.string();
}

double json_number(const std::string& path, const std::string& key) {
  std::ifstream in(path);
  const nlohmann::json j = nlohmann::json::parse(in);
  REQUIRE(j.contains(key));
  return j.at(key).get<double>();
}

struct RunResult {
  std::vector<BlowRecord> blows;
  ParticleSnapshot final_state;
  int tie_particles = 0;
};

// The CI deck with the sand and the clay beyond r = 0.15 m in 15 mm elements ([fem]).
Config coupled_ci_deck(bool subcycle = true) {
  Config cfg = load_deck(deck_path);
  cfg.fem.subcycle = subcycle;
  cfg.fem.enabled = true;
  cfg.fem.element_size = cfg.sph.spacing;
  cfg.fem.zone_r_min = 0.0;
  cfg.fem.zone_r_max = 0.15;
  cfg.fem.zone_z_min = 0.2;
  cfg.fem.zone_z_max = 0.5;
  return cfg;
}

// Runs `cfg` in `dir`, from `restart` if given, stopping after stage `stop_after`.
RunResult run_config(const Config& cfg, const std::string& dir, int stop_after = -1, const std::string& restart = "") {
  Simulation sim(cfg);
  DropSequence seq(sim, cfg, dir);
  if (!restart.empty()) seq.restore(read_checkpoint_h5(restart));
  seq.run(stop_after);
  return {seq.blows(), sim.snapshot(), sim.tie_particle_count()};
}

// The CI deck (or its coupled variant) run as run_config does.
RunResult run_deck(const std::string& dir, int stop_after = -1, const std::string& restart = "",
                   bool coupled = false, bool subcycle = true) {
  return run_config(coupled ? coupled_ci_deck(subcycle) : load_deck(deck_path), dir, stop_after, restart);
}

// The CI deck with its schedule replaced: a fourth and fifth blow, charges after blows 3 and 4.
Config five_blow_ci_deck(double fourth_drop_m) {
  Config cfg = load_deck(deck_path);
  cfg.schedule.drop_heights = {0.30, 0.50, 0.70, fourth_drop_m, 0.30};
  cfg.schedule.backfill_after = {3, 4};
  return cfg;
}

}  // namespace

TEST_CASE("Drop sequence: the CI scenario writes every output with sane values, and restarts exactly",
          "[drop-sequence][verification]") {
  tamp::log::set_level(tamp::log::Level::Quiet);
  const std::string a = fresh_dir("drop_full");
  const RunResult full = run_deck(a);

  // Every output file.
  for (const char* f : {"blows.csv", "column.csv", "summary.json", "tracers.csv", "pounder.csv", "energy.csv",
                        "stages.xdmf", "stages/000-relax.h5", "checkpoints/007-backfill-blow03.h5"})
    CHECK(fs::exists(fs::path(a) / f));

  // The plot step: the report with whole counts, the figures and the animation of the column
  // forming (one frame per stage file: 8 here).
  {
    std::ofstream(a + "/deck.toml") << tamp::to_toml(load_deck(deck_path));  // as `tamp run` writes it
    const std::string cmd = std::string(TAMP_SOURCE_DIR) + "/scripts/plot-dr.py " + a + " > " + a + "/plot.log 2>&1";
    REQUIRE(std::system(cmd.c_str()) == 0);
    for (const char* f : {"report.md", "column.png", "crater-depths.png", "column-forming.gif"})
      CHECK(fs::exists(fs::path(a) / f));
    std::ifstream in(a + "/report.md");
    const std::string report((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    CHECK(report.find("](column-forming.gif)") != std::string::npos);
    CHECK(report.find("The column forming: 8 stages") != std::string::npos);
    CHECK(report.find("696 particles") != std::string::npos);  // a count printed as a whole number (660 + the charge)
    CHECK(report.find(".0 particles") == std::string::npos);
  }

  // blows.csv: crater deeper after each blow (no backfill until blow 3), positive
  // penetration and deceleration, the charge after blow 3 only; every blow ended at rest in
  // contact (issue: or with the max-time warning, which this scenario must not need), and
  // the crater floor left after extraction is no deeper than where the pounder rested plus
  // one spacing (the floor can rebound upwards a little once the pounder is lifted).
  std::vector<std::string> header;
  const auto table = read_csv(a + "/blows.csv", &header);
  REQUIRE(table.size() == 3);
  std::vector<std::string> expected{"blow"};
  for (const auto& c : tamp::blow_columns()) expected.push_back(c.name);
  for (const char* m : {"sand", "clay", "aggregate"}) expected.push_back(std::string("plastic_") + m + "_J");
  expected.push_back("wall_s");
  CHECK(header == expected);
  auto col = [&](size_t b, const std::string& name) {
    const size_t k = std::find(header.begin(), header.end(), name) - header.begin();
    REQUIRE(k < header.size());
    return table[b][k];
  };
  // the legacy positions used below
  std::vector<std::vector<double>> blows(3);
  for (size_t b = 0; b < 3; ++b)
    blows[b] = {col(b, "blow"), col(b, "drop_height_m"), col(b, "crater_depth_m"), col(b, "penetration_m"),
                col(b, "peak_deceleration_m_s2"), col(b, "uplift_m"), col(b, "aggregate_added_kg")};
  const double dp = 0.015;
  for (size_t b = 0; b < 3; ++b) {
    std::printf("[drop] blow %zu: H %.2f m, crater %.4f m (deepest %.4f, floor after extraction %.4f), penetration "
                "%.4f m, %.0f contacts, restitution %.3f, peak deceleration %.1f m/s2, uplift %.4f m, aggregate %.3f kg\n",
                b + 1, blows[b][1], blows[b][2], col(b, "deepest_m"), col(b, "crater_floor_m"), blows[b][3],
                col(b, "contacts"), col(b, "restitution"), blows[b][4], blows[b][5], blows[b][6]);
    CHECK(blows[b][3] > 0.0);
    CHECK(blows[b][4] > 9.81);  // the pounder was stopped: more than g upwards at some time
    CHECK(blows[b][5] >= 0.0);
    CHECK(blows[b][5] < 0.1);
    if (b > 0) CHECK(blows[b][2] > blows[b - 1][2]);
    CHECK(col(b, "rest_in_contact") == 1.0);
    CHECK(col(b, "contacts") >= 1.0);
    CHECK(col(b, "deepest_m") >= blows[b][2]);
    CHECK(blows[b][2] >= col(b, "crater_floor_m") - dp);
    CHECK(col(b, "restitution") >= 0.0);
    CHECK(col(b, "restitution") < 1.0);
  }

  // Energy account per blow (issue: the residual below 2 % of the blow energy). The blow's
  // energy is what the pounder brought, energy_in = m g (H + its fall to rest), which is
  // what the sinks share; m g H is printed beside it. Every sink is non-negative where it
  // must be: radiation, damping, wall friction and the artificial-viscosity heat.
  for (size_t b = 0; b < 3; ++b) {
    const double mgh = 10.55 * 9.81 * blows[b][1];
    const double blow = col(b, "energy_in_J");
    std::printf("[drop] blow %zu energy: in %.3f J; plastic sand %.3f clay %.3f aggregate %.3f, elastic %.3f, viscous "
                "%.3f, soil motion %.3f, radiated %.3f, damping %.3f, wall friction %.4f, contact %.3f; returned to "
                "the pounder %.3f; fed in by the axis images %.3f, the wall images %.4f (numerical); residual %.4f J = "
                "%.2f %% of the energy brought (%.2f %% of m g H)\n",
                b + 1, col(b, "energy_in_J"), col(b, "plastic_sand_J"), col(b, "plastic_clay_J"),
                col(b, "plastic_aggregate_J"), col(b, "elastic_J"), col(b, "viscous_heat_J"), col(b, "soil_motion_J"),
                col(b, "radiated_J"), col(b, "damping_J"), col(b, "wall_friction_J"), col(b, "contact_J"),
                col(b, "returned_J"), col(b, "axis_images_J"), col(b, "wall_images_J"), col(b, "residual_J"),
                100 * col(b, "residual_J") / blow,
                100 * col(b, "residual_J") / mgh);
    CHECK(blow > mgh);
    CHECK(std::fabs(col(b, "residual_J")) < 0.02 * blow);
    for (const char* k : {"radiated_J", "damping_J", "wall_friction_J", "viscous_heat_J"}) CHECK(col(b, k) >= -1e-9);
  }
  CHECK(blows[0][6] == 0.0);
  CHECK(blows[1][6] == 0.0);
  CHECK(blows[2][6] > 0.0);

  // summary.json: the aggregate mass equals what was added (and what the particles hold).
  const std::string summary = a + "/summary.json";
  const double added = blows[2][6];
  double in_particles = 0;
  const int aggregate = 2;  // materials: sand, clay, aggregate
  for (size_t i = 0; i < full.final_state.size(); ++i)
    if (full.final_state.material[i] == aggregate) in_particles += full.final_state.mass[i];
  std::printf("[drop] aggregate: added %.6f kg, in summary %.6f kg, in particles %.6f kg; column %.3f m long, "
              "diameters head %.3f / max %.3f / base %.3f m\n",
              added, json_number(summary, "aggregate_total_kg"), in_particles, json_number(summary, "column_length_m"),
              json_number(summary, "head_diameter_m"), json_number(summary, "max_diameter_m"),
              json_number(summary, "base_diameter_m"));
  CHECK(json_number(summary, "aggregate_total_kg") == Approx(added).epsilon(1e-5));  // summary vs the blow records
  CHECK(in_particles == Approx(added).epsilon(1e-12));
  CHECK(json_number(summary, "blows_completed") == 3);
  // The column fills the crater of blow 3: as long as its depth (within one spacing), its
  // head and widest part as wide as the pounder (90-100 mm, within a spacing either way).
  // The base (mean over the bottom 30 mm) is where the crater walls close in under the
  // pounder's rounded foot: it may be narrower than the pounder (measured 75.0-76 mm with
  // 15 mm particles), so it is only bounded by half the pounder's base and the widest part.
  CHECK(std::fabs(json_number(summary, "column_length_m") - blows[2][2]) < dp);
  for (const char* k : {"head_diameter_m", "max_diameter_m"}) {
    CHECK(json_number(summary, k) > 0.09 - dp);
    CHECK(json_number(summary, k) < 0.10 + 2 * dp);
  }
  CHECK(json_number(summary, "base_diameter_m") > 0.5 * 0.09);
  CHECK(json_number(summary, "base_diameter_m") <= json_number(summary, "max_diameter_m"));
  const auto column = read_csv(a + "/column.csv");
  CHECK(column.size() >= 5);

  // Restart (tolerance 1e-12 relative, issue): stop after stage 3 (impact of blow 2),
  // restart from its checkpoint in a new folder, finish; the blows and the final particle
  // state must equal the uninterrupted run's. Every kernel sums in a fixed order, so the
  // difference expected is exactly zero.
  const std::string b = fresh_dir("drop_part");
  (void)run_deck(b, 3);
  CHECK_FALSE(fs::exists(fs::path(b) / "summary.json"));  // not finished
  const std::string c = fresh_dir("drop_rest");
  const RunResult resumed = run_deck(c, -1, b + "/checkpoints/003-impact-blow02.h5");
  REQUIRE(resumed.blows.size() == full.blows.size());
  double worst = 0;
  auto rel = [](double x, double y) { return std::fabs(x - y) / std::max(1e-300, std::max(std::fabs(x), std::fabs(y))); };
  for (size_t k = 0; k < full.blows.size(); ++k) {
    const BlowRecord &x = full.blows[k], &y = resumed.blows[k];
    for (const auto& c : tamp::blow_columns()) {  // every column of the blow table
      const double p = x.*c.field, q = y.*c.field;
      if (p != q) std::printf("[drop] restart: blow %zu %s differs: %.17g vs %.17g\n", k + 1, c.name, p, q);
      if (p != 0 || q != 0) worst = std::max(worst, rel(p, q));
    }
  }
  REQUIRE(resumed.final_state.size() == full.final_state.size());
  double scale = 0, diff = 0;
  for (size_t i = 0; i < full.final_state.size(); ++i) {
    scale = std::max(scale, std::fabs(full.final_state.z[i]));
    diff = std::max(diff, std::fabs(full.final_state.z[i] - resumed.final_state.z[i]));
    diff = std::max(diff, std::fabs(full.final_state.r[i] - resumed.final_state.r[i]));
  }
  std::printf("[drop] restart from stage 3: worst relative difference of the blow results %.3g, of the final "
              "positions %.3g\n",
              worst, diff / scale);
  CHECK(worst < 1e-12);
  CHECK(diff / scale < 1e-12);
  tamp::log::set_level(tamp::log::Level::Info);
}

TEST_CASE("Drop sequence: the CI scenario with elements outside the clay zone backfills and restarts exactly, "
          "and subcycled elements give the craters of one step for all within 2 %",
          "[drop-sequence][tie][fem][multirate]") {
  // The same 3 blows and charge with the sand, and the clay beyond r = 0.15 m, in 15 mm
  // quads tied to the particles (docs/coupling.md), the elements subcycled inside the
  // particles' step ([fem] subcycle). Backfill appends particles while the
  // tie particles stay (same count, refilled from the elements); a restart from the
  // checkpoint of stage 3 reproduces the blows, the particles and the element nodes
  // exactly (the checkpoint holds the element state and the tie forces). The same run with
  // one step for all (the elements' stable step, 4 times smaller) gives craters within
  // 2 % (issue: multi-rate against single-rate stepping).
  tamp::log::set_level(tamp::log::Level::Quiet);
  const std::string a = fresh_dir("drop_fem_full");
  Config cfg = coupled_ci_deck();
  Simulation probe(cfg);
  const int ties_at_start = probe.tie_particle_count();
  REQUIRE(ties_at_start > 0);
  const RunResult full = run_deck(a, -1, "", true);
  REQUIRE(full.blows.size() == 3);
  CHECK(full.tie_particles == ties_at_start);
  CHECK(full.blows[2].aggregate_added_kg > 0);
  for (size_t k = 1; k < 3; ++k) CHECK(full.blows[k].crater_depth_m > full.blows[k - 1].crater_depth_m);
  REQUIRE_FALSE(full.final_state.elements.node_r.empty());

  const std::string b = fresh_dir("drop_fem_part");
  (void)run_deck(b, 3, "", true);
  const std::string c = fresh_dir("drop_fem_rest");
  const RunResult resumed = run_deck(c, -1, b + "/checkpoints/003-impact-blow02.h5", true);
  REQUIRE(resumed.blows.size() == full.blows.size());
  double worst = 0;
  for (size_t k = 0; k < full.blows.size(); ++k)
    for (auto [p, q] : {std::pair{full.blows[k].crater_depth_m, resumed.blows[k].crater_depth_m},
                        {full.blows[k].uplift_m, resumed.blows[k].uplift_m},
                        {full.blows[k].peak_deceleration_m_s2, resumed.blows[k].peak_deceleration_m_s2}})
      worst = std::max(worst, std::fabs(p - q) / std::max(std::fabs(p), std::fabs(q)));
  REQUIRE(resumed.final_state.size() == full.final_state.size());
  double diff = 0;
  for (size_t i = 0; i < full.final_state.size(); ++i)
    diff = std::max({diff, std::fabs(full.final_state.z[i] - resumed.final_state.z[i]),
                     std::fabs(full.final_state.r[i] - resumed.final_state.r[i])});
  const tamp::ElementSnapshot &ef = full.final_state.elements, &er = resumed.final_state.elements;
  REQUIRE(ef.node_z.size() == er.node_z.size());
  for (size_t i = 0; i < ef.node_z.size(); ++i)
    diff = std::max({diff, std::fabs(ef.node_z[i] - er.node_z[i]), std::fabs(ef.node_r[i] - er.node_r[i])});
  std::printf("[drop, elements] %d tie particles; craters %.4f %.4f %.4f m; restart: worst relative difference of "
              "the blows %.3g, largest position difference %.3g m\n",
              full.tie_particles, full.blows[0].crater_depth_m, full.blows[1].crater_depth_m,
              full.blows[2].crater_depth_m, worst, diff);
  CHECK(worst < 1e-12);
  CHECK(diff < 1e-12);

  const std::string d = fresh_dir("drop_fem_one_step");
  const RunResult one = run_deck(d, -1, "", true, false);
  REQUIRE(one.blows.size() == full.blows.size());
  for (size_t k = 0; k < full.blows.size(); ++k) {
    const double rel = full.blows[k].crater_depth_m / one.blows[k].crater_depth_m - 1;
    std::printf("[drop, elements] blow %zu: crater %.4f m subcycled, %.4f m one step (%+.2f %%); energy residual "
                "%+.2f %% / %+.2f %% of the blow\n", k + 1,
                full.blows[k].crater_depth_m, one.blows[k].crater_depth_m, 100 * rel,
                100 * full.blows[k].residual_J / full.blows[k].energy_in_J,
                100 * one.blows[k].residual_J / one.blows[k].energy_in_J);
    CHECK(std::fabs(rel) < 0.02);
    // The account books the elements too (docs/drop-sequence.md "Energy account"); what the
    // tie does not conserve is in the residual. Measured 2026-12-03: -0.54 / +0.79 / +3.01 %
    // subcycled, -0.50 / +0.89 / +3.02 % one step (all particles: -0.42 / -1.15 / -0.69 %).
    // The 2 % is not met on blow 3 (docs/coupling.md); this bound (5 %) only guards
    // against losing the elements from the account again (particles only: 3.8-8.1 % on the lab).
    CHECK(std::fabs(full.blows[k].residual_J) < 0.05 * full.blows[k].energy_in_J);
    CHECK(std::fabs(one.blows[k].residual_J) < 0.05 * one.blows[k].energy_in_J);
  }
  tamp::log::set_level(tamp::log::Level::Info);
}

TEST_CASE("Drop sequence: a charge that finds no room in a shallow crater adds nothing, and the run goes on",
          "[drop-sequence]") {
  // The lab's late light blows (0.5, 0.3, 0.15 m) leave craters shallower than a particle
  // spacing, where a charge finds no free site: that charge adds no particle, and the run
  // must go on (the main job once crashed there, remapping its tracers through an empty
  // renumbering). The CI scenario with a fourth blow from 0.02 m onto the filled crater and
  // a charge after it, then a fifth blow: the charge after blow 4 adds 0 kg, blow 5 is
  // struck, the aggregate in the particles is what the charges added, and the tracers are
  // written for every blow. Measured 2026-12-04: blow 4 rests 0.1 mm above the original
  // ground on the charge of blow 3 (filled to the ground, its top 1.5 mm proud after the
  // extraction); blow 5 makes a 9.6 mm crater. About 14 s on 2 threads.
  tamp::log::set_level(tamp::log::Level::Quiet);
  const Config cfg = five_blow_ci_deck(0.02);
  const std::string dir = fresh_dir("drop_no_room");
  const RunResult run = run_config(cfg, dir);
  const auto& blows = run.blows;
  REQUIRE(blows.size() == 5);
  const double dp = cfg.sph.spacing;
  std::printf("[drop, no room] blow 4 from 0.02 m: crater %.4f m, floor after extraction %.4f m, charge %.3f kg; "
              "blow 5: crater %.4f m\n",
              blows[3].crater_depth_m, blows[3].crater_floor_m, blows[3].aggregate_added_kg, blows[4].crater_depth_m);
  CHECK(blows[2].aggregate_added_kg > 0.0);
  CHECK(blows[3].crater_floor_m < dp);  // the crater left is shallower than a particle
  CHECK(blows[3].aggregate_added_kg == 0.0);
  CHECK(blows[4].rest_in_contact == 1.0);
  CHECK(blows[4].penetration_m > 0.0);
  double in_particles = 0;
  const ParticleSnapshot& s = run.final_state;
  for (size_t i = 0; i < s.size(); ++i)
    if (s.material[i] == 2) in_particles += s.mass[i];  // materials: sand, clay, aggregate
  CHECK(in_particles == Approx(blows[2].aggregate_added_kg).epsilon(1e-12));
  const auto tracers = read_csv(dir + "/tracers.csv");
  REQUIRE_FALSE(tracers.empty());
  CHECK(tracers.back()[1] == 5.0);  // column "blow": the last rows are blow 5's
  for (double v : tracers.back()) CHECK(std::isfinite(v));
  tamp::log::set_level(tamp::log::Level::Info);
}

TEST_CASE("Drop sequence: a charge fills the crater to the original ground, or level with the heaved surface "
          "around it", "[drop-sequence]") {
  // [backfill] mode = "surface" (docs/drop-sequence.md): the level is the mean top of the
  // soil in the two radial columns just outside the fill radius. A clay bed (10 mm spacing)
  // with a hole of radius 0.06 m from z = 0.06 m up to the original ground at 0.10 m, and a
  // ring of clay 2 spacings proud of the ground just outside it (0.06 < r < 0.09 m, up to
  // 0.12 m: the heaved rim); fill radius 0.06 m (pounder 0.08 m wide + 2 spacings). One
  // blow from 5 mm, then a charge. The two runs are the same until the charge; "surface"
  // fills the hole's 6 columns 2 rows higher: the ring masses rho 2 pi r_c dp^2 of those 12
  // sites, 2 x 1835 x 2 pi x 18 dp^3 = 0.4151 kg more (to round-off, 1e-12). Both charges
  // stay below the level they fill to. Under 1 s on 2 threads.
  tamp::log::set_level(tamp::log::Level::Quiet);
  Config cfg = load_deck(deck_path);
  const double dp = 0.01;
  cfg.sph.spacing = dp;
  cfg.blocks = {{"clay", 0.0, 0.15, 0.0, 0.06}, {"clay", 0.06, 0.15, 0.06, 0.10}, {"clay", 0.06, 0.09, 0.10, 0.12}};
  cfg.bottom.position = 0.0;
  cfg.outer.position = 0.15;
  cfg.pounder.base_diameter = 0.07;
  cfg.pounder.max_diameter = 0.08;
  cfg.pounder.height = 0.1;
  cfg.schedule.ground_level = 0.10;
  cfg.schedule.drop_heights = {0.005};
  cfg.schedule.backfill_after = {1};
  cfg.tracers.clear();
  const double rho = cfg.materials[2].density;  // the aggregate
  double expected = 0;
  for (int k = 0; k < 6; ++k) expected += 2 * rho * 2.0 * tamp::pi * (k + 0.5) * dp * dp * dp;
  auto charge = [&](const std::string& mode) {
    Config c = cfg;
    c.backfill.mode = mode;
    const RunResult run = run_config(c, fresh_dir("backfill_" + mode));
    REQUIRE(run.blows.size() == 1);
    double top = -1;  // highest aggregate particle centre
    for (size_t i = 0; i < run.final_state.size(); ++i)
      if (run.final_state.material[i] == 2) top = std::max(top, run.final_state.z[i]);
    std::printf("[backfill] mode %s: charge %.4f kg, its highest grain at %.4f m\n", mode.c_str(),
                run.blows[0].aggregate_added_kg, top);
    return std::make_pair(run.blows[0].aggregate_added_kg, top);
  };
  const auto [fill_kg, fill_top] = charge("fill");
  const auto [surface_kg, surface_top] = charge("surface");
  CHECK(fill_kg > 0.0);
  CHECK(surface_kg - fill_kg == Approx(expected).epsilon(1e-12));
  CHECK(fill_top < 0.10);
  CHECK(surface_top > 0.10);
  CHECK(surface_top < 0.12);
  tamp::log::set_level(tamp::log::Level::Info);
}

namespace {
// The CI scenario with a fourth and fifth blow and charges after blows 3 and 4, run whole and
// restarted from each named checkpoint of the whole run: every blow's crater and uplift must
// be the uninterrupted run's, bit for bit.
void check_restarts_exact(const std::vector<std::string>& checkpoints, const std::string& tag) {
  tamp::log::set_level(tamp::log::Level::Quiet);
  const Config cfg = five_blow_ci_deck(0.30);
  const std::string a = fresh_dir("restart_" + tag + "_full");
  const auto full = run_config(cfg, a).blows;
  REQUIRE(full.size() == 5);
  for (const auto& ck : checkpoints) {
    const auto resumed = run_config(cfg, fresh_dir("restart_" + tag + "_" + ck), -1, a + "/checkpoints/" + ck + ".h5").blows;
    REQUIRE(resumed.size() == full.size());
    for (size_t k = 0; k < full.size(); ++k) {
      if (resumed[k].crater_depth_m != full[k].crater_depth_m)
        std::printf("[restart] from %s: blow %zu crater %.17g m, uninterrupted %.17g m\n", ck.c_str(), k + 1,
                    resumed[k].crater_depth_m, full[k].crater_depth_m);
      CHECK(resumed[k].crater_depth_m == full[k].crater_depth_m);
      CHECK(resumed[k].uplift_m == full[k].uplift_m);
    }
  }
  tamp::log::set_level(tamp::log::Level::Info);
}
}  // namespace

// Found 2026-12-04 comparing a whole 10 mm main job with the resolution study's restarted
// one: a restart into a stage that begins by placing the pounder or adding a charge was not
// the uninterrupted run (craters apart by 0.4-63 um on this scenario from the next blow on;
// CI restarted from an impact only, which is followed by an extraction). Two causes, both
// mended: those stages compute the accelerations before any strain-rate pass, from the
// artificial stress and the hoop factor, which checkpoints did not hold (they do now); and
// placing the pounder used the mirror ghosts' half-step velocities where a restart has the
// full-step ones (it syncs them now). The two kinds of stage boundary the CI restart test
// above (from an impact, into an extraction) does not cross: extraction -> charge and
// charge -> impact. (Checked by hand on 2026-12-04 also from 000, 002, 008 and 010: equal.)
TEST_CASE("Restart: from the end of an extraction or a charge, through charges and blows, the run is the "
          "uninterrupted one bit for bit",
          "[restart][drop-sequence]") {
  check_restarts_exact({"006-extract-blow03", "007-backfill-blow03"}, "exact");
}

namespace {
// Real particles at the points xs (r, z) with materials mats, each a ring of one spacing
// square at density rho (mass rho 2 pi r dp^2): the measurements' tests lay them by hand.
tamp::Particles laid_by_hand(const std::vector<std::array<double, 2>>& xs, const std::vector<int>& mats, double dp,
                             double rho) {
  tamp::Particles P;
  const int N = static_cast<int>(xs.size());
  P.reserve(N);
  P.n_real = N;
  auto x = Kokkos::create_mirror_view(P.x);
  auto m = Kokkos::create_mirror_view(P.mass);
  auto r = Kokkos::create_mirror_view(P.rho);
  auto mat = Kokkos::create_mirror_view(P.material);
  for (int p = 0; p < N; ++p) {
    x(p, 0) = xs[p][0];
    x(p, 1) = xs[p][1];
    r(p) = rho;
    m(p) = rho * 2 * tamp::pi * xs[p][0] * dp * dp;
    mat(p) = mats[p];
  }
  Kokkos::deep_copy(P.x, x);
  Kokkos::deep_copy(P.mass, m);
  Kokkos::deep_copy(P.rho, r);
  Kokkos::deep_copy(P.material, mat);
  return P;
}
}  // namespace

// The column measure (docs/drop-sequence.md "Column"): a column of known diameter 2 n dp on a
// lattice in a clay wall, with grains heaped above the original ground at heights that put
// the aggregate's top anywhere within a spacing. Exact answers (1e-12 relative, round-off):
// - the outline, the hole in the clay 2 (r_wall - dp/2) with the wall's first ring at
//   (n + 1/2) dp, is 2 n dp: the head, the widest band and the base, whatever the heap;
// - the solid diameter 2 sqrt(V_b / (pi dp)) of a band of n rings r = (i + 1/2) dp (ring
//   volume 2 pi r dp^2) is also 2 n dp; with every other ring left out (a loose column,
//   grains two spacings apart) it is 2 dp sqrt(sum of the kept (2 i + 1)), while the
//   outline stays 2 n dp;
// - a lone clay particle inside the column (fewer than 3 clay neighbours) is not the wall;
//   without any wall the band's diameter is the solid one;
// - the length is the lattice's extent in the ground.
// Bands laid from the top grain down (the rule until 2026-12-05) averaged a half-empty band
// of heap grains into the head for some of these heaps.
TEST_CASE("Column: head, widest band and length measured in bands fixed below the original ground, as the hole in "
          "the clay, whatever grains lie heaped above it",
          "[drop-sequence][column]") {
  const double dp = 0.01, ground = 0.5, rho = 1900.0;
  const int n = 7, rows = 30, aggregate = 2;
  const double d_exact = 2 * n * dp;
  double loose_sum = 0;
  for (int i = 0; i < n; i += 2) loose_sum += 2 * i + 1;
  for (int variant = 0; variant < 3; ++variant) {  // 0: dense column in clay, 1: loose column in clay, 2: no clay
    for (double shift : {-0.003, 0.0, 0.0025}) {    // lattice rows at ground - (k + 1/2) dp + shift
      for (double heap_top : {-1.0, 0.0005, 0.002, 0.0049, 0.006, 0.012, 0.023}) {  // above the ground, m (-1: none)
        std::vector<std::array<double, 2>> xs;
        for (int k = 0; k < rows; ++k)
          for (int i = 0; i < n; i += variant == 1 ? 2 : 1) xs.push_back({(i + 0.5) * dp, ground - (k + 0.5) * dp + shift});
        for (double z = ground + heap_top; heap_top > 0 && z > ground + 1e-4; z -= dp)
          for (int i = 0; i < 3; ++i) xs.push_back({(i + 0.5) * dp, z});  // a narrower heap, 60 mm
        const int n_agg = static_cast<int>(xs.size());
        if (variant != 2) {
          for (int k = 0; k < rows; ++k)  // the clay wall, 5 rings thick
            for (int i = n; i < n + 5; ++i) xs.push_back({(i + 0.5) * dp, ground - (k + 0.5) * dp});
          if (variant == 1) xs.push_back({1.5 * dp, ground - 10.3 * dp + shift});  // a lone entrained clay particle
        }
        std::vector<int> mats(xs.size(), 1);
        std::fill(mats.begin(), mats.begin() + n_agg, aggregate);
        const tamp::Particles P = laid_by_hand(xs, mats, dp, rho);
        const tamp::ColumnSummary c = tamp::measure_column(tamp::ParticleSurvey(P, dp), aggregate, ground, dp);
        INFO("variant " << variant << ", lattice shift " << shift << " m, heap top " << heap_top
                        << " m above the ground: head " << c.head_diameter_m << " (solid " << c.head_solid_diameter_m
                        << "), max " << c.max_diameter_m << ", base " << c.base_diameter_m << ", length " << c.length_m);
        const double solid = variant == 1 ? 2 * dp * std::sqrt(loose_sum) : d_exact;
        const double outline = variant == 2 ? solid : d_exact;
        CHECK(c.head_diameter_m == Approx(outline).epsilon(1e-12));
        CHECK(c.max_diameter_m == Approx(outline).epsilon(1e-12));
        CHECK(c.base_diameter_m == Approx(outline).epsilon(1e-12));
        CHECK(c.head_solid_diameter_m == Approx(solid).epsilon(1e-12));
        CHECK(c.max_solid_diameter_m == Approx(solid).epsilon(1e-12));
        const double top = heap_top > 0 ? ground : std::min(ground, ground + shift);
        CHECK(c.length_m == Approx(top - (ground - (rows - 0.5) * dp + shift - 0.5 * dp)).epsilon(1e-12));
      }
    }
  }
}

// The other measurements of a blow, each alone on particles laid by hand (kernels/DropMeasures.hpp):
// a clay lattice whose top is the ground (centres at ground - (k + 1/2) dp, top = centre + dp/2),
// a ring of one more row from r = 0.07 to 0.12 m (the heave: its top dp above the ground), a
// crater of three rows under the pounder's base (r < 0.04 m), and one particle splashed 5 dp
// up with no neighbour (not ground). Exact by construction: the uplift is dp, the heave volume
// the sum of the raised rings' volumes 2 pi r_c dp^2 outside the pounder's widest radius, the
// crater floor 3 dp below the ground, the top under the pounder the highest centre there.
TEST_CASE("Measurements: uplift, heave volume and crater floor of a surface laid by hand", "[drop-sequence][column]") {
  const double dp = 0.01, ground = 0.3, rho = 1900.0;
  const int rings = 30, rows = 12;
  std::vector<std::array<double, 2>> xs;
  for (int i = 0; i < rings; ++i) {
    const double rc = (i + 0.5) * dp;
    for (int k = (rc < 0.04 ? 3 : 0); k < rows; ++k) xs.push_back({rc, ground - (k + 0.5) * dp});
    if (rc > 0.07 && rc < 0.12) xs.push_back({rc, ground + 0.5 * dp});
  }
  xs.push_back({0.095, ground + 5.5 * dp});  // a splash
  const tamp::Particles P = laid_by_hand(xs, std::vector<int>(xs.size(), 0), dp, rho);
  const tamp::ParticleSurvey survey(P, dp);
  tamp::DropGeometry g;
  g.ground = ground;
  g.spacing = dp;
  g.pounder_max_diameter = 0.1;
  g.pounder_base_diameter = 0.08;
  g.domain_r_max = rings * dp;
  double heave = 0;
  for (int i = 0; i < rings; ++i) {
    const double rc = (i + 0.5) * dp;
    if (rc > 0.07 && rc < 0.12 && rc >= 0.05) heave += 2 * tamp::pi * rc * dp * dp;
  }
  CHECK(tamp::uplift(survey, g) == Approx(dp).epsilon(1e-12));
  CHECK(tamp::heave_volume(survey, g) == Approx(heave).epsilon(1e-12));
  CHECK(tamp::crater_floor(survey, g) == Approx(3 * dp).epsilon(1e-12));
  // the highest centre whose column overlaps the pounder's widest radius (0.05 + dp/2): the splash at 0.095 is
  // outside it, the heave ring's first particles (r 0.075) too, so the lattice's top row
  CHECK(tamp::surface_under_pounder(survey, g) == Approx(ground - 0.5 * dp).epsilon(1e-12));
  // without the heave ring's window: an uplift measured further out sees the flat ground
  g.pounder_max_diameter = 0.3;
  CHECK(tamp::uplift(survey, g) == Approx(0.0).margin(1e-12));
  CHECK(tamp::heave_volume(survey, g) == Approx(0.0).margin(1e-15));
}

TEST_CASE("Blow account: rest in contact, the ballistic landing and the energy account, each alone",
          "[drop-sequence][blow]") {
  using namespace tamp;
  SECTION("at rest in contact: touching, slow, and carried by the soil within the tolerance") {
    const double W = 103.5;  // N, the lab pounder's weight
    CHECK(pounder_at_rest(true, 0.004, 1.05 * W, W, 0.005, 0.10));
    CHECK_FALSE(pounder_at_rest(false, 0.0, W, W, 0.005, 0.10));        // not touching
    CHECK_FALSE(pounder_at_rest(true, -0.006, W, W, 0.005, 0.10));      // sinking too fast
    CHECK_FALSE(pounder_at_rest(true, 0.0, 0.85 * W, W, 0.005, 0.10));  // held up by less than its weight
    CHECK_FALSE(pounder_at_rest(true, 0.0, 1.15 * W, W, 0.005, 0.10));  // still being pushed up
  }
  SECTION("landing time: the later root of the free fall, to round-off") {
    const double g = 9.81;
    CHECK(landing_time(1.0, 0.0, g, 0.0) == Approx(std::sqrt(2.0 / g)).epsilon(1e-14));
    for (const double v : {-1.5, 0.0, 0.8, 3.0}) {  // falling, at its apex, rising
      const double z = 0.3, z_land = 0.1, t = landing_time(z, v, g, z_land);
      CHECK(t > 0.0);
      CHECK(std::abs(z + v * t - 0.5 * g * t * t - z_land) < 1e-14);
      CHECK(v - g * t < 0.0);  // it arrives falling
    }
  }
  SECTION("energy account: the pounder's loss, split into the sinks, leaves no residual") {
    // Two materials; the pounder lost 10 J, which went to: soil motion 1, internal 6 (elastic
    // 2, numerical heat 0.5, so plastic 3.5), contact 1, radiated 1.2, damping 0.5, wall friction 0.3.
    BlowEnergies before, after;
    before.known = after.known = true;
    before.pounder = 12.0;
    after.pounder = 2.0;
    before.materials = {{0.0, 1.0, 0.0, 0.5, 0.1}, {0.0, 2.0, 0.0, 0.5, 0.0}};
    after.materials = {{0.4, 4.0, 0.2, 2.0, 0.6}, {0.4, 5.0, 0.0, 1.0, 0.0}};
    after.contact = 1.0;
    after.boundary = -1.2;
    after.damping = -0.5;
    after.wall_friction = -0.3;
    BlowRecord rec;
    account_blow_energy(before, after, rec);
    CHECK(rec.energy_in_J == Approx(10.0));
    CHECK(rec.soil_motion_J == Approx(1.0));
    CHECK(rec.elastic_J == Approx(2.0));
    CHECK(rec.viscous_heat_J == Approx(0.5));
    REQUIRE(rec.plastic_J.size() == 2);
    CHECK(rec.plastic_J[0] == Approx(3.0 - 1.5 - 0.5));
    CHECK(rec.plastic_J[1] == Approx(3.0 - 0.5));
    CHECK(rec.radiated_J == Approx(1.2));
    CHECK(rec.damping_J == Approx(0.5));
    CHECK(rec.wall_friction_J == Approx(0.3));
    CHECK(std::abs(rec.residual_J) < 1e-12);
    // A term the checkpoint before lacked (NaN) counts from the restart: no difference, so the
    // 1 J of contact energy is missing from the sinks and shows in the residual.
    before.contact = std::nan("");
    account_blow_energy(before, after, rec);
    CHECK(rec.contact_J == 0.0);
    CHECK(rec.residual_J == Approx(1.0));
  }
}
