// The `tamp` command line.
//   tamp run DECK --out DIR [--force]   run a deck, results in DIR
//   tamp check DECK                     validate a deck and print what it would run
//   tamp --version
//   tamp run DECK --out DIR --restart OLD/checkpoint.h5   resume an interrupted run
//   (a deck with [schedule] runs the drop sequence: drivers/sequence/DropSequence.hpp)
// Exit codes: 0 ok, 2 bad input, 1 run failure (or interrupted). Every snapshot also
// writes DIR/checkpoint.h5, the last good restartable state.
#include <CLI/CLI.hpp>
#include <Kokkos_Core.hpp>
#include <nlohmann/json.hpp>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <thread>
#include <unistd.h>

#include "core/Deck.hpp"
#include "core/Format.hpp"
#include "core/ParticleGrid.hpp"
#include "core/Log.hpp"
#include "core/Output.hpp"
#include "drivers/sequence/DropSequence.hpp"
#include "drivers/sequence/PlainRun.hpp"
#include "drivers/sequence/RunLoop.hpp"
#include "drivers/loop/ForwardRuns.hpp"
#include "drivers/loop/Calibration.hpp"
#include "drivers/loop/Ranks.hpp"
#include "kernels/solver/Simulation.hpp"
#include "drivers/cli/CommandLine.hpp"

namespace fs = std::filesystem;
// Using-declarations, not `using namespace tamp`: that would make tamp::log visible at
// global scope, where it clashes with ::log in the CUDA runtime's math headers (nvcc).
using tamp::Config;
using tamp::DeckError;
using tamp::Energies;
using tamp::ParticleSnapshot;
using tamp::RunFailure;
using tamp::Simulation;
using tamp::XdmfSeries;
using tamp::load_deck;
using tamp::ModelKey;
using tamp::omitted_at_default;
using tamp::key_value;
using tamp::keys_of;
using tamp::material_model;
using tamp::to_toml;
using tamp::write_csv;
using tamp::write_snapshot_h5;

