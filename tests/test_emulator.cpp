// The loop's emulators (drivers/loop/): designs, the Gaussian process and the fit on it,
// checked on analytic functions whose answers are known.
#include <catch2/catch.hpp>
#include <cmath>
#include <functional>
#include <random>
#include <set>

#include "core/Deck.hpp"
#include "drivers/loop/Calibration.hpp"
#include "drivers/loop/EmulatedFit.hpp"
#include "drivers/loop/Emulator.hpp"

using tamp::loop::GaussianProcess;

TEST_CASE("Emulator: a maximin Latin hypercube has one point in each stratum of each input and is seeded", "[loop][emulator]") {
  const Eigen::MatrixXd X = tamp::loop::maximin_lhs(12, 3, 7);
  for (int j = 0; j < 3; ++j) {
    std::set<int> cells;
    for (int i = 0; i < 12; ++i) cells.insert(static_cast<int>(std::floor(X(i, j) * 12)));
    CHECK(cells.size() == 12);
  }
  CHECK((tamp::loop::maximin_lhs(12, 3, 7) - X).norm() == 0.0);  // the same seed, the same design
  CHECK((tamp::loop::maximin_lhs(12, 3, 8) - X).norm() > 0.0);
}

TEST_CASE("Emulator: a Gaussian process reproduces a quadratic within its stated variance, and reports its leave-one-out errors",
          "[loop][emulator]") {
  // f over [0, 1]^2, range about 4: a known quadratic response (no noise). From 20 maximin
  // points the emulator must predict 200 other points to 1 % of the range, and its stated
  // predictive sd must cover the error (|e| <= 3 sd at 97 % of them, as a Gaussian would at
  // 99.7 %). Leave-one-out errors: under 2 % of the range.
  auto f = [](const Eigen::VectorXd& x) { return 1 + 2 * x(0) - 3 * x(1) + 4 * x(0) * x(1) + x(0) * x(0); };
  const Eigen::MatrixXd X = tamp::loop::maximin_lhs(20, 2, 3);
  Eigen::VectorXd y(20);
  for (int i = 0; i < 20; ++i) y(i) = f(X.row(i).transpose());
  GaussianProcess gp;
  gp.fit(X, y);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  int covered = 0;
  double worst = 0;
  for (int k = 0; k < 200; ++k) {
    Eigen::VectorXd x(2);
    x << u(rng), u(rng);
    const auto p = gp.predict(x);
    const double e = std::fabs(p.mean - f(x));
    worst = std::max(worst, e);
    if (e <= 3 * std::sqrt(p.variance + p.nugget) + 1e-9) ++covered;
  }
  INFO("worst error " << worst << ", covered " << covered << " of 200");
  CHECK(worst < 0.04);
  CHECK(covered >= 194);
  const auto loo = gp.leave_one_out();
  const double loo_rmse = std::sqrt((loo.mean - y).squaredNorm() / 20);
  CHECK(loo_rmse < 0.08);
  CHECK(loo.sd.minCoeff() > 0);
}

TEST_CASE("Emulator: a too-small design misleads the emulator, the confirmation run catches it and the fit is refitted",
          "[loop][emulator]") {
  // One input, two outputs: y0 = x, y1 = a dip of width 0.04 at x = 0.72 in a slope. The
  // data are the dip's bottom (y0 = 0.72, y1 = 0), sigma 0.01. Three design points cannot see
  // the dip: the emulators' prediction at their optimum is wrong, and a run there contradicts it. The fit
  // must not stop on the emulator's word: it runs more rounds until a run agrees, and ends
  // at the dip.
  auto sim = [](const std::vector<Eigen::VectorXd>& pts) {
    std::vector<Eigen::VectorXd> out;
    for (const auto& x : pts) {
      Eigen::VectorXd y(2);
      y << x(0), 0.5 * (1 - std::exp(-std::pow((x(0) - 0.72) / 0.04, 2)));
      out.push_back(y);
    }
    return out;
  };
  Eigen::VectorXd t(2), s(2);
  t << 0.72, 0.0;
  s << 0.01, 0.01;
  tamp::loop::EmulatedFitOptions o;
  o.points_per_parameter = 3;
  o.max_rounds = 8;
  o.seed = 2;
  const auto fit = tamp::loop::emulated_fit(sim, t, s, 1, o);
  REQUIRE(fit.round_confirmed.size() >= 2);
  INFO("first round: emulated chi2 " << fit.round_predicted[0] << ", run " << fit.round_confirmed[0]);
  // the first optimum's run contradicts the emulators (by far more than their stated sd) ...
  CHECK(std::fabs(fit.round_confirmed[0] - fit.round_predicted[0]) > 100);
  CHECK(fit.rounds >= 2);  // ... so the fit went on, refitted with that run
  CHECK(fit.converged);
  CHECK(fit.x(0) == Approx(0.72).margin(0.01));
  CHECK(fit.run_chi2 < 10);
}

