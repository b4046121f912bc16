// The closed loop (issue: closing the loop): data files, residuals, and the undeclared-
// effect tests: synthetic data made by the engine with an effect that `diagnose` is not
// told about, on the tiny scenario examples/synthetic/tiny-drop.toml.
#include <catch2/catch.hpp>
#include <Kokkos_Core.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <chrono>
#include <filesystem>
#include <functional>
#include <fstream>
#include <sstream>

#include "core/Deck.hpp"
#include "core/Log.hpp"
#include "drivers/loop/ForwardRuns.hpp"
#include "drivers/loop/Calibration.hpp"
#include <nlohmann/json.hpp>

// Using-declarations, not `using namespace tamp`: tamp::log would clash with ::log in the
// CUDA math headers (nvcc).
using tamp::Config;
using tamp::DeckError;
using tamp::DiagnoseOptions;
using tamp::ObservationSet;
using tamp::RunOutputs;
using tamp::apply_effect;
using tamp::diagnose;
using tamp::load_deck;
using tamp::load_observations;
using tamp::residuals;
using tamp::rms;
using tamp::synthesise;
using tamp::write_observations;
namespace fs = std::filesystem;

namespace {
const std::string tiny = std::string(TAMP_SOURCE_DIR) + "/examples/synthetic/tiny-drop.toml";

std::string temp_dir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("tamp_loop_" + name);
  fs::remove_all(p);
  fs::create_directories(p);
  return p.string();
}

void write(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

std::string json_string(const std::string& path, const std::string& key) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string t = ss.str();
  const auto at = t.find("\"" + key + "\": ");
  REQUIRE(at != std::string::npos);
  const auto v = at + key.size() + 4;
  if (t[v] == '"') return t.substr(v + 1, t.find('"', v + 1) - v - 1);
  return t.substr(v, t.find_first_of(",\n}", v) - v);
}
}  // namespace