namespace {

std::atomic<bool> g_interrupted{false};
void on_sigint(int) { g_interrupted = true; }

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

void print_plan(const Config& cfg, const Simulation& sim, std::ostream& os) {
  os << "deck:        " << (cfg.source_file.empty() ? "(in code)" : cfg.source_file) << "\n"
     << "run:         " << cfg.run.name << ", end time " << cfg.run.end_time << " s"
     << (cfg.run.max_steps > 0 ? ", at most " + std::to_string(cfg.run.max_steps) + " steps" : "") << "\n"
     << "particles:   " << sim.particle_count() << " (+" << sim.ghost_count()
     << " mirror), spacing " << cfg.sph.spacing << " m, h " << sim.smoothing_length() << " m\n"
     << (sim.fem() ? "elements:    " + std::to_string(sim.fem()->mesh().n_elements) + " quads of " +
                         fmt("%g", cfg.fem.element_size) + " m" +
                         (cfg.fem.grading > 1.0 ? " at the SPH zone, graded x" + fmt("%g", cfg.fem.grading) + " per element away from it,"
                                                : " at most,") +
                         " outside the SPH zone r < " + fmt("%g", cfg.fem.zone_r_max) +
                         " m, z in [" + fmt("%g", cfg.fem.zone_z_min) + ", " + fmt("%g", cfg.fem.zone_z_max) + "] m; " +
                         std::to_string(sim.tie_particle_count()) + " tie particles on " +
                         std::to_string(sim.tie_edge_count()) + " interface edges" +
                         (cfg.fem.subcycle ? "; substeps of their own inside the particles' step" : "") + "\n"
                   : std::string())
     << "materials:\n";
  // Each material's own stable step h / c_p (at rest) against the run's, and its particles:
  // what a material would need if it were stepped alone (issue 14: multi-rate stepping).
  const std::vector<long> count = sim.survey().count_by_material(static_cast<int>(cfg.materials.size()));
  double c_max = 0;
  for (size_t k = 0; k < cfg.materials.size(); ++k)
    if (count[k] > 0) c_max = std::max(c_max, sim.materials()[k].wave_speed());
  for (size_t k = 0; k < cfg.materials.size(); ++k) {
    const auto& m = cfg.materials[k];
    const auto& p = sim.materials()[k];
    // every key the model declares (core/MaterialModel.hpp), effects only when set
    os << "  " << m.name << ": " << m.model;
    for (const ModelKey* k : keys_of(material_model(m))) {
      const double x = key_value(m, *k);
      if (omitted_at_default(*k) && x == k->fallback.value_or(0.0)) continue;
      os << ", " << k->key << " " << x << (k->unit.empty() ? "" : " " + k->unit);
    }
    os << ", c_p " << fmt("%.1f", p.wave_speed()) << " m/s";
    if (count[k] > 0 && c_max > 0)
      os << "; " << count[k] << " particles, own stable step " << fmt("%.2f", c_max / p.wave_speed())
         << " x the run's";
    os << "\n";
  }
  const double dt = sim.stable_dt();
  os << "time step:   " << fmt("%.3g", dt) << " s (CFL " << cfg.run.cfl << "), about "
     << static_cast<long>(cfg.run.end_time / dt) << " steps\n"
     << "gravity:     " << cfg.gravity << " m/s2, damping " << cfg.damping << " 1/s\n"
     << "stages:      ";
  if (!cfg.schedule.enabled) {
    os << "one (" << cfg.run.end_time << " s of dynamics)\n";
    return;
  }
  const auto& s = cfg.schedule;
  os << "relax " << s.relax_time << " s, then " << s.drop_heights.size() << " blows (impact, extract) and "
     << s.backfill_after.size() << " backfills of \"" << cfg.backfill.material << "\" (" << cfg.backfill.mode << ")\n"
     << "pounder:     " << cfg.pounder.mass << " kg, base " << cfg.pounder.base_diameter << " m, max "
     << cfg.pounder.max_diameter << " m, height " << cfg.pounder.height << " m; friction FS "
     << cfg.contact.static_friction << " FD " << cfg.contact.dynamic_friction << "\n";
}

// A model must fit in this machine's memory: the particle count of the deck (counted before
// anything is allocated, core/ParticleGrid.hpp) against MemAvailable of /proc/meminfo
// (host memory; a GPU build would need the device's). Throws DeckError (exit 2).
void check_memory(const Config& cfg, const std::string& deck) {
  double particles = 0;
  for (const auto& b : tamp::particle_grid(cfg)) particles += b.count();
  const double need = particles * tamp::kBytesPerParticle;
  std::ifstream info("/proc/meminfo");
  std::string key;
  double kb = 0;
  while (info >> key >> kb) {
    if (key == "MemAvailable:") break;
    info.ignore(256, '\n');
    kb = 0;
  }
  const double have = kb * 1024.0;
  if (have > 0 && need > have)
    throw DeckError(deck + ": sph.spacing = " + tamp::fmt_num(cfg.sph.spacing) + " asks for " + fmt("%.3g", particles) +
                    " particles, about " + fmt("%.3g", need / 1e9) + " GB of memory; this machine has " +
                    fmt("%.3g", have / 1e9) + " GB available (allowed: a larger spacing or smaller blocks)");
}

int cmd_check(const std::string& deck, const std::vector<std::string>& sets) {
  Config cfg = load_deck(deck, sets);
  check_memory(cfg, deck);
  Simulation sim(cfg);
  print_plan(cfg, sim, std::cout);
  std::cout << "deck is valid\n";
  return 0;
}

// One --set KEY=VALUE: the value must be a finite number written in full ("12abc", "abc"
// and "1e999" are refused, naming the option).
std::pair<std::string, double> parse_set(const std::string& s) {
  const auto eq = s.find('=');
  if (eq == std::string::npos || eq == 0)
    throw std::invalid_argument("--set '" + s + "': expected KEY=VALUE, e.g. clay.Su=12000");
  const std::string text = s.substr(eq + 1);
  std::size_t used = 0;
  double value = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (text.empty() || used != text.size() || !std::isfinite(value))
    throw std::invalid_argument("--set '" + s + "': the value '" + text + "' is not a finite number");
  return {s.substr(0, eq), value};
}

// The result folder: one that cannot be created (a path under a file, no permission, a
// read-only file system) is bad input (exit 2) naming the folder and the reason.
void create_result_folder(const std::string& out) {
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec) throw std::invalid_argument("result folder '" + tamp::printable(out) + "' cannot be created: " + ec.message());
}