TEST_CASE("Emulator: decks that run the same physics compare equal after canonical_effects", "[loop][emulator]") {
  const tamp::Config base = tamp::load_deck(std::string(TAMP_SOURCE_DIR) + "/examples/synthetic/tiny-drop.toml");
  tamp::Config a = base, b = base;
  tamp::set_param(a, "clay.air_voids", 0.0);  // compaction with no air voids to lose: off
  tamp::set_param(a, "clay.crush_pressure", 5e4);
  CHECK(tamp::to_toml(tamp::canonical_effects(a)) == tamp::to_toml(tamp::canonical_effects(b)));
  tamp::set_param(a, "clay.air_voids", 0.1);
  CHECK(tamp::to_toml(tamp::canonical_effects(a)) != tamp::to_toml(tamp::canonical_effects(b)));
  tamp::Config c = base;
  tamp::set_param(c, "clay.rate_coefficient", 0.0);
  tamp::set_param(c, "clay.remoulded_ratio", 1.0);
  tamp::set_param(c, "clay.remoulding_strain", 3.0);
  CHECK(tamp::to_toml(tamp::canonical_effects(c)) == tamp::to_toml(tamp::canonical_effects(b)));
  // no air voids: no compaction on any material, and the deck is one the reader accepts (it
  // refuses a crush pressure without air voids)
  tamp::Config d = base;
  for (auto& m : d.materials)
    if (m.name == "aggregate") m.separation_density = 1500;
  const tamp::Config e = d;
  tamp::set_param(d, "aggregate.air_voids", 0.0);
  tamp::set_param(d, "aggregate.crush_pressure", 5e4);
  CHECK(tamp::to_toml(tamp::canonical_effects(d)) == tamp::to_toml(tamp::canonical_effects(e)));
  CHECK_THROWS(tamp::parse_deck(tamp::to_toml(d), "d.toml"));
  CHECK_NOTHROW(tamp::parse_deck(tamp::to_toml(tamp::canonical_effects(d)), "d.toml"));
}

namespace {
// A simulator of two outputs over [0, 1]^2: the point itself plus shift(x).
tamp::loop::UnitSimulator shifted(const std::function<Eigen::Vector2d(const Eigen::VectorXd&)>& shift) {
  return [shift](const std::vector<Eigen::VectorXd>& pts) {
    std::vector<Eigen::VectorXd> out;
    for (const auto& x : pts) out.push_back(x + shift(x));
    return out;
  };
}
}  // namespace

TEST_CASE("Emulator: a cheap simulator's bias is learnt from pairs of runs and not inherited by the fit", "[loop][emulator]") {
  // The full simulator gives (x0, x1); a cheap one the same shifted by (+0.10, -0.05), ten and
  // five times the data's sigma. Fitted to (0.4, 0.6) on the cheap one alone, the answer
  // inherits the bias (x0 = 0.3); with the full one beside it (each round's optimum run on
  // both, the rest cheap), the discrepancy is learnt (to 1e-6: it is constant here) and the
  // fit lands on the truth within a tenth of sigma, with a handful of full runs.
  const auto full = shifted([](const Eigen::VectorXd&) { return Eigen::Vector2d(0, 0); });
  const auto cheap = shifted([](const Eigen::VectorXd&) { return Eigen::Vector2d(0.10, -0.05); });
  Eigen::VectorXd t(2), s(2);
  t << 0.4, 0.6;
  s << 0.01, 0.01;
  tamp::loop::EmulatedFitOptions o;
  o.seed = 4;
  const auto alone = tamp::loop::emulated_fit(cheap, t, s, 2, o);
  CHECK(alone.x(0) == Approx(0.3).margin(0.002));
  const auto both = tamp::loop::emulated_fit(cheap, t, s, 2, o, {}, &full);
  INFO("full runs " << both.full_runs << ", pairs " << both.discrepancy.pairs);
  CHECK(both.discrepancy.mean(0, both.x) == Approx(-0.10).margin(1e-6));
  CHECK(both.discrepancy.mean(1, both.x) == Approx(0.05).margin(1e-6));
  CHECK(both.x(0) == Approx(0.4).margin(0.001));
  CHECK(both.x(1) == Approx(0.6).margin(0.001));
  CHECK(both.run_chi2 < 0.1);  // the full run at the fit
  CHECK(both.converged);
  CHECK(both.full_runs <= 5);
}