TEST_CASE("Loop: data files are validated and residuals are normalised by the uncertainty", "[loop]") {
  const std::string d = temp_dir("data");
  write(d + "/deck.toml", "# placeholder\n");
  write(d + "/ok.toml",
        "scenario = \"deck.toml\"\n[[observations]]\nquantity = \"uplift_m\"\nrange = [0.010, 0.014]\n"
        "[[observations]]\nquantity = \"crater_depth_m\"\nblow = 2\nvalue = 0.1\nsigma = 0.01\n");
  const ObservationSet set = load_observations(d + "/ok.toml");
  REQUIRE(set.observations.size() == 2);
  CHECK(set.scenario == (fs::path(d) / "deck.toml").string());
  CHECK(set.observations[0].value == Approx(0.012));
  CHECK(set.observations[0].sigma == Approx(0.002));
  RunOutputs run;
  run.summary["uplift_m"] = 0.016;
  run.blows = {{{"crater_depth_m", 0.05}}, {{"crater_depth_m", 0.13}}};
  const auto r = residuals(set, run);
  CHECK(r[0].normalised == Approx(2.0));   // (0.016 - 0.012) / 0.002
  CHECK(r[1].normalised == Approx(3.0));   // (0.13 - 0.1) / 0.01
  CHECK(rms(r) == Approx(std::sqrt(6.5)));

  auto require_error = [&](const std::string& text, const std::vector<std::string>& parts) {
    write(d + "/bad.toml", text);
    try {
      (void)load_observations(d + "/bad.toml");
      FAIL("no error for: " << text);
    } catch (const DeckError& e) {
      for (const auto& p : parts) CHECK_THAT(e.what(), Catch::Contains(p));
    }
  };
  require_error("[[observations]]\nquantity = \"uplift_m\"\nvalue = 1\nsigma = 1\n", {"bad.toml", "scenario is missing"});
  require_error("scenario = \"x\"\n[[observations]]\nquantity = \"upliftt\"\nvalue = 1\nsigma = 1\n",
                {"observations[0].quantity", "upliftt", "not a known quantity", "uplift_m"});
  require_error("scenario = \"x\"\n[[observations]]\nquantity = \"uplift_m\"\nvalue = 1\nsigma = 0\n",
                {"observations[0].sigma", "sigma > 0"});
  require_error("scenario = \"x\"\n[[observations]]\nquantity = \"uplift_m\"\nrange = [2, 1]\n",
                {"observations[0].range", "low < high"});
  require_error("scenario = \"x\"\n[[observations]]\nquantity = \"column_length_m\"\nblow = 3\nvalue = 1\nsigma = 1\n",
                {"not a per-blow quantity", "crater_depth_m"});
  // target materials: a name or a list, each once; diagnose checks them against the scenario
  // before any forward run
  write(d + "/two.toml", "scenario = \"deck.toml\"\ntarget_material = [\"clay\", \"aggregate\"]\n"
                         "[[observations]]\nquantity = \"uplift_m\"\nvalue = 0.01\nsigma = 0.001\n");
  const ObservationSet two = load_observations(d + "/two.toml");
  CHECK(two.target_materials == std::vector<std::string>{"clay", "aggregate"});
  CHECK(two.target_material == "clay");
  require_error("scenario = \"x\"\ntarget_material = [\"clay\", \"clay\"]\n[[observations]]\nquantity = \"uplift_m\"\n"
                "value = 1\nsigma = 1\n", {"target_material = \"clay\"", "is named twice"});
  require_error("scenario = \"x\"\ntarget_material = []\n[[observations]]\nquantity = \"uplift_m\"\nvalue = 1\nsigma = 1\n",
                {"target_material", "names no material"});
  write(d + "/peat.toml", "scenario = \"" + tiny + "\"\ntarget_material = [\"clay\", \"peat\"]\n"
                          "[[observations]]\nquantity = \"uplift_m\"\nvalue = 0.01\nsigma = 0.001\n");
  try {
    (void)diagnose(load_observations(d + "/peat.toml"), d + "/peat-diagnosis", DiagnoseOptions{});
    FAIL("no error for target_material peat");
  } catch (const DeckError& e) {
    CHECK_THAT(e.what(), Catch::Contains("target_material = \"peat\" is not a material of"));
    CHECK_THAT(e.what(), Catch::Contains("allowed: clay, aggregate"));
  }
  // model switches: a list of names, each once; diagnose checks them against its catalogue
  require_error("scenario = \"x\"\nmodel_switches = \"modified-cam-clay\"\n[[observations]]\nquantity = \"uplift_m\"\n"
                "value = 1\nsigma = 1\n", {"bad.toml", "model_switches", "wrong type", "a list of names"});
  require_error("scenario = \"x\"\nmodel_switches = [\"a\", \"a\"]\n[[observations]]\nquantity = \"uplift_m\"\n"
                "value = 1\nsigma = 1\n", {"model_switches", "\"a\"", "is named twice"});
  require_error("scenario = \"x\"\neffects = [1]\n[[observations]]\nquantity = \"uplift_m\"\nvalue = 1\nsigma = 1\n",
                {"effects[0]", "is not a name"});
  write(d + "/switch.toml", "scenario = \"" + tiny + "\"\nmodel_switches = [\"cam-clay\"]\n"
                            "[[observations]]\nquantity = \"uplift_m\"\nvalue = 0.01\nsigma = 0.001\n");
  const ObservationSet sw = load_observations(d + "/switch.toml");
  CHECK(sw.model_switches == std::vector<std::string>{"cam-clay"});
  CHECK(!sw.has_effects);  // no effects key: every effect of the catalogue
  write(d + "/effects.toml", "scenario = \"" + tiny + "\"\neffects = [\"rate\", \"creep\"]\n"
                             "[[observations]]\nquantity = \"uplift_m\"\nvalue = 0.01\nsigma = 0.001\n");
  try {
    tamp::check_target_materials(load_observations(d + "/effects.toml"), load_deck(tiny));
    FAIL("no error for effects = [\"rate\", \"creep\"]");
  } catch (const DeckError& e) {
    CHECK_THAT(e.what(), Catch::Contains("effects.toml: effects[1] = \"creep\" is not a known effect"));
    CHECK_THAT(e.what(), Catch::Contains("allowed: compaction, rate, remoulding"));
  }
  try {
    tamp::check_target_materials(sw, load_deck(tiny));
    FAIL("no error for model_switches = [\"cam-clay\"]");
  } catch (const DeckError& e) {
    CHECK_THAT(e.what(), Catch::Contains("switch.toml: model_switches[0] = \"cam-clay\" is not a known model switch"));
    CHECK_THAT(e.what(), Catch::Contains("allowed: modified-cam-clay"));
  }
  // the lab data file of the repository is valid
  const ObservationSet lab = load_observations(std::string(TAMP_SOURCE_DIR) + "/data/lab-observations.toml");
  CHECK(lab.observations.size() == 5);
  CHECK(fs::exists(lab.scenario));
  // The candidates of a diagnosis: on the cohesionless aggregate (c = 0) neither the effects
  // that scale c (rate, remoulding) nor the switch from Su are tried; on the clay all are.
  write(d + "/both.toml", "scenario = \"" + tiny + "\"\ntarget_material = [\"clay\", \"aggregate\"]\n"
                          "model_switches = [\"modified-cam-clay\"]\n"
                          "[[observations]]\nquantity = \"uplift_m\"\nvalue = 0.01\nsigma = 0.001\n");
  std::vector<std::string> labels;
  for (const auto& c : tamp::diagnosis_candidates(load_observations(d + "/both.toml"), load_deck(tiny)))
    labels.push_back(c.label);
  CHECK(labels == std::vector<std::string>{"compaction (clay)", "rate (clay)", "remoulding (clay)",
                                           "modified-cam-clay (clay)", "compaction (aggregate)"});
  // the lab's: the clay and the aggregate charge (docs/closing-the-loop.md)
  labels.clear();
  for (const auto& c : tamp::diagnosis_candidates(lab, load_deck(lab.scenario))) labels.push_back(c.label);
  CHECK(labels == std::vector<std::string>{"compaction (clay)", "rate (clay)", "remoulding (clay)",
                                           "modified-cam-clay (clay)", "compaction (aggregate)"});
}

