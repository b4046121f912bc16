// Bad input, second round (issue 56): the probes of a new user, each a test, and two fuzzers
// with an oracle: they generate inputs whose verdict they know (valid or not, from the declared
// kinds and ranges) and check that the program gives that verdict, not only that it does not
// crash. Data files: core/Observations.cpp's rules; options: drivers/cli/CommandLine.cpp's
// numeric_options() and the option sets.
#include <catch2/catch.hpp>

#include <sys/stat.h>
#include <sys/wait.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/Deck.hpp"
#include "core/Observations.hpp"
#include "drivers/cli/CommandLine.hpp"

namespace fs = std::filesystem;

namespace {

std::string src() { return TAMP_SOURCE_DIR; }

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("tamp_input_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

struct Outcome {
  int code;
  std::vector<std::string> errors;  // the "[tamp] error:" lines
};
Outcome run_tamp(const std::string& args, const fs::path& dir) {
  const std::string log = (dir / "log.txt").string();
  // under a time limit: a hang (a FIFO read) is exit 124, not a stuck test
  const int status = std::system(("timeout 60 " + std::string(TAMP_BINARY) + " " + args + " > " + log + " 2>&1 < /dev/null").c_str());
  Outcome o{WIFEXITED(status) ? WEXITSTATUS(status) : -1, {}};
  std::ifstream in(log);
  for (std::string line; std::getline(in, line);)
    if (line.rfind("[tamp] error:", 0) == 0) o.errors.push_back(line);
  return o;
}

// A finished run folder of the lab scenario's quantities, written here (no run needed).
void write_run_folder(const fs::path& d, const std::string& eol = "\n") {
  fs::create_directories(d);
  std::ofstream(d / "summary.json") << "{\"column_length_m\": 0.3, \"head_diameter_m\": 0.15, \"max_diameter_m\": 0.25, "
                                       "\"uplift_m\": 0.012, \"aggregate_total_kg\": 19.0}\n";
  std::ofstream(d / "blows.csv", std::ios::binary) << "blow,crater_depth_m,uplift_m" << eol << "1,0.05,0.01" << eol
                                                   << "2,0.12,0.02" << eol;
}

// The lab's data file with its first observation replaced by `first` (TOML lines).
std::string lab_data_with(const fs::path& dir, const std::string& name, const std::string& first) {
  std::ifstream in(src() + "/data/lab-observations.toml");
  std::stringstream all;
  all << in.rdbuf();
  std::string t = all.str();
  const size_t a = t.find("[[observations]]"), b = t.find("[[observations]]", a + 1);
  t = t.substr(0, a) + "[[observations]]\n" + first + "\n\n" + t.substr(b);
  const size_t s0 = t.find("\nscenario = ");
  const size_t s1 = t.find('\n', s0 + 1);
  t = t.substr(0, s0) + "\nscenario = \"" + src() + "/examples/lab-test.toml\"" + t.substr(s1);
  const std::string path = (dir / name).string();
  std::ofstream(path) << t;
  return path;
}

}  // namespace

TEST_CASE("Bad input: the probes of a new user are refused in one line before any work", "[input]") {
  // Each row of issue 56's table: exit 2, one error line naming the file or option and the key,
  // and nothing created (no data file, no result folder). Rows that are valid input (a range
  // near the largest double, a CRLF blow table) are accepted with finite, correct residuals.
  const fs::path d = fresh_dir("probes");
  write_run_folder(d / "run");
  const std::string tiny = src() + "/examples/synthetic/tiny-drop.toml";
  const std::string lab = src() + "/data/lab-observations.toml";
  const std::string out = (d / "out").string();
  struct Row {
    std::string args, must_name;
  };
  const std::string q = "quantity = \"uplift_m\"\n";
  const std::string nan_value = lab_data_with(d, "nan.toml", q + "value = nan\nsigma = 0.002");
  const std::string inf_range = lab_data_with(d, "inf.toml", q + "range = [0.010, inf]");
  const std::string source_bool = lab_data_with(d, "src.toml", q + "range = [0.010, 0.014]\nsource = true");
  const std::string value_text = lab_data_with(d, "txt.toml", q + "value = \"0.01\"\nsigma = 0.002");
  const std::string run = " --run " + (d / "run").string();
  ::mkfifo((d / "fifo.toml").c_str(), 0600);
  fs::create_directories(d / "big");
  write_run_folder(d / "big");
  std::ofstream(d / "big" / "summary.json") << "{\"column_length_m\": 1e999, \"uplift_m\": 0.012}\n";
  const std::string long_value(4000, 'x');
  const std::vector<Row> rows = {
      {"compare " + nan_value + run, "observations[0].value"},
      {"compare " + inf_range + run, "observations[0].range"},
      {"compare " + source_bool + run, "observations[0].source"},
      {"compare " + value_text + run, "observations[0].value"},
      {"compare " + lab + " --run " + (d / "big").string(), "column_length_m"},
      {"synth " + tiny + " --noise nan --out " + out, "--noise"},
      {"synth " + tiny + " --noise -1 --out " + out, "--noise"},
      {"synth " + tiny + " --noise inf --out " + out, "--noise"},
      {"synth " + tiny + " --noise -0.5 --out " + out, "--noise"},
      {"synth " + tiny + " --set clay.Su=-5 --out " + out, "Su"},
      {"synth " + tiny + " --set contact.dynamic_friction=5 --out " + out, "dynamic_friction"},
      {"synth " + tiny + " --set clay.nu=0.7 --out " + out, "nu"},
      {"synth " + tiny + " --set clay.G=0 --out " + out, "G"},
      {"calibrate " + lab + " --iterations -1 --out " + out, "--iterations"},
      {"calibrate " + lab + " --iterations 0 --out " + out, "--iterations"},
      {"diagnose " + lab + " --bic-margin nan --out " + out, "--bic-margin"},
      {"check " + (d / "fifo.toml").string(), "not a regular file"},
      {"calibrate " + lab + " --params clay.Sx --out " + out, "clay.Sx"},
      {"diagnose " + lab + " --params clay.Sx --out " + out, "clay.Sx"},
      {"calibrate " + lab + " --method newton --out " + out, "--method"},
      {"diagnose " + lab + " --method newton --out " + out, "--method"},
      {"synth " + tiny + " --noise " + long_value + " --out " + out, "--noise"},
      {"synth " + tiny + " --noise $(printf 'a\\377\\376b') --out " + out, "\\xff\\xfe"},
  };
  for (const Row& r : rows) {
    const Outcome o = run_tamp(r.args, d);
    INFO(r.args.substr(0, 300));
    CHECK(o.code == 2);
    REQUIRE(o.errors.size() == 1);
    INFO(o.errors[0]);
    CHECK(o.errors[0].find(r.must_name) != std::string::npos);
    CHECK(o.errors[0].size() < 600);  // a long value is cut, not echoed whole
    CHECK_FALSE(fs::exists(out));
  }
  // Valid, and answered: a range near the largest double (its midpoint and half-width taken
  // without overflow) and a blow table with CRLF line ends (RFC 4180).
  const std::string huge = lab_data_with(d, "huge.toml", q + "range = [1e308, 1.7e308]");
  Outcome o = run_tamp("compare " + huge + run, d);
  CHECK(o.code == 0);
  {
    const auto js = nlohmann::json::parse(std::ifstream(d / "run" / "residuals.json"));
    const double r = js["observations"][0]["normalised_residual"].get<double>();
    CHECK(r == Approx((0.012 - 1.35e308) / 0.35e308).epsilon(1e-12));  // the uplift's, finite
  }
  write_run_folder(d / "crlf", "\r\n");
  o = run_tamp("compare " + lab + " --run " + (d / "crlf").string(), d);
  CHECK(o.code == 0);
  CHECK(o.errors.empty());
}

TEST_CASE("Fuzz with an oracle: generated data files are accepted exactly when valid", "[input][fuzz]") {
  // Each file is built field by field from pools of valid and invalid values of each field's
  // kind (docs/closing-the-loop.md "Data files"); the file is valid when every field is. The
  // verdict of load_observations must be that: accepted, or refused with one line naming the
  // file (and, when one field alone is invalid, its key). TAMP_FUZZ_CASES changes the count.
  const int cases = std::getenv("TAMP_FUZZ_CASES") ? std::atoi(std::getenv("TAMP_FUZZ_CASES")) : 2000;
  const fs::path d = fresh_dir("data_oracle");
  std::mt19937 rng(20261207u);
  auto pick = [&](size_t n) { return std::uniform_int_distribution<size_t>(0, n - 1)(rng); };
  auto chance = [&](double p) { return std::uniform_real_distribution<double>(0, 1)(rng) < p; };
  auto real = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  auto num = [](double x) {
    char b[64];
    std::snprintf(b, sizeof b, "%.17g", x);
    std::string s = b;
    if (s.find_first_of(".en") == std::string::npos) s += ".0";
    return s;
  };
  const std::vector<std::string> summary_only = {"column_length_m", "head_diameter_m", "max_diameter_m",
                                                 "base_diameter_m", "aggregate_total_kg", "blows_completed"};
  const std::vector<std::string> per_blow = {"crater_depth_m", "penetration_m", "peak_deceleration_m_s2",
                                             "aggregate_added_kg"};
  const std::vector<std::string> bad_number = {"nan", "inf", "-inf", "+nan", "\"0.01\"", "true", "[1.0]", "{}"};
  int accepted = 0, refused = 0, wrong = 0;
  std::vector<std::string> failures;
  const auto t0 = std::chrono::steady_clock::now();
  for (int c = 0; c < cases; ++c) {
    std::ostringstream f;
    std::vector<std::string> invalid;  // the keys generated invalid
    f << "scenario = \"" << src() << "/examples/lab-test.toml\"\n";
    if (chance(0.95)) {
      f << "target_material = \"clay\"\n";
    } else {
      f << "target_material = []\n";
      invalid.push_back("target_material");
    }
    if (chance(0.03)) {
      f << "fuzz_key = 1\n";
      invalid.push_back("fuzz_key");
    }
    const int n = 1 + static_cast<int>(pick(3));
    for (int i = 0; i < n; ++i) {
      const std::string p = "observations[" + std::to_string(i) + "]";
      f << "\n[[observations]]\n";
      // quantity and blow
      switch (pick(8)) {
        case 0: f << "quantity = \"" << per_blow[pick(per_blow.size())] << "\"\nblow = " << 1 + pick(36) << "\n"; break;
        case 1: f << "quantity = \"uplift_m\"\nblow = " << 1 + pick(1000000) << "\n"; break;
        case 2:
          f << "quantity = \"" << per_blow[pick(per_blow.size())] << "\"\nblow = "
            << std::vector<std::string>{"0", "-1", "1.5", "\"2\"", "1000001", "9223372036854775807"}[pick(6)] << "\n";
          invalid.push_back(p + ".blow");
          break;
        case 3:
          f << "quantity = \"" << summary_only[pick(summary_only.size())] << "\"\nblow = 3\n";
          invalid.push_back(p + ".quantity");
          break;
        case 4:
          f << "quantity = \"" << std::vector<std::string>{"crater", "", "Uplift_m"}[pick(3)] << "\"\n";
          invalid.push_back(p + ".quantity");
          break;
        default: f << "quantity = \"" << summary_only[pick(summary_only.size())] << "\"\n";
      }
      // the measurement: value and sigma, or a range
      if (chance(0.5)) {
        const double v = real(-1e3, 1e3);
        if (chance(0.9)) {
          f << "value = " << num(v) << "\n";
        } else {
          f << "value = " << bad_number[pick(bad_number.size())] << "\n";
          invalid.push_back(p + ".value");
        }
        if (chance(0.9)) {
          f << "sigma = " << num(real(1e-6, 1e3)) << "\n";
        } else {
          f << "sigma = " << std::vector<std::string>{"0.0", "-1.0", "nan", "inf", "\"x\"", "-0.0"}[pick(6)] << "\n";
          invalid.push_back(p + ".sigma");
        }
        if (chance(0.03)) {
          f << "range = [0.0, 1.0]\n";
          invalid.push_back(p + ".value");  // value and range together
        }
      } else {
        const double lo = real(-1e3, 1e3), w = real(1e-3, 1e3);
        if (chance(0.9)) {
          f << "range = [" << num(lo) << ", " << num(lo + w) << "]\n";
        } else {
          f << "range = "
            << std::vector<std::string>{"[" + num(lo + w) + ", " + num(lo) + "]", "[" + num(lo) + ", " + num(lo) + "]",
                                        "[" + num(lo) + ", inf]", "[nan, 1.0]", "[1.0]", "[1.0, 2.0, 3.0]", "\"x\"",
                                        "[-inf, 0.0]", "[\"a\", 1.0]"}[pick(9)]
            << "\n";
          invalid.push_back(p + ".range");
        }
      }
      if (chance(0.5)) {
        if (chance(0.9)) {
          f << "source = \"fuzz " << c << "\"\n";
        } else {
          f << "source = " << std::vector<std::string>{"true", "1", "[]"}[pick(3)] << "\n";
          invalid.push_back(p + ".source");
        }
      }
    }
    const std::string path = (d / ("case-" + std::to_string(c) + ".toml")).string();
    std::ofstream(path) << f.str();
    bool ok = true;
    std::string msg;
    try {
      (void)tamp::load_observations(path);
    } catch (const tamp::DeckError& e) {
      ok = false;
      msg = e.what();
    } catch (const std::exception& e) {
      failures.push_back("case " + std::to_string(c) + ": escaped: " + e.what());
      continue;
    }
    const bool valid = invalid.empty();
    ok ? ++accepted : ++refused;
    bool right = ok == valid;
    if (!ok) {
      right = right && msg.rfind(path + ": ", 0) == 0 && msg.find('\n') == std::string::npos &&
              (msg.find("; allowed: ") != std::string::npos || msg.find("; required: ") != std::string::npos);
      // one field alone invalid: the message names it (a missing partner names itself)
      if (invalid.size() == 1 && invalid[0] != "fuzz_key" && msg.find(invalid[0]) == std::string::npos &&
          msg.find(invalid[0].substr(0, invalid[0].find('.'))) == std::string::npos)
        right = false;
    }
    if (!right) {
      ++wrong;
      if (failures.size() < 5)
        failures.push_back("case " + std::to_string(c) + ": oracle " + (valid ? "valid" : "invalid (" + invalid[0] + ")") +
                           ", verdict " + (ok ? "accepted" : "refused: " + msg) + "\n" + f.str());
    } else {
      fs::remove(path);
    }
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("[fuzz] data files with an oracle: %d cases, %d accepted, %d refused, %d wrong verdicts, %.2f s\n", cases,
              accepted, refused, wrong, s);
  for (const auto& m : failures) std::printf("[fuzz] %s\n", m.c_str());
  CHECK(wrong == 0);
  CHECK(failures.empty());
  CHECK(accepted > cases / 5);  // both verdicts are exercised
  CHECK(refused > cases / 5);
}

TEST_CASE("Fuzz with an oracle: command-line options are accepted exactly when inside their declared range",
          "[input][fuzz]") {
  // Every numeric option of every subcommand (numeric_options(): kind and range, declared once
  // with the option) and the --method sets, given values generated valid or invalid by
  // construction; the command line is parsed (no command runs) and must accept exactly the
  // valid ones. Every option of the program that takes a number is declared there.
  const int cases = std::getenv("TAMP_FUZZ_CASES") ? std::atoi(std::getenv("TAMP_FUZZ_CASES")) : 3000;
  const auto& opts = tamp::cli::numeric_options();
  {
    const auto cl = tamp::cli::make_command_line();
    for (const CLI::App* sub : cl->app.get_subcommands({}))
      for (const CLI::Option* o : sub->get_options()) {
        const std::string type = o->get_type_name();
        const bool numeric = type.find("INT") != std::string::npos || type.find("FLOAT") != std::string::npos ||
                             type.find("UINT") != std::string::npos || type.find("NUMBER") != std::string::npos;
        if (!numeric) continue;
        bool declared = false;
        for (const auto& n : opts) declared = declared || (n.command == sub->get_name() && n.name == o->get_name());
        INFO(sub->get_name() << " " << o->get_name() << " (" << type << ")");
        CHECK(declared);
      }
  }
  std::mt19937 rng(20261207u);
  auto pick = [&](size_t n) { return std::uniform_int_distribution<size_t>(0, n - 1)(rng); };
  auto required = [](const std::string& cmd) -> std::vector<std::string> {
    if (cmd == "run" || cmd == "synth") return {"deck.toml", "--out", "x"};
    if (cmd == "calibrate" || cmd == "diagnose") return {"data.toml", "--out", "x"};
    return {"deck.toml"};
  };
  int accepted = 0, refused = 0, wrong = 0;
  std::vector<std::string> failures;
  const auto t0 = std::chrono::steady_clock::now();
  for (int c = 0; c < cases; ++c) {
    std::string cmd, name, value;
    bool valid = false;
    if (c % 10 == 9) {  // the method sets
      const bool diag = pick(2) == 1;
      cmd = diag ? "diagnose" : "calibrate";
      name = "--method";
      const std::vector<std::string> ok = diag ? std::vector<std::string>{"emulator", "profile", "nelder-mead", "lm", "sbplx", "bobyqa"}
                                               : std::vector<std::string>{"nelder-mead", "lm", "sbplx", "bobyqa", "emulator"};
      valid = pick(2) == 0;
      value = valid ? ok[pick(ok.size())] : std::vector<std::string>{"newton", "Emulator", "profile2", "", "lm "}[pick(5)];
      if (!diag && value == "profile") valid = false;
    } else {
      const auto& n = opts[pick(opts.size())];
      cmd = n.command;
      name = n.name;
      valid = pick(2) == 0;
      if (valid) {
        if (n.whole) {
          value = std::to_string(std::uniform_int_distribution<long long>(static_cast<long long>(n.lo), static_cast<long long>(n.hi))(rng));
        } else {
          char b[64];
          std::snprintf(b, sizeof b, "%.9g", std::uniform_real_distribution<double>(n.lo, n.hi)(rng));
          value = b;
          if (std::stod(value) > n.hi) value = std::to_string(n.hi);  // (rounding at the top end)
        }
      } else {
        std::vector<std::string> bad = {"nan", "inf", "-inf", "abc", "1e999", "0x10", "1,5", "",
                                        "99999999999999999999999"};
        if (n.whole) {
          bad.push_back(std::to_string(static_cast<long long>(n.lo) - 1));
          bad.push_back(std::to_string(static_cast<long long>(n.hi) + 1));
          bad.push_back("1.5");
          bad.push_back("2e3");
        } else {
          char b[64];
          std::snprintf(b, sizeof b, "%.9g", n.lo - 1 - (n.hi - n.lo) * std::uniform_real_distribution<double>(0, 1)(rng));
          bad.push_back(b);
          std::snprintf(b, sizeof b, "%.9g", n.hi + 1 + (n.hi - n.lo) * std::uniform_real_distribution<double>(0, 1)(rng));
          bad.push_back(b);
        }
        value = bad[pick(bad.size())];
      }
    }
    std::vector<std::string> args{"tamp", cmd};
    for (const auto& a : required(cmd)) args.push_back(a);
    args.push_back(name);
    args.push_back(value);
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    const auto cl = tamp::cli::make_command_line();
    bool ok = true;
    std::string msg;
    try {
      cl->app.parse(static_cast<int>(argv.size()), argv.data());
    } catch (const CLI::ParseError& e) {
      ok = false;
      msg = e.what();
    }
    ok ? ++accepted : ++refused;
    const bool right = ok == valid && (ok || msg.find(name) != std::string::npos);
    if (!right) {
      ++wrong;
      if (failures.size() < 5)
        failures.push_back(cmd + " " + name + " '" + value + "': oracle " + (valid ? "valid" : "invalid") + ", verdict " +
                           (ok ? "accepted" : "refused: " + msg));
    }
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("[fuzz] options with an oracle: %d cases over %zu numeric options and 2 method sets, %d accepted, %d "
              "refused, %d wrong verdicts, %.2f s\n",
              cases, opts.size(), accepted, refused, wrong, s);
  for (const auto& m : failures) std::printf("[fuzz] %s\n", m.c_str());
  CHECK(wrong == 0);
  CHECK(accepted > cases / 4);
  CHECK(refused > cases / 4);
}