TEST_CASE("Emulator: a screening fit runs no full run and reads the full simulator through the pairs already run",
          "[loop][emulator]") {
  // The diagnosis screens its candidates on the cheap deck (EmulatedFitOptions::screen): the
  // pairs an earlier fit ran (here two, of the constant shift of the test above) carry the
  // discrepancy, so the screened fit lands on the full simulator's optimum without a full run
  // of its own; each round's optimum is checked by a cheap run against the cheap emulators.
  const auto full = shifted([](const Eigen::VectorXd&) { return Eigen::Vector2d(0, 0); });
  const auto cheap = shifted([](const Eigen::VectorXd&) { return Eigen::Vector2d(0.10, -0.05); });
  Eigen::VectorXd t(2), s(2);
  t << 0.4, 0.6;
  s << 0.01, 0.01;
  std::vector<tamp::loop::DiscrepancyPair> pairs;
  for (const Eigen::Vector2d x : {Eigen::Vector2d(0.2, 0.3), Eigen::Vector2d(0.7, 0.8)})
    pairs.push_back({x, cheap({x})[0], full({x})[0]});
  tamp::loop::EmulatedFitOptions o;
  o.seed = 4;
  o.screen = true;
  const auto fit = tamp::loop::emulated_fit(cheap, t, s, 2, o, {}, &full, pairs);
  INFO("x " << fit.x.transpose() << ", cheap runs " << fit.runs);
  CHECK(fit.screened);
  CHECK(fit.full_runs == 0);
  CHECK(fit.discrepancy.pairs == 2);
  CHECK(fit.x(0) == Approx(0.4).margin(0.001));
  CHECK(fit.x(1) == Approx(0.6).margin(0.001));
  CHECK(fit.confirmed);  // the cheap runs at the optimum agree with the cheap emulators
}

TEST_CASE("Emulator: a cheap simulator's bias that varies over the box is learnt linearly once there are enough pairs",
          "[loop][emulator]") {
  // The cheap simulator's first output is off by 0.05 + 0.3 x1 (5 to 35 sigma over the box), so
  // a constant discrepancy cannot serve everywhere. From d + 3 = 5 pairs on, the discrepancy is
  // fitted linearly (exact here); the fit, made to run all its 8 rounds (9 pairs), lands on the
  // truth with the linear discrepancy.
  const auto full = shifted([](const Eigen::VectorXd&) { return Eigen::Vector2d(0, 0); });
  const auto cheap = shifted([](const Eigen::VectorXd& x) { return Eigen::Vector2d(0.05 + 0.3 * x(1), 0); });
  Eigen::VectorXd t(2), s(2);
  t << 0.4, 0.6;
  s << 0.01, 0.01;
  tamp::loop::EmulatedFitOptions o;
  o.seed = 5;
  o.max_rounds = 8;
  o.max_latent_share = 0;  // never converged: all 8 rounds
  const auto fit = tamp::loop::emulated_fit(cheap, t, s, 2, o, {}, &full);
  INFO("full runs " << fit.full_runs << ", pairs " << fit.discrepancy.pairs << ", x " << fit.x.transpose());
  CHECK(fit.x(0) == Approx(0.4).margin(0.003));
  CHECK(fit.x(1) == Approx(0.6).margin(0.003));
  CHECK(fit.run_chi2 < 1);
  CHECK(fit.discrepancy.pairs == 9);
  REQUIRE(fit.discrepancy.linear);
  CHECK(fit.discrepancy.mean(0, fit.x) == Approx(-(0.05 + 0.3 * fit.x(1))).margin(1e-6));
  CHECK(fit.discrepancy.mean(1, fit.x) == Approx(0.0).margin(1e-6));
}
