// The command line of `tamp`: its subcommands and options, declared once. main.cpp parses it
// and runs the chosen command; tests parse it too (the option fuzzer, tests/test_fuzz_input.cpp).
// Every numeric option's kind and range is declared in numeric_options(), from which its
// validator (drivers/cli/Validators.hpp) and its help text are made: a bad value is refused
// while parsing, before any work, in one line naming the option, the value and what is allowed.
#pragma once
#include <CLI/CLI.hpp>

#include <memory>
#include <string>
#include <vector>

namespace tamp::cli {

struct NumericOption {
  std::string command;  // the subcommand
  std::string name;     // "--noise"
  bool whole;           // a whole number (else a finite real)
  double lo, hi;        // allowed: lo <= value <= hi
};
// Every numeric option of every subcommand.
const std::vector<NumericOption>& numeric_options();

struct CommandLine {
  CLI::App app{"Tamp: particle simulation of dynamic replacement (axisymmetric SPH for soils)"};
  CLI::App *run = nullptr, *check = nullptr, *compare = nullptr, *calibrate = nullptr, *diagnose = nullptr,
           *synth = nullptr, *keys = nullptr;
  std::string deck, out, restart;
  int stop_after = -1;
  std::vector<std::string> sets;
  bool force = false, profile = false, forward = false;
  std::string data_path, run_dir, params, effect = "none", material = "clay";
  double noise = 0.02;
  unsigned seed = 1;
  int iterations = 8;
  double bic_margin = 6.0;
  std::string method = "nelder-mead";
  int jobs = 1, max_steps = 3;
  bool resume = false;
  std::string diagnose_method = "profile";
  int batch = 4, points_per_parameter = 10;
  std::vector<std::string> cheap;
  std::string engine;
};

// The command line with every subcommand and option declared (not parsed).
std::unique_ptr<CommandLine> make_command_line();

}  // namespace tamp::cli