TEST_CASE("Loop: a model switch sets the new model, its keys and its strength from Su, and its deck round-trips",
          "[loop]") {
  Config cfg = load_deck(tiny);
  apply_effect(cfg, "clay", "modified-cam-clay");
  const auto clay = [](const Config& c) {
    for (const auto& m : c.materials)
      if (m.name == "clay") return m;
    return tamp::MaterialSpec{};
  };
  CHECK(clay(cfg).model == "modified-cam-clay");
  // p_c0 = 4 Su / M: the top of the yield surface, q = M p_c0 / 2, is the Tresca q = 2 Su
  CHECK(tamp::get_param(cfg, "clay.p_c0") == Approx(4 * 10.2e3 / 0.9).epsilon(1e-12));
  CHECK(tamp::get_param(cfg, "clay.lambda") == 0.2);
  CHECK(tamp::get_param(cfg, "clay.kappa") == 0.04);
  CHECK(tamp::get_param(cfg, "clay.M") == 0.9);
  CHECK(clay(cfg).params.at("v0") == 2.2);
  CHECK(!tamp::has_param(cfg, "clay.Su"));  // the Tresca strength is no parameter of the new model
  const Config back = tamp::parse_deck(tamp::to_toml(cfg), "round-trip.toml");
  CHECK(clay(back).model == "modified-cam-clay");
  CHECK(tamp::get_param(back, "clay.p_c0") == tamp::get_param(cfg, "clay.p_c0"));
  CHECK(clay(back).params.at("v0") == 2.2);
  Config cfg2 = load_deck(tiny);  // the aggregate has no Su to start p_c0 from
  CHECK_THROWS_WITH(apply_effect(cfg2, "aggregate", "modified-cam-clay"), Catch::Contains("allowed: Su > 0"));
  CHECK_THROWS_WITH(apply_effect(cfg2, "clay", "cam-clay"), Catch::Contains("modified-cam-clay"));
}

