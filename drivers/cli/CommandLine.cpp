// The command line of `tamp`, declared once (drivers/cli/CommandLine.hpp).
#include "drivers/cli/CommandLine.hpp"

#include <stdexcept>

#include "core/Format.hpp"
#include "drivers/cli/Validators.hpp"

namespace tamp::cli {

const std::vector<NumericOption>& numeric_options() {
  static const std::vector<NumericOption> o{
      {"run", "--stop-after-stage", true, 0, 1e6},
      {"calibrate", "--iterations", true, 1, 1e4},
      {"calibrate", "--jobs", true, 1, 4096},
      {"diagnose", "--iterations", true, 1, 1e4},
      {"diagnose", "--bic-margin", false, 0, 1e6},
      {"diagnose", "--batch", true, 1, 1024},
      {"diagnose", "--points-per-parameter", true, 2, 1000},
      {"diagnose", "--jobs", true, 1, 4096},
      {"diagnose", "--max-steps", true, 1, 100},
      {"synth", "--noise", false, 0, 1},
      {"synth", "--seed", true, 0, 4294967295.0},
  };
  return o;
}

namespace {
// A numeric option, its validator and the range in its help made from numeric_options().
template <class T>
void number(CLI::App* sub, const std::string& name, T& field, const std::string& help) {
  for (const auto& n : numeric_options()) {
    if (n.command != sub->get_name() || n.name != name) continue;
    const CLI::Validator v = n.whole ? whole(static_cast<long long>(n.lo), static_cast<long long>(n.hi)) : finite(n.lo, n.hi);
    sub->add_option(name, field, help + "; allowed: " + (n.whole ? "a whole number" : "a finite number") + " from " +
                                     fmt_num(n.lo) + " to " + fmt_num(n.hi))
        ->check(v);
    return;
  }
  throw std::logic_error("numeric option " + sub->get_name() + " " + name + " is not declared in numeric_options()");
}
}  // namespace

std::unique_ptr<CommandLine> make_command_line() {
  auto cl = std::make_unique<CommandLine>();
  CommandLine& c = *cl;
  c.app.set_version_flag("--version", std::string("tamp ") + TAMP_VERSION);
  c.app.require_subcommand(1);
  c.run = c.app.add_subcommand("run", "Run an input deck and write the results to a folder");
  c.run->add_option("deck", c.deck, "Input deck (TOML), e.g. examples/geostatic-clay.toml")->required();
  c.run->add_option("--out", c.out, "Result folder (must not exist unless --force)")->required();
  c.run->add_flag("--force", c.force, "Overwrite an existing result folder");
  c.run->add_option("--restart", c.restart,
                  "Resume from a checkpoint of an earlier run of the same deck: DIR/checkpoint.h5, or for a "
                  "drop sequence DIR/checkpoints/<stage>.h5 (any stage) or DIR/checkpoints/interrupted.h5");
  c.run->add_option("--set", c.sets,
                  "Override a deck value: KEY=VALUE, e.g. sph.spacing=0.005, fem.enabled=true, clay.Su=12000 "
                  "(a dotted path of tables, or <material>.<key>; the value in TOML; KEY= removes the key)");
  number(c.run, "--stop-after-stage", c.stop_after, "Drop sequence: stop after this stage (0-based, as numbered in checkpoints/)");
  c.run->add_flag("--forward", c.forward, "A forward run of calibrate/diagnose: quiet, no per-stage snapshots or checkpoints")
      ->group("");  // internal
  c.run->add_flag("--profile", c.profile, "Time each part of the step (fences between parts) and write profile.csv");
  c.keys = c.app.add_subcommand("keys", "Print the material keys of every model (unit, default, range, meaning) as Markdown");
  c.check = c.app.add_subcommand("check", "Validate a deck and print what it would run");
  c.check->add_option("deck", c.deck, "Input deck (TOML)")->required();
  c.check->add_option("--set", c.sets, "Override a deck value, as for run: KEY=VALUE, e.g. sph.spacing=0.005 (KEY= removes the key)");
  c.compare = c.app.add_subcommand("compare", "Residuals of a finished run against measured data");
  c.compare->add_option("data", c.data_path, "Data file (TOML), e.g. data/lab-observations.toml")->required();
  c.compare->add_option("--run", c.run_dir, "Result folder of a finished tamp run")->required();
  c.calibrate = c.app.add_subcommand("calibrate", "Fit parameters of the data file's scenario (Levenberg-Marquardt)");
  c.calibrate->add_option("data", c.data_path, "Data file (TOML)")->required();
  c.calibrate->add_option("--params", c.params, "Comma-separated parameters, e.g. clay.Su,clay.G (default <target>.Su)");
  c.calibrate->add_option("--out", c.out, "Result folder")->required();
  number(c.calibrate, "--iterations", c.iterations, "Most Levenberg-Marquardt iterations (default 8)");
  c.calibrate->add_option("--method", c.method,
                        "nelder-mead (default), lm, NLopt's sbplx / bobyqa (bounded, derivative-free), or emulator "
                        "(Gaussian-process emulators over each parameter's range, confirmed by runs)")
      ->check(CLI::IsMember({"nelder-mead", "lm", "sbplx", "bobyqa", "emulator"}));
  c.calibrate->add_flag("--force", c.force, "Overwrite an existing result folder");
  number(c.calibrate, "--jobs", c.jobs, "Forward runs side by side (child processes, OMP_NUM_THREADS = cores / N)");
  c.calibrate->add_flag("--resume", c.resume, "Continue in an existing result folder, reusing its finished forward runs");
  const char* scenario_set_help =
      "Override a value of the data file's scenario deck, as for run: KEY=VALUE, e.g. sph.spacing=0.02 "
      "(a coarser screening deck)";
  c.calibrate->add_option("--set", c.sets, scenario_set_help);
  c.diagnose = c.app.add_subcommand("diagnose", "Calibrate the baseline, refit with each catalogued effect, rank by BIC");
  c.diagnose->add_option("data", c.data_path, "Data file (TOML)")->required();
  c.diagnose->add_option("--params", c.params, "Baseline parameters (default <target>.Su)");
  c.diagnose->add_option("--out", c.out, "Result folder (diagnosis.json, report.md)")->required();
  number(c.diagnose, "--iterations", c.iterations, "Most Levenberg-Marquardt iterations per fit (default 8)");
  number(c.diagnose, "--bic-margin", c.bic_margin, "How much an effect must lower BIC to be selected (default 6, 'strong' evidence)");
  c.diagnose->add_flag("--force", c.force, "Overwrite an existing result folder");
  c.diagnose->add_option("--method", c.diagnose_method,
                       "profile (default: a profile grid and a Nelder-Mead polish by runs alone), the profile with "
                       "another polish (lm, sbplx, bobyqa), or emulator (every fit on Gaussian-process emulators "
                       "from a space-filling design, confirmed by runs; far fewer runs)")
      ->check(CLI::IsMember({"emulator", "profile", "nelder-mead", "lm", "sbplx", "bobyqa"}));
  number(c.diagnose, "--batch", c.batch, "Emulator: points run per sequential round (default 4; the answer does not depend on --jobs)");
  const char* cheap_help =
      "Emulator: a deck override (KEY=VALUE, as --set) that makes the cheap deck of the design, e.g. "
      "sph.spacing=0.02 (repeat for several); each round's optimum runs on the full deck too, and the fit "
      "is the full deck's, the cheap deck's bias learnt from the pairs";
  c.diagnose->add_option("--cheap", c.cheap, cheap_help);
  c.calibrate->add_option("--cheap", c.cheap, cheap_help);
  number(c.diagnose, "--points-per-parameter", c.points_per_parameter, "Emulator: initial design runs per fitted parameter (default 10)");
  number(c.diagnose, "--jobs", c.jobs, "Forward runs side by side (child processes, OMP_NUM_THREADS = cores / N)");
  number(c.diagnose, "--max-steps", c.max_steps, "Most effects composed, one per step (default 3)");
  c.diagnose->add_flag("--resume", c.resume, "Continue in an existing result folder, reusing its finished forward runs");
  c.diagnose->add_option("--set", c.sets, scenario_set_help);
  const char* engine_help =
      "The tamp executable that runs the forward runs (default: this one; needs --jobs 2 or more). The run "
      "cache keys on its bytes: a long diagnosis resumed after a rebuild keeps its runs with a frozen copy";
  c.diagnose->add_option("--engine", c.engine, engine_help);
  c.calibrate->add_option("--engine", c.engine, engine_help);
  c.synth = c.app.add_subcommand("synth", "Make synthetic data with a chosen effect and seeded noise");
  c.synth->add_option("deck", c.deck, "Scenario deck with a [schedule]")->required();
  c.synth->add_option("--effect", c.effect, "none, compaction, rate or remoulding (default none)");
  c.synth->add_option("--set", c.sets, "KEY=VALUE parameter overrides, e.g. clay.Su=12000 or crush_pressure=20000");
  c.synth->add_option("--material", c.material, "Material the effect applies to (default clay)");
  number(c.synth, "--noise", c.noise, "Relative noise: sigma = noise x |value| (default 0.02)");
  number(c.synth, "--seed", c.seed, "Random seed (default 1)");
  c.synth->add_option("--out", c.out, "Data file to write")->required();
  c.synth->add_flag("--force", c.force, "Overwrite an existing data file");
  return cl;
}

}  // namespace tamp::cli