// profile.csv of `tamp run --profile`: the wall time of each part of the step.
void write_profile(const std::string& out, const Simulation& sim) {
  const tamp::StepProfile& p = sim.profile();
  std::ofstream f(out + "/profile.csv");
  f << "part,wall_s,share,us_per_step\n";
  const double total = p.total();
  for (const auto& [name, member] : tamp::StepProfile::parts())
    f << name << "," << fmt("%.6g", p.*member) << "," << fmt("%.4f", total > 0 ? p.*member / total : 0.0) << ","
      << fmt("%.4g", p.steps > 0 ? 1e6 * p.*member / p.steps : 0.0) << "\n";
  f << "all," << fmt("%.6g", total) << ",1," << fmt("%.4g", p.steps > 0 ? 1e6 * total / p.steps : 0.0) << "\n";
  tamp::log::info("profile of " + std::to_string(p.steps) + " steps written to " + out + "/profile.csv");
}

int cmd_run(const std::string& deck, const std::string& out, bool force, const std::string& restart,
            int stop_after, const std::vector<std::string>& sets, bool profile, bool forward) {
  Config cfg = load_deck(deck, sets);  // --set applied to the deck, all validated before any work
  check_memory(cfg, deck);
  tamp::Checkpoint resume;
  if (!restart.empty()) {
    if (!fs::exists(restart)) {
      tamp::log::error("restart checkpoint '" + restart + "' does not exist");
      return 2;
    }
    try {
      resume = tamp::read_checkpoint_h5(restart);  // read before the result folder may be replaced
    } catch (const std::runtime_error& e) {
      throw std::invalid_argument(std::string(e.what()) + " (is it a checkpoint.h5 written by tamp run?)");
    }
  }
  if (fs::exists(out)) {
    if (!force) {
      tamp::log::error("result folder '" + out + "' exists; pass --force to overwrite it");
      return 2;
    }
    fs::remove_all(out);
  }
  create_result_folder(out);
  { std::ofstream(out + "/deck.toml") << to_toml(cfg); }

  Simulation sim(cfg);
  sim.set_profiling(profile);
  // One run loop for both kinds of run (drivers/sequence/RunLoop.hpp): the stage sequence of the
  // deck's [schedule], or one stage of dynamics.
  std::unique_ptr<tamp::Run> run;
  if (cfg.schedule.enabled) {
    if (forward) {
      tamp::log::set_level(tamp::log::Level::Quiet);  // errors still reach stderr
    } else {
      print_plan(cfg, sim, std::cerr);
    }
    auto seq = std::make_unique<tamp::DropSequence>(sim, cfg, out);
    seq->set_stage_files(!forward);
    seq->set_stop_after(stop_after);
    if (!restart.empty()) {
      seq->restore(resume);
      tamp::log::info("restarted at stage " + std::to_string(seq->next_stage()) + " of " +
                      std::to_string(seq->stages().size()) + ", t = " + std::to_string(sim.time()) + " s");
    }
    run = std::move(seq);
  } else {
    if (stop_after >= 0) throw std::invalid_argument("--stop-after-stage needs a deck with a [schedule]");
    if (!restart.empty()) {
      sim.load_state(resume);
      tamp::log::info("restarted from " + restart + " at t = " + std::to_string(sim.time()) + " s, step " +
                      std::to_string(sim.steps()));
    }
    print_plan(cfg, sim, std::cerr);
    run = std::make_unique<tamp::PlainRun>(sim, cfg, out);
  }
  std::signal(SIGINT, on_sigint);
  const int rc = tamp::run_to_end(*run, [] { return !g_interrupted.load(); });
  if (profile) write_profile(out, sim);
  return rc;
}