namespace {
// synth (the truth: the deck changed by `make_truth`, seeded noise) -> diagnose of the
// unchanged deck; returns the selected effects and the errors. The diagnosis runs as many
// forward runs side by side as this process has threads (OMP_NUM_THREADS): with 2, child
// processes of 1 thread each (the tiny scenario's 150 particles use a second thread
// poorly); with 1, one at a time in this process, which is how scripts/run-tests runs it,
// two tests at a time. The answer is the same for any number of workers (test
// "[forward-runs]").
struct Outcome {
  std::string selected;
  double before, after;
  std::string json;  // diagnosis.json
};
Outcome undeclared(const std::string& name, const std::function<void(Config&)>& make_truth, unsigned seed,
                   const std::vector<std::string>& model_switches = {}, const std::vector<std::string>* effects = nullptr,
                   const std::string& method = "profile") {
  tamp::log::set_level(tamp::log::Level::Quiet);
  const std::string d = temp_dir(name);
  Config cfg = load_deck(tiny);
  make_truth(cfg);
  const std::string data = d + "/data.toml";
  synthesise(cfg, fs::relative(tiny, d).string(), "clay", 0.01, seed, data, d + "/synth", "test " + name);
  if (!model_switches.empty() || effects) {  // the candidates the data file asks for
    ObservationSet set = load_observations(data);
    set.model_switches = model_switches;
    if (effects) {
      set.has_effects = true;
      set.effects = *effects;
    }
    write_observations(data, set, "test " + name);
  }
  DiagnoseOptions opt;
  opt.fit.verbose = false;
  opt.jobs = std::max(1, static_cast<int>(Kokkos::DefaultHostExecutionSpace().concurrency()));
  opt.tamp_binary = TAMP_BINARY;
  // TAMP_LOOP_METHOD=bobyqa (or sbplx, lm) runs the diagnosis with another fit method, for
  // comparing methods on these tests (docs/closing-the-loop.md); the default is Nelder-Mead.
  // TAMP_LOOP_METHOD=emulator runs it on emulators (DiagnoseOptions::method).
  opt.method = method;
  if (const char* m = std::getenv("TAMP_LOOP_METHOD")) {
    if (std::string(m) == "emulator") opt.method = m;
    else opt.fit.method = m;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const std::string selected = diagnose(load_observations(data), d + "/diagnosis", opt);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const std::string js = d + "/diagnosis/diagnosis.json";
  std::ifstream in(js);
  std::stringstream text;
  text << in.rdbuf();
  Outcome o{selected, std::stod(json_string(js, "error_before")), std::stod(json_string(js, "error_after")), text.str()};
  std::printf("[loop] %s: selected '%s', error before %.3f, after %.3f; %s forward runs (+%s from the cache), %.0f s\n",
              name.c_str(), selected.c_str(), o.before, o.after, json_string(js, "run").c_str(),
              json_string(js, "from_cache").c_str(), wall);
  tamp::log::set_level(tamp::log::Level::Info);
  return o;
}
Outcome undeclared(const std::string& name, const std::string& effect, const std::map<std::string, double>& set,
                   unsigned seed) {
  return undeclared(name, [&](Config& cfg) { apply_effect(cfg, "clay", effect, set); }, seed);
}
}  // namespace

TEST_CASE("Loop: undeclared compaction is found and cuts the error by 3", "[loop][verification]") {
  const Outcome o = undeclared("compaction", "compaction", {{"crush_pressure", 15e3}}, 11);
  CHECK(o.selected == "compaction");
  CHECK(o.after < o.before / 3);
}

TEST_CASE("Loop: an undeclared rate effect is found and cuts the error by 3", "[loop][verification]") {
  const Outcome o = undeclared("rate", "rate", {{"rate_coefficient", 0.5}}, 12);
  CHECK(o.selected == "rate");
  CHECK(o.after < o.before / 3);
}

TEST_CASE("Loop: on emulators, an undeclared rate effect is found and cuts the error by 3 in a third of the runs",
          "[loop][verification][emulator]") {
  // The rate test's data (seed 12) diagnosed on emulators (--method emulator): every fit from a
  // maximin design of 10 runs per parameter less the earlier runs in its box, confirmed by runs
  // at the emulators' optimum. The profile method needs 360 forward runs on these data
  // (docs/closing-the-loop.md); the emulators at most a third of that.
  const Outcome o = undeclared("rate-emulated", [](Config& cfg) { apply_effect(cfg, "clay", "rate", {{"rate_coefficient", 0.5}}); },
                               12, {}, nullptr, "emulator");
  CHECK(o.selected == "rate");
  CHECK(o.after < o.before / 3);
  const auto js = nlohmann::json::parse(o.json);
  CHECK(js["forward_runs"]["run"].get<int>() <= 120);
  // every fit states its emulators' leave-one-out errors and whether a run confirmed them
  const auto& sel = js["path"][0]["fit"]["emulator"];
  CHECK(sel["confirmed"].get<bool>());
  CHECK(sel["leave_one_out"].size() == 8);
  for (const auto& l : sel["leave_one_out"]) CHECK(l["rmse_in_sigma"].get<double>() >= 0);
  // rate's coefficient and the strength it trades with are identified (sd under a quarter of the range)
  for (const auto& p : sel["parameters"]) CHECK(p["identified"].get<bool>());
}

TEST_CASE("Loop: compaction at air voids 0.25 and a crush pressure of 40 kPa is selected alone on emulators",
          "[loop][verification][emulator]") {
  // Issue acceptance 2 (a false second effect is not selected): the truth's clay compacts with
  // both of compaction's parameters away from the values the profile method fixes or starts
  // from (air voids 0.15, crush pressure 15 kPa). On emulators compaction fits both, so the
  // data are matched by compaction alone and no second effect earns the BIC margin.
  const Outcome o = undeclared("compaction-av25", [](Config& cfg) {
    apply_effect(cfg, "clay", "compaction", {{"crush_pressure", 40e3}, {"air_voids", 0.25}});
  }, 17, {}, nullptr, "emulator");
  CHECK(o.selected == "compaction");
  CHECK(o.after < o.before / 3);
  const auto js = nlohmann::json::parse(o.json);
  const auto& sel = js["path"][0]["fit"]["emulator"];
  CHECK(sel["confirmed"].get<bool>());
}

TEST_CASE("Loop: two undeclared effects at once are both found, step by step, and cut the error by 3",
          "[loop][verification]") {
  // (d) The truth has compaction and remoulding of the clay; the diagnosis must select both,
  // in either order (the second on top of the first), and end below a third of the error.
  const Outcome o = undeclared("two", [](Config& cfg) {
    apply_effect(cfg, "clay", "compaction", {{"crush_pressure", 15e3}});
    apply_effect(cfg, "clay", "remoulding", {{"remoulded_ratio", 0.5}});
  }, 14);
  CHECK((o.selected == "compaction + remoulding" || o.selected == "remoulding + compaction"));
  CHECK(o.after < o.before / 3);
  CHECK_THAT(o.json, Catch::Contains("\"path\""));
}

TEST_CASE("Loop: a change outside the catalogue (drop heights 10 % higher) is not claimed as an effect, or the "
          "residual left is flagged", "[loop][verification]") {
  // (e) The truth drops the pounder from 1.1 x the heights the deck says; no effect of the
  // catalogue is that. Either none is selected with strong evidence, or a residual the
  // selected effects do not explain is reported (error after above 2, with its pattern).
  const Outcome o = undeclared("heights", [](Config& cfg) {
    for (double& h : cfg.schedule.drop_heights) h *= 1.1;
  }, 15);
  const bool flagged = o.json.find("\"remains\": true") != std::string::npos;
  INFO("selected " << o.selected << ", error after " << o.after);
  CHECK((o.selected == "none" || flagged));
  // whenever the error stays above 2 the residual is reported as unexplained
  if (o.after > 2) CHECK(flagged);
}

TEST_CASE("Loop: a clay that is Modified Cam-Clay is found by the model switch and cuts the error by 3",
          "[loop][verification]") {
  // The truth's clay is Modified Cam-Clay (lambda 0.3, p_c0 60 kPa; kappa, M, v0 the switch's
  // fixed values); the deck's is Tresca. The data file asks for `model_switches =
  // ["modified-cam-clay"]` and, to keep CI within its 20 minutes, no effect (`effects = []`:
  // 87 runs, about 70 s on 2 threads; 91 s with compaction beside it, 138 s with all three).
  // The switch is fitted as an effect is (as many parameters: p_c0 in place of Su, and
  // lambda) and must earn its place by the same BIC margin: it must be selected and cut the
  // error by 3. Beside all three effects, on the same data, it is selected too, by a BIC 1857
  // below compaction's (docs/closing-the-loop.md "Model switches").
  const std::vector<std::string> effects{};
  const Outcome o = undeclared("cam-clay", [](Config& cfg) {
    apply_effect(cfg, "clay", "modified-cam-clay", {{"lambda", 0.3}, {"p_c0", 60e3}});
  }, 16, {"modified-cam-clay"}, &effects);
  CHECK(o.selected == "modified-cam-clay");
  CHECK(o.after < o.before / 3);
  CHECK_THAT(o.json, Catch::Contains("\"kind\": \"model switch\""));
  CHECK_THAT(o.json, Catch::Contains("\"effects\": []"));
}

// (c) Hidden from 2026-12-01 to 12-02 as a known defect (docs/closing-the-loop.md "A false
// positive"): the sequential profile's refit stopped at Su = 12.41 kPa on the rough peak
// deceleration of blow 2 and remoulding exploited it. The batched profile grid (its scan of
// Su at every effect value) and the fair comparison now find the better baseline.
TEST_CASE("Loop: shifted baseline parameters without an effect give 'none'", "[loop][verification]") {
  const Outcome o = undeclared("none", "none", {{"clay.Su", 12.5e3}}, 13);
  CHECK(o.selected == "none");
  // The baseline refitted to the shifted Su has its misfit within the noise (chi2 7.8 on 8
  // observations): a candidate's BIC is at least its 2 parameters times ln 8 = 4.16, not
  // below the baseline's BIC minus the margin 6, so no refit could be selected and step 1 is
  // recorded as not run, with that bound (exact: the answer the refits would give; the
  // refits' false-positive guard is exercised by test (e) and step 2 of the compaction test).
  const auto js = nlohmann::json::parse(o.json);
  REQUIRE(js["path"].size() == 1);
  const auto& step = js["path"][0];
  REQUIRE(step.contains("not_run"));
  const double start_bic = step["start"]["bic"].get<double>();
  CHECK(step["not_run"]["start_bic"].get<double>() == Approx(start_bic));
  CHECK(step["not_run"]["bic_floor"].get<double>() == Approx(2 * std::log(8.0)));  // Su + the effect's, n = 8
  CHECK(step["not_run"]["bic_floor"].get<double>() >= start_bic - js["bic_margin"].get<double>());
  CHECK(step["candidates"].empty());
}

TEST_CASE("Loop: a damaged run folder is an error naming the file, row and column", "[loop]") {
  // Issue 13's reproducer 6: an empty, garbage, [] or truncated summary.json was read as
  // zeros (and `tamp compare` exited 0), a blows.csv cell "abc" gave "stod", "12abc" was 12.
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "tamp-test-damaged-run";
  fs::remove_all(dir);
  fs::create_directories(dir);
  auto write = [&](const char* name, const std::string& text) { std::ofstream(dir / name) << text; };
  auto error = [&]() {
    try {
      tamp::read_run_dir(dir.string());
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string good_csv = "blow,crater_depth_m\n1,0.05\n2,0.08\n";
  write("blows.csv", good_csv);
  write("summary.json", "{\"uplift_m\": 0.012, \"column_length_m\": null}");
  const RunOutputs ok = tamp::read_run_dir(dir.string());
  CHECK(ok.summary.at("uplift_m") == 0.012);
  CHECK(std::isnan(ok.summary.at("column_length_m")));  // null: not measured
  CHECK(ok.blows.at(1).at("crater_depth_m") == 0.08);
  for (const char* bad : {"", "garbage{", "{\"uplift_m\": 0.0"}) {
    write("summary.json", bad);
    CHECK_THAT(error(), Catch::Contains("summary.json is not valid JSON"));
  }
  write("summary.json", "[]");
  CHECK_THAT(error(), Catch::Contains("summary.json is not a JSON object"));
  write("summary.json", "{\"uplift_m\": \"12\"}");
  CHECK_THAT(error(), Catch::Contains("\"uplift_m\" is \"12\"; allowed: a number or null"));
  write("summary.json", "{\"uplift_m\": 0.012}");
  for (const char* cell : {"abc", "12abc", "1e999"}) {
    write("blows.csv", std::string("blow,crater_depth_m\n1,0.05\n2,") + cell + "\n");
    CHECK_THAT(error(), Catch::Contains("blows.csv row 3, column crater_depth_m: '" + std::string(cell) +
                                        "' is not a finite number"));
  }
  write("blows.csv", "blow,crater_depth_m\n1\n");
  CHECK_THAT(error(), Catch::Contains("blows.csv row 2 has 1 cells; the header has 2"));
  fs::remove_all(dir);
}

TEST_CASE("Loop: forward runs side by side give the answers of one at a time, the cache skips finished runs, a "
          "failed run is a failed point", "[loop][forward-runs]") {
  // Three decks of the tiny scenario (clay Su 0.8, 1, 1.25 of its value). One at a time in
  // this process on 2 threads, against 2 child processes of 1 thread each: every summary and
  // blow value must be equal to the last bit (deterministic reductions, decks that
  // round-trip), which is what lets a diagnosis give the same answer on any number of workers.
  tamp::log::set_level(tamp::log::Level::Quiet);
  const Config base = load_deck(tiny);
  std::vector<Config> batch;
  for (double f : {0.8, 1.0, 1.25}) {
    Config c = base;
    tamp::set_param(c, "clay.Su", f * tamp::get_param(base, "clay.Su"));
    batch.push_back(c);
  }
  batch.push_back(batch[1]);  // the same deck twice: run once
  const std::string d = temp_dir("forward");
  tamp::ForwardRunOptions one;
  one.scratch = d + "/one";
  one.cache = d + "/cache-one";
  tamp::ForwardRunOptions two = one;
  two.jobs = 2;
  two.threads_per_job = 1;
  two.scratch = d + "/two";
  two.cache = d + "/cache-two";
  two.tamp_binary = TAMP_BINARY;
  tamp::ForwardRuns a(one), b(two);
  const auto ra = a.run(batch);
  const auto rb = b.run(batch);
  CHECK(a.runs() == 3);
  CHECK(b.runs() == 3);
  REQUIRE(ra.size() == 4);
  int compared = 0;
  for (size_t k = 0; k < ra.size(); ++k) {
    REQUIRE(ra[k].ok);
    REQUIRE(rb[k].ok);
    for (const auto& [key, v] : ra[k].outputs.summary) {
      if (key == "wall_s") continue;
      REQUIRE(rb[k].outputs.summary.count(key) == 1);
      CHECK(rb[k].outputs.summary.at(key) == v);
      ++compared;
    }
    REQUIRE(ra[k].outputs.blows.size() == rb[k].outputs.blows.size());
    for (size_t i = 0; i < ra[k].outputs.blows.size(); ++i)
      for (const auto& [key, v] : ra[k].outputs.blows[i]) {
        if (key == "wall_s") continue;
        INFO("blow " << i + 1 << " " << key);
        CHECK(rb[k].outputs.blows[i].at(key) == v);
        ++compared;
      }
  }
  std::printf("[forward] %d values compared, 1 worker x 2 threads against 2 workers x 1 thread: identical\n", compared);
  // a different Su gives a different crater (the runs are not trivially equal)
  CHECK(ra[0].outputs.summary.at("column_length_m") != ra[2].outputs.summary.at("column_length_m"));
  // the cache: a second runner on the same cache runs nothing
  tamp::ForwardRuns again(two);
  const auto rc = again.run(batch);
  CHECK(again.runs() == 0);
  CHECK(again.cache_hits() == 4);
  CHECK(rc[2].outputs.summary.at("uplift_m") == rb[2].outputs.summary.at("uplift_m"));
  // ... but not the runs of another engine build: the cache key holds the engine (by
  // default a hash of the executables; here named, as a rebuilt engine would hash)
  tamp::ForwardRunOptions rebuilt = two;
  rebuilt.engine = "another-build";
  tamp::ForwardRuns other(rebuilt);
  (void)other.run(batch);
  CHECK(other.runs() == 3);
  CHECK(other.cache_hits() == b.cache_hits());  // as on an empty cache (the repeated deck only)
  // the default engine is this process's executable and the children's: 16 hex digits that
  // change with the files' bytes
  const std::string e_self = tamp::engine_fingerprint({"/proc/self/exe"});
  CHECK(e_self.size() == 16);
  CHECK(e_self == tamp::engine_fingerprint({"/proc/self/exe"}));
  CHECK(e_self != tamp::engine_fingerprint({"/proc/self/exe", TAMP_BINARY}));
  // a failed run (here a time-out) is a recorded failed point, and stays one from the cache
  tamp::ForwardRunOptions slow = two;
  slow.cache = d + "/cache-slow";
  slow.timeout_s = 1e-3;
  tamp::ForwardRuns s(slow);
  const auto rs = s.run(std::vector<Config>{batch[0]});
  CHECK_FALSE(rs[0].ok);
  CHECK_THAT(rs[0].failure, Catch::Contains("time-out"));
  CHECK(s.failures() == 1);
  tamp::ForwardRuns s2(slow);
  CHECK_FALSE(s2.run(batch[0]).ok);
  CHECK(s2.runs() == 0);
  tamp::log::set_level(tamp::log::Level::Info);
}

#ifdef TAMP_HAVE_MPI
TEST_CASE("Loop: fits side by side give the answers of one after the other in fewer rounds of runs",
          "[loop][forward-runs]") {
  // Two calibrations of Su on the same data from two starts (0.7 and 1.4 of the truth), on
  // one blow of the tiny scenario: one after the other, then side by side through
  // ForwardRuns::side_by_side (their batches merged). Values, chi2 and runs must be equal to
  // the last bit; the merged batches are fewer.
  tamp::log::set_level(tamp::log::Level::Quiet);
  const std::string d = temp_dir("lanes");
  Config base = load_deck(tiny);
  base.schedule.drop_heights = {0.85};
  base.schedule.backfill_after.clear();
  Config truth = base;
  tamp::set_param(truth, "clay.Su", 12e3);
  synthesise(truth, fs::relative(tiny, d).string(), "clay", 0.01, 21, d + "/data.toml", d + "/synth", "lanes");
  const ObservationSet data = load_observations(d + "/data.toml");
  std::vector<Config> starts(2, base);
  tamp::set_param(starts[0], "clay.Su", 0.7 * 12e3);
  tamp::set_param(starts[1], "clay.Su", 1.4 * 12e3);
  auto fit = [&](const Config& c, tamp::ForwardRuns& r) {
    tamp::CalibrateOptions o;
    o.verbose = false;
    o.max_runs = 10;
    o.runner = &r;
    return tamp::calibrate(c, data, {"clay.Su"}, o);
  };
  tamp::ForwardRunOptions fo;
  fo.scratch = d + "/one";
  tamp::ForwardRuns one(fo);
  const tamp::FitResult a0 = fit(starts[0], one), a1 = fit(starts[1], one);
  fo.scratch = d + "/two";
  tamp::ForwardRuns two(fo);
  std::vector<tamp::FitResult> b(2);
  two.side_by_side(2, [&](size_t i) { b[i] = fit(starts[i], two); });
  long batches_one = 0, batches_two = 0;
  for (const auto& [size, count] : one.batch_sizes()) batches_one += count;
  for (const auto& [size, count] : two.batch_sizes()) batches_two += count;
  std::printf("[lanes] Su %.6f / %.6f kPa, %d + %d runs; %ld batches one after the other, %ld side by side\n",
              a0.values[0] / 1e3, a1.values[0] / 1e3, a0.runs, a1.runs, batches_one, batches_two);
  CHECK(b[0].values[0] == a0.values[0]);
  CHECK(b[1].values[0] == a1.values[0]);
  CHECK(b[0].chi2 == a0.chi2);
  CHECK(b[1].chi2 == a1.chi2);
  CHECK(b[0].sigmas[0] == a0.sigmas[0]);
  CHECK(b[0].runs == a0.runs);
  CHECK(b[1].runs == a1.runs);
  CHECK(two.runs() <= one.runs());  // a deck both fits ask for at once runs once
  CHECK(batches_two < batches_one);
  // a fit that throws: the others finish, the error comes back to the caller
  CHECK_THROWS_WITH(two.side_by_side(3, [&](size_t i) {
                      if (i == 1) throw std::runtime_error("fit 1 failed");
                      (void)two.run(std::vector<Config>{starts[0]});
                    }),
                    "fit 1 failed");
  tamp::log::set_level(tamp::log::Level::Info);
}

TEST_CASE("Loop: a calibration shared by 2 MPI ranks gives the answer of one process", "[loop][forward-runs][mpi]") {
  // `mpirun -n 2 tamp calibrate`: the ranks share every batch of forward runs and exchange
  // the results (drivers/loop/ForwardRuns.hpp); the fit must be the one of a single process to
  // the last bit (parameter, uncertainty, chi2, runs), and rank 0 alone writes the files.
  namespace fs = std::filesystem;
  const std::string d = temp_dir("mpi");
  const std::string bin = TAMP_BINARY;
  const std::string data = d + "/data.toml";
  auto sh = [&](const std::string& cmd) {
    const int status = std::system(("OMP_PROC_BIND=false " + cmd + " > " + d + "/log.txt 2>&1").c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  };
  REQUIRE(sh(bin + " synth " + tiny + " --set clay.Su=12000 --seed 5 --out " + data) == 0);
  REQUIRE(sh("OMP_NUM_THREADS=2 " + bin + " calibrate " + data + " --out " + d + "/one") == 0);
  const int rc = sh("mpirun -n 2 --allow-run-as-root --oversubscribe -x OMP_NUM_THREADS=1 -x OMP_PROC_BIND " + bin +
                    " calibrate " + data + " --out " + d + "/two");
  {
    std::ifstream in(d + "/log.txt");
    std::stringstream s;
    s << in.rdbuf();
    INFO("mpirun log:\n" << s.str());
    REQUIRE(rc == 0);
  }
  for (const char* key : {"value", "sigma", "chi2", "error", "runs"})
    CHECK(json_string(d + "/one/calibration.json", key) == json_string(d + "/two/calibration.json", key));
  CHECK(json_string(d + "/two/calibration.json", "ranks") == "2");
  std::printf("[mpi] 2 ranks: clay.Su = %s (one process: %s), runs %s\n",
              json_string(d + "/two/calibration.json", "value").c_str(),
              json_string(d + "/one/calibration.json", "value").c_str(),
              json_string(d + "/two/calibration.json", "runs").c_str());
}
#endif

TEST_CASE("Loop: the scenario overrides of calibrate and diagnose are checked before any work", "[loop]") {
  // `tamp diagnose DATA --set KEY=VALUE` runs the data file's scenario with the override (a
  // coarser screening deck, docs/closing-the-loop.md). A bad override is bad input: exit 2,
  // one error line naming the deck and the override, and no result folder made.
  namespace fs = std::filesystem;
  const std::string d = temp_dir("overrides");
  const std::string bin = TAMP_BINARY;
  const std::string data = std::string(TAMP_SOURCE_DIR) + "/data/lab-observations.toml";
  struct Case {
    const char* command;
    const char* set;
  };
  for (const Case& c : {Case{"diagnose", "sph.spacing=0.015"},  // zone edges not at whole spacings
                        Case{"diagnose", "sph.spacng=0.02"},    // no such key
                        Case{"calibrate", "clay.Su=abc"}}) {    // not a TOML value
    const std::string out = d + "/" + c.command;
    const std::string log = d + "/log.txt";
    const int status = std::system((bin + " " + c.command + " " + data + " --set " + c.set + " --out " + out + " > " +
                                    log + " 2>&1")
                                       .c_str());
    std::ifstream in(log);
    std::vector<std::string> errors;
    for (std::string line; std::getline(in, line);)
      if (line.rfind("[tamp] error:", 0) == 0) errors.push_back(line);
    INFO(c.command << " --set " << c.set);
    CHECK((WIFEXITED(status) ? WEXITSTATUS(status) : -1) == 2);
    REQUIRE(errors.size() == 1);
    CHECK(errors[0].find("lab-test.toml") != std::string::npos);
    CHECK(errors[0].find(c.set) != std::string::npos);
    CHECK_FALSE(fs::exists(out));
  }
}

TEST_CASE("Loop: --engine names an executable that runs the forward runs and is checked before any work", "[loop]") {
  // `--engine PATH`: the runs are child processes of that executable (a frozen copy keeps a
  // long diagnosis's run cache across rebuilds of the loop); a path that is not an executable
  // regular file, or --jobs 1, is bad input: exit 2, one error line naming --engine, no folder.
  namespace fs = std::filesystem;
  const std::string d = temp_dir("engine");
  const std::string bin = TAMP_BINARY;
  const std::string data = std::string(TAMP_SOURCE_DIR) + "/data/lab-observations.toml";
  for (const std::string args : {"--engine " + d + " --jobs 2",            // a folder
                                 "--engine " + d + "/none --jobs 2",        // nothing there
                                 "--engine " + data + " --jobs 2",          // not executable
                                 "--engine " + bin + " --jobs 1"}) {        // not child processes
    const std::string out = d + "/out";
    const std::string log = d + "/log.txt";
    const int status = std::system((bin + " diagnose " + data + " " + args + " --out " + out + " > " + log + " 2>&1").c_str());
    std::ifstream in(log);
    std::vector<std::string> errors;
    for (std::string line; std::getline(in, line);)
      if (line.rfind("[tamp] error:", 0) == 0) errors.push_back(line);
    INFO(args);
    CHECK((WIFEXITED(status) ? WEXITSTATUS(status) : -1) == 2);
    REQUIRE(errors.size() == 1);
    CHECK(errors[0].find("--engine") != std::string::npos);
    CHECK_FALSE(fs::exists(out));
  }
}

TEST_CASE("Loop: a residual the catalogue does not explain is reported with its pattern", "[loop]") {
  // The definition (docs/closing-the-loop.md): error = RMS of the normalised residuals; above
  // 2 a residual remains, and the observations beyond 2 uncertainties are listed by quantity
  // with the sign of the misfit. Residuals chosen by hand: three crater depths at -3, -2.5 and
  // +0.5 and one uplift at +4 give error sqrt((9 + 6.25 + 0.25 + 16) / 4) = 2.806; the same
  // quantities at -1.5, +1, +0.5 and +2 give 1.346 and nothing to report.
  std::vector<tamp::Observation> obs(4);
  for (int k = 0; k < 3; ++k) {
    obs[k].quantity = "crater_depth_m";
    obs[k].blow = k + 1;
    obs[k].sigma = 0.01;
  }
  obs[3].quantity = "uplift_m";
  obs[3].sigma = 0.002;
  auto make = [&](const std::vector<double>& normalised) {
    std::vector<tamp::Residual> r(obs.size());
    for (size_t k = 0; k < obs.size(); ++k) {
      r[k].obs = &obs[k];
      r[k].normalised = normalised[k];
      r[k].model = obs[k].value + normalised[k] * obs[k].sigma;
    }
    return r;
  };
  const tamp::UnexplainedResidual u = tamp::unexplained_residual(make({-3.0, -2.5, 0.5, 4.0}));
  CHECK(u.remains);
  CHECK(u.error == Approx(std::sqrt(31.5 / 4.0)).epsilon(1e-14));
  REQUIRE(u.groups.size() == 2);
  CHECK(u.groups[0].quantity == "crater_depth_m");
  CHECK(u.groups[0].blows == std::vector<int>{1, 2});  // blow 3 is within 2 uncertainties
  CHECK(u.groups[0].below == 2);
  CHECK(u.groups[0].above == 0);
  CHECK(u.groups[0].largest == -3.0);
  CHECK(u.groups[1].quantity == "uplift_m");
  CHECK(u.groups[1].above == 1);
  CHECK(u.groups[1].largest == 4.0);
  INFO(u.text());
  CHECK_THAT(u.text(), Catch::Contains("crater_depth_m (blow 1, 2), model below the measurement, largest residual -3.00"));
  CHECK_THAT(u.text(), Catch::Contains("uplift_m, model above the measurement, largest residual +4.00"));

  const tamp::UnexplainedResidual ok = tamp::unexplained_residual(make({-1.5, 1.0, 0.5, 2.0}));
  CHECK_FALSE(ok.remains);
  CHECK(ok.groups.empty());
  CHECK(ok.error == Approx(std::sqrt(7.5 / 4.0)).epsilon(1e-14));
  // every residual within 2 uncertainties, but together more than the noise explains: chi2
  // 14.44 on 4 degrees of freedom; for an even number d of them Q(d/2, x/2) has the closed
  // form exp(-x/2) (1 + x/2) (d = 4), p = 0.0060 < 0.01
  const tamp::UnexplainedResidual poor = tamp::unexplained_residual(make({1.9, -1.9, 1.9, 1.9}));
  CHECK(poor.remains);
  CHECK_FALSE(poor.too_large_error);
  CHECK(poor.poor_fit);
  CHECK(poor.dof == 4);
  CHECK(poor.p_value == Approx(std::exp(-7.22) * (1 + 7.22)).epsilon(1e-10));
  CHECK(poor.groups.empty());
  CHECK_THAT(poor.text(), Catch::Contains("p = 0.006 < 0.01"));
  CHECK_THAT(poor.text(), Catch::Contains("no single observation beyond 2 uncertainties"));
  // two fitted parameters leave 2 degrees of freedom: Q(1, x/2) = exp(-x/2); the residuals
  // of `ok` (chi2 7.5) then give p = 0.0235, still above 0.01: not flagged
  const tamp::UnexplainedResidual ok2 = tamp::unexplained_residual(make({-1.5, 1.0, 0.5, 2.0}), 2.0, 2);
  CHECK(ok2.p_value == Approx(std::exp(-3.75)).epsilon(1e-10));
  CHECK_FALSE(ok2.remains);
  std::printf("[loop] unexplained residual: %s\n", u.text().c_str());
  std::printf("[loop] unexplained residual: %s\n", poor.text().c_str());
}