std::vector<std::string> split_list(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

int cmd_compare(const std::string& data_path, const std::string& run_dir) {
  const tamp::ObservationSet data = tamp::load_observations(data_path);
  const tamp::RunOutputs run = tamp::read_run_dir(run_dir);
  const auto res = tamp::residuals(data, run);
  // A quantity the data has and the run folder lacks is a damaged or unfinished run, not a
  // 100-sigma misfit (that penalty is for forward runs inside a fit).
  std::string missing;
  for (const auto& r : res)
    if (!std::isfinite(r.model))
      missing += (missing.empty() ? "" : ", ") + r.obs->quantity + (r.obs->blow > 0 ? " (blow " + std::to_string(r.obs->blow) + ")" : "");
  if (!missing.empty())
    throw std::invalid_argument(run_dir + " has no value for " + missing +
                                " (summary.json / blows.csv); is it a finished run of " + data_path + "'s scenario?");
  std::cout << "data: " << data_path << "\nrun:  " << run_dir << "\n\n" << tamp::residual_table(res);
  std::ofstream(run_dir + "/residuals.json") << tamp::residuals_json(res);
  std::cout << "written: " << run_dir << "/residuals.json\n";
  return 0;
}

// The executable of this process, for the forward runs' child processes.
std::string this_executable() {
  std::error_code ec;
  const fs::path p = fs::read_symlink("/proc/self/exe", ec);
  return ec ? std::string() : p.string();
}

int prepare_loop_folder_here(const std::string& out, bool force, bool resume);

// A result folder of calibrate / diagnose: refused if it exists, unless --force (replaced)
// or --resume (kept: its run cache saves the forward runs already done). Returns 0 or 2.
int prepare_loop_folder(const std::string& out, bool force, bool resume) {
  // under MPI rank 0 prepares the folder and tells the others what it found
  if (tamp::ranks().size > 1) {
    std::string verdict;
    if (tamp::ranks().rank == 0) verdict = std::to_string(prepare_loop_folder_here(out, force, resume));
    return std::stoi(tamp::allgather(verdict)[0]);
  }
  return prepare_loop_folder_here(out, force, resume);
}

int prepare_loop_folder_here(const std::string& out, bool force, bool resume) {
  if (force && resume) {
    tamp::log::error("--force and --resume: give one (--force replaces '" + out + "', --resume continues it)");
    return 2;
  }
  if (fs::exists(out) && !force && !resume) {
    tamp::log::error("result folder '" + out + "' exists; pass --force to overwrite it or --resume to continue it");
    return 2;
  }
  if (fs::exists(out) && force) fs::remove_all(out);
  create_result_folder(out);
  return 0;
}

// --engine: the tamp executable the forward runs are run with (children, so --jobs 2 or more),
// checked before the result folder.
void check_engine(const std::string& engine, int jobs) {
  if (engine.empty()) return;
  std::error_code ec;
  if (!fs::is_regular_file(engine, ec) || ::access(engine.c_str(), X_OK) != 0)
    throw std::invalid_argument("--engine '" + engine + "': not an executable regular file; allowed: a tamp executable");
  if (jobs < 2)
    throw std::invalid_argument("--engine '" + engine + "' with --jobs " + std::to_string(jobs) +
                                ": allowed only with --jobs 2 or more (the runs are its child processes)");
}

tamp::ForwardRunOptions forward_options(const std::string& out, int jobs, const std::string& engine = "") {
  if (jobs < 1) throw std::invalid_argument("--jobs " + std::to_string(jobs) + ": allowed: 1 or more");
  tamp::ForwardRunOptions fo;
  fo.jobs = jobs;
  const int cores = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  fo.threads_per_job = std::max(1, cores / jobs);
  fo.scratch = out + "/scratch";
  fo.cache = out + "/cache";
  fo.tamp_binary = engine.empty() ? this_executable() : fs::absolute(engine).string();
  return fo;
}

// The data file with the command line's overrides of its scenario deck (`--set`); the
// callers check them by loading the deck with them before any work.
tamp::ObservationSet load_data_with_overrides(const std::string& data_path, const std::vector<std::string>& sets) {
  tamp::ObservationSet data = tamp::load_observations(data_path);
  data.scenario_overrides = sets;
  return data;
}

// The cheap deck of --cheap: only with the emulator, and a valid deck (checked before any work).
void check_cheap_deck(const Config& base, const std::vector<std::string>& cheap, const std::string& method) {
  if (cheap.empty()) return;
  if (method != "emulator")
    throw std::invalid_argument("--cheap " + cheap.front() + ": a cheap deck needs --method emulator (given: " + method + ")");
  (void)tamp::parse_deck(tamp::to_toml(base), "the cheap deck (--cheap)", cheap);
}

int cmd_calibrate(const std::string& data_path, const std::vector<std::string>& sets, const std::string& params,
                  const std::string& out, bool force, int iterations, const std::string& method, int jobs, bool resume,
                  const std::vector<std::string>& cheap, const std::string& engine) {
  check_engine(engine, jobs);
  const tamp::ObservationSet data = load_data_with_overrides(data_path, sets);
  const Config cfg = load_deck(data.scenario, data.scenario_overrides);
  const auto names = split_list(params.empty() ? data.target_material + ".Su" : params);
  // the parameters and their ranges checked before the result folder
  const auto ranges = method == "emulator" ? tamp::default_ranges(cfg, names) : std::vector<tamp::ParameterRange>{};
  for (const auto& p : names) (void)tamp::get_param(cfg, p);
  check_cheap_deck(cfg, cheap, method);
  if (const int rc = prepare_loop_folder(out, force, resume)) return rc;
  tamp::ForwardRuns runner(forward_options(out, jobs, engine));
  tamp::CalibrateOptions opt;
  opt.scratch = out + "/scratch";
  opt.max_iterations = iterations;
  opt.method = method;
  opt.runner = &runner;
  tamp::EmulatorSettings settings;
  settings.cheap_overrides = cheap;
  const tamp::FitResult f = method == "emulator"
                                ? tamp::calibrate_emulated(cfg, data, ranges, settings, runner, "calibrate")
                                : tamp::calibrate(cfg, data, names, opt);
  nlohmann::ordered_json js;
  js["parameters"] = nlohmann::ordered_json::object();
  for (size_t j = 0; j < f.names.size(); ++j) {
    js["parameters"][f.names[j]] = {{"value", f.values[j]}, {"sigma", f.sigmas[j]}};
    if (tamp::ranks().rank == 0) std::cout << f.names[j] << " = " << f.values[j] << " +- " << f.sigmas[j] << "\n";
  }
  js["chi2"] = f.chi2;
  js["error"] = f.error;
  js["runs"] = f.runs;
  if (!f.emulator_json.empty()) js["emulator"] = nlohmann::ordered_json::parse(f.emulator_json);
  js["scenario_overrides"] = data.scenario_overrides;
  js["forward_runs"] = {{"run", runner.runs()}, {"from_cache", runner.cache_hits()}, {"failed", runner.failures()},
                        {"jobs", jobs}, {"ranks", tamp::ranks().size}};
  if (tamp::ranks().rank > 0) return 0;  // rank 0 writes
  std::ofstream(out + "/calibration.json") << js.dump(2) << "\n";
  std::ofstream(out + "/residuals.json") << tamp::residuals_json(f.residuals);
  std::cout << tamp::residual_table(f.residuals) << "forward runs: " << f.runs << "; written: " << out << "/calibration.json\n";
  return 0;
}

int cmd_diagnose(const std::string& data_path, const std::vector<std::string>& sets, const std::string& params,
                 const std::string& out, bool force, int iterations, double bic_margin, int jobs, bool resume,
                 const std::string& method, int max_steps, int batch, int points_per_parameter,
                 const std::vector<std::string>& cheap, const std::string& engine) {
  check_engine(engine, jobs);
  const tamp::ObservationSet data = load_data_with_overrides(data_path, sets);
  // the deck with its overrides and the targets checked before the result folder
  const Config base = load_deck(data.scenario, data.scenario_overrides);
  tamp::check_target_materials(data, base);
  for (const auto& p : split_list(params)) (void)tamp::get_param(base, p);  // a baseline parameter the deck has
  check_cheap_deck(base, cheap, method);
  if (const int rc = prepare_loop_folder(out, force, resume)) return rc;
  tamp::ForwardRuns runner(forward_options(out, jobs, engine));
  tamp::DiagnoseOptions opt;
  opt.fit.runner = &runner;
  opt.method = method == "emulator" ? "emulator" : "profile";
  opt.fit.method = method == "emulator" || method == "profile" ? "nelder-mead" : method;
  opt.emulator.batch = batch;
  opt.emulator.points_per_parameter = points_per_parameter;
  opt.emulator.cheap_overrides = cheap;
  opt.baseline_params = split_list(params);
  opt.fit.max_iterations = iterations;
  opt.bic_margin = bic_margin;
  opt.max_steps = max_steps;
  const std::string selected = tamp::diagnose(data, out, opt);
  if (tamp::ranks().rank == 0) std::cout << "selected_effect: " << selected << "\n";
  return 0;
}

int cmd_synth(const std::string& deck, const std::string& effect, const std::vector<std::string>& sets,
              const std::string& material, double noise, unsigned seed, const std::string& out, bool force) {
  Config cfg = load_deck(deck);
  if (!cfg.schedule.enabled) throw std::invalid_argument(deck + " has no [schedule]: synthetic data need a drop sequence");
  if (fs::exists(out) && !force) {
    tamp::log::error("data file '" + out + "' exists; pass --force to overwrite it");
    return 2;
  }
  std::map<std::string, double> overrides;
  for (const auto& s : sets) {
    const auto [key, value] = parse_set(s);
    overrides[key] = value;
  }
  tamp::apply_effect(cfg, material, effect, overrides);
  std::string description = "effect " + effect;
  for (const auto& [k, v] : overrides) description += ", " + k + " = " + std::to_string(v);
  // the deck with the effect and the overrides is checked as `tamp check` checks a deck,
  // before any run (a strength below 0, a Poisson ratio of 0.7)
  try {
    (void)tamp::parse_deck(tamp::to_toml(cfg), deck);
  } catch (const DeckError& e) {
    std::string with;
    for (const auto& s : sets) with += (with.empty() ? "" : " ") + ("--set " + s);
    throw DeckError(std::string(e.what()) + " (with " + (with.empty() ? "--effect " + effect : with) + ")");
  }
  // the data file refers to the deck relative to its own folder
  const fs::path out_dir = fs::absolute(out).parent_path();
  const std::string rel = fs::relative(fs::absolute(deck), out_dir).string();
  tamp::synthesise(cfg, rel, material, noise, seed, out, out + ".scratch", description);
  fs::remove_all(out + ".scratch");
  std::cout << "written: " << out << " (" << description << ")\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const auto cl = tamp::cli::make_command_line();
  tamp::cli::CommandLine& c = *cl;
  CLI::App& app = c.app;
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    // one line, as every other refusal: the option, the value (quoted, escaped, cut), what is allowed
    std::string what = e.what();
    for (char& ch : what)
      if (ch == '\n') ch = ' ';
    tamp::log::error("bad command line: " + tamp::printable(what));
    return 2;
  }

  // calibrate / diagnose under mpirun: the ranks share the forward runs (drivers/loop/Ranks.hpp);
  // each rank takes its share of the node's cores, rank 0 reports and writes.
  if (*c.calibrate || *c.diagnose) {
    const tamp::Ranks& rk = tamp::ranks_init(&argc, &argv);
    if (rk.size > 1 && !std::getenv("OMP_NUM_THREADS")) {  // a set OMP_NUM_THREADS is kept
      const char* local = std::getenv("OMPI_COMM_WORLD_LOCAL_SIZE");
      const int per_node = local ? std::max(1, std::atoi(local)) : rk.size;
      const int cores = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
      setenv("OMP_NUM_THREADS", std::to_string(std::max(1, cores / per_node)).c_str(), 1);
    }
    if (rk.rank > 0) tamp::log::set_level(tamp::log::Level::Quiet);
  }
  Kokkos::initialize(argc, argv);
  int rc = 0;
  try {
    if (*c.run) rc = cmd_run(c.deck, c.out, c.force, c.restart, c.stop_after, c.sets, c.profile, c.forward);
    if (*c.check) rc = cmd_check(c.deck, c.sets);
    if (*c.keys) std::fputs(tamp::material_keys_markdown().c_str(), stdout);
    if (*c.compare) rc = cmd_compare(c.data_path, c.run_dir);
    if (*c.calibrate) rc = cmd_calibrate(c.data_path, c.sets, c.params, c.out, c.force, c.iterations, c.method, c.jobs, c.resume, c.cheap, c.engine);
    if (*c.diagnose)
      rc = cmd_diagnose(c.data_path, c.sets, c.params, c.out, c.force, c.iterations, c.bic_margin, c.jobs, c.resume, c.diagnose_method,
                        c.max_steps, c.batch, c.points_per_parameter, c.cheap, c.engine);
    if (*c.synth) rc = cmd_synth(c.deck, c.effect, c.sets, c.material, c.noise, c.seed, c.out, c.force);
  } catch (const DeckError& e) {
    tamp::log::error(e.what());
    rc = 2;
  } catch (const std::invalid_argument& e) {
    tamp::log::error(std::string("bad input: ") + e.what());
    rc = 2;
  } catch (const std::exception& e) {
    tamp::log::error(e.what());
    rc = 1;
  }
  if (tamp::hdf5_write_failed()) {
    // A file HDF5 could not close stays open inside the library, whose clean-up at exit
    // would retry the write (an endless loop or a crash on a full disk): end here. Every
    // earlier result file is complete (each is written via a temporary and a rename).
    std::cout.flush();
    std::cerr.flush();
    std::_Exit(rc != 0 ? rc : 1);
  }
  Kokkos::finalize();
  tamp::ranks_finalize();
  return rc;
}
