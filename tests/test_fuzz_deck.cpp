// The deck fuzzer (issue 13): mutated copies of the example decks, each parsed (and, when
// accepted, built into a Simulation). The promise of docs/input-deck.md, checked on every
// case: a deck is either accepted or refused with one DeckError line of the documented form
// ("<file>: <key> ... ; allowed: ..." / "... is missing; required: ..." / "TOML syntax error
// ..."); building an accepted deck either works or fails with std::invalid_argument (exit 2,
// "bad input"); nothing else escapes, nothing crashes. Seeded, so a failure reproduces:
// TAMP_FUZZ_CASES and TAMP_FUZZ_SEED change the count (default 3000, about 1 s) and the seed.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdlib>
#include <sys/wait.h>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "core/Deck.hpp"
#include "core/Observations.hpp"
#include "kernels/solver/Simulation.hpp"

namespace {

std::vector<std::string> lines_of(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> out;
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

// Values that have broken validators before: zero, signs, extremes, denormals, non-numbers,
// wrong types, empty and odd arrays.
const std::vector<std::string> kNasty = {
    "0", "-1", "1", "0.5", "2", "1e308", "-1e308", "5e-324", "1e-300", "nan", "inf", "-inf",
    "9223372036854775807", "-9223372036854775808", "\"\"", "\"x\"", "\"\\n\"", "true", "[]", "[1]",
    "[0, 0]", "[1, 0]", "[0, 1e308]", "[-1, 1]", "[1, 2, 3]", "{}", "[\"a\", \"b\"]", "1e999", "0x10",
    "[[1]]"};

// A refusal of the documented form: one line, "<file>: <key> ...; allowed: ..." /
// "...; required: ..." / a TOML syntax error.
bool documented_refusal(const std::string& msg, const std::string& file) {
  const bool one_line = msg.find('\n') == std::string::npos && msg.size() < 600;
  return one_line && msg.rfind(file + ": ", 0) == 0 &&
         (msg.find("; allowed: ") != std::string::npos || msg.find("; required: ") != std::string::npos ||
          msg.find("TOML syntax error") != std::string::npos);
}

// The oracle where a mutation's verdict is known (issue 56): a deck or data file with an
// unknown key, or with a number replaced by a non-finite one, is invalid whatever else it holds.
bool is_number_text(std::string v) {
  const size_t hash = v.find('#');
  if (hash != std::string::npos) v = v.substr(0, hash);
  while (!v.empty() && (v.back() == ' ' || v.back() == '\t')) v.pop_back();
  if (v.empty()) return false;
  char* end = nullptr;
  std::strtod(v.c_str(), &end);
  return end && *end == '\0' && v.find_first_of("\"[") == std::string::npos;
}
bool non_finite_text(const std::string& v) { return v == "nan" || v == "inf" || v == "-inf" || v == "1e999"; }

}  // namespace

TEST_CASE("Fuzz: mutated decks are accepted or refused in one line, and never crash", "[deck][fuzz]") {
  const int cases = std::getenv("TAMP_FUZZ_CASES") ? std::atoi(std::getenv("TAMP_FUZZ_CASES")) : 3000;
  const unsigned seed = std::getenv("TAMP_FUZZ_SEED") ? std::atoi(std::getenv("TAMP_FUZZ_SEED")) : 20261201u;
  const std::string dir = std::string(TAMP_SOURCE_DIR) + "/examples/";
  const std::vector<std::string> decks = {"ci-drop.toml", "lab-geostatic.toml", "lab-test.toml"};
  std::vector<std::vector<std::string>> texts;
  for (const auto& d : decks) texts.push_back(lines_of(dir + d));
  std::mt19937 rng(seed);
  auto pick = [&](std::size_t n) { return std::uniform_int_distribution<std::size_t>(0, n - 1)(rng); };
  int accepted = 0, refused = 0, built = 0, build_refused = 0, wrong = 0;
  std::vector<std::string> failures;
  for (int c = 0; c < cases && failures.size() < 5; ++c) {
    const std::size_t d = pick(decks.size());
    std::vector<std::string> t = texts[d];
    const int mutations = 1 + static_cast<int>(pick(3));
    std::string what;
    std::vector<std::string> invalid_lines;  // known-invalid lines put in (a later mutation may remove them)
    for (int m = 0; m < mutations; ++m) {
      std::vector<std::size_t> keyed;  // "key = value" lines
      for (std::size_t i = 0; i < t.size(); ++i)
        if (t[i].find(" = ") != std::string::npos && t[i][0] != '#') keyed.push_back(i);
      if (keyed.empty()) break;
      const std::size_t i = keyed[pick(keyed.size())];
      const std::string key = t[i].substr(0, t[i].find(" = "));
      switch (pick(4)) {
        case 0:
        case 1: {  // a nasty value
          const std::string v = kNasty[pick(kNasty.size())];
          const std::string texts_line = t[i].substr(t[i].find(" = ") + 3);
          t[i] = key + " = " + v;
          if (is_number_text(texts_line) && non_finite_text(v)) invalid_lines.push_back(t[i]);
          break;
        }
        case 2: t.erase(t.begin() + static_cast<long>(i)); break;          // a key left out
        default:
          t.insert(t.begin() + static_cast<long>(i), "fuzz_key = 1");  // an unknown key
          invalid_lines.push_back("fuzz_key = 1");
      }
      what += " | " + (i < t.size() ? t[i] : std::string("(end)"));
    }
    bool known_invalid = false;
    for (const auto& l : t) known_invalid = known_invalid || std::find(invalid_lines.begin(), invalid_lines.end(), l) != invalid_lines.end();
    std::ostringstream text;
    for (const auto& l : t) text << l << "\n";
    // in the decks' folder: a deck's materials_from is relative to it
    const std::string label = dir + "fuzz-" + std::to_string(c) + "-" + decks[d];
    tamp::Config cfg;
    try {
      cfg = tamp::parse_deck(text.str(), label);
      ++accepted;
      if (known_invalid) {
        ++wrong;
        failures.push_back("case " + std::to_string(c) + what + "\n  accepted, but an unknown key or a non-finite number is in it");
        continue;
      }
    } catch (const tamp::DeckError& e) {
      const std::string msg = e.what();
      if (!documented_refusal(msg, label)) failures.push_back("case " + std::to_string(c) + what + "\n  message: " + msg);
      ++refused;
      continue;
    } catch (const std::exception& e) {
      failures.push_back("case " + std::to_string(c) + what + "\n  escaped: " + e.what());
      continue;
    }
    // Build the small scenario's accepted mutants (the lab decks take ~0.1-1 s each).
    if (decks[d] != "ci-drop.toml") continue;
    try {
      tamp::Simulation sim(cfg);
      ++built;
    } catch (const std::invalid_argument&) {
      ++build_refused;  // "bad input", exit 2
    } catch (const std::exception& e) {
      failures.push_back("case " + std::to_string(c) + what + "\n  building escaped: " + e.what());
    }
  }
  std::printf("[fuzz] %d cases (seed %u): %d accepted, %d refused in one line; of the accepted ci-drop mutants "
              "%d built, %d refused as bad input; %d wrong verdicts where known; %zu failures\n",
              cases, seed, accepted, refused, built, build_refused, wrong, failures.size());
  for (const auto& f : failures) std::printf("[fuzz] %s\n", f.c_str());
  CHECK(failures.empty());
  CHECK(refused > cases / 4);  // the mutations do reach the validators
}

TEST_CASE("Fuzz: mutated data files are accepted or refused in one line, and never crash", "[deck][fuzz]") {
  // The same mutations of the lab's data file (data/lab-observations.toml, with its scenario
  // made absolute so that the copies can live in a temporary folder) and of a per-blow data
  // file, each read by load_observations: accepted, or refused with one DeckError line
  // naming the file and the key ("; allowed: " / "; required: " / TOML syntax error).
  // 1000 cases (about 1 s); TAMP_FUZZ_CASES / TAMP_FUZZ_SEED as for the decks.
  const int cases = std::getenv("TAMP_FUZZ_CASES") ? std::atoi(std::getenv("TAMP_FUZZ_CASES")) / 3 : 1000;
  const unsigned seed = std::getenv("TAMP_FUZZ_SEED") ? std::atoi(std::getenv("TAMP_FUZZ_SEED")) : 20261201u;
  const std::string src = std::string(TAMP_SOURCE_DIR);
  std::vector<std::string> lab = lines_of(src + "/data/lab-observations.toml");
  for (auto& l : lab)
    if (l.rfind("scenario = ", 0) == 0) l = "scenario = \"" + src + "/examples/lab-test.toml\"";
  const std::vector<std::string> per_blow = {
      "scenario = \"" + src + "/examples/ci-drop.toml\"", "target_material = \"clay\"", "[[observations]]",
      "quantity = \"crater_depth_m\"", "blow = 2", "value = 0.12", "sigma = 0.005", "[[observations]]",
      "quantity = \"uplift_m\"", "range = [0.01, 0.02]", "source = \"synthetic\""};
  const std::vector<std::vector<std::string>> texts = {lab, per_blow};
  const std::string dir = (std::filesystem::temp_directory_path() / "tamp_fuzz_data").string();
  std::filesystem::create_directories(dir);
  std::mt19937 rng(seed);
  auto pick = [&](std::size_t n) { return std::uniform_int_distribution<std::size_t>(0, n - 1)(rng); };
  int accepted = 0, refused = 0, wrong = 0;
  std::vector<std::string> failures;
  for (int c = 0; c < cases && failures.size() < 5; ++c) {
    std::vector<std::string> t = texts[pick(texts.size())];
    std::string what;
    std::vector<std::string> invalid_lines;  // known-invalid lines put in (a later mutation may remove them)
    const int mutations = 1 + static_cast<int>(pick(3));
    for (int m = 0; m < mutations; ++m) {
      std::vector<std::size_t> keyed;
      for (std::size_t i = 0; i < t.size(); ++i)
        if (t[i].find(" = ") != std::string::npos && t[i][0] != '#') keyed.push_back(i);
      if (keyed.empty()) break;
      const std::size_t i = keyed[pick(keyed.size())];
      const std::string key = t[i].substr(0, t[i].find(" = "));
      switch (pick(5)) {
        case 0:
        case 1: {
          const std::string v = kNasty[pick(kNasty.size())];
          const std::string texts_line = t[i].substr(t[i].find(" = ") + 3);
          t[i] = key + " = " + v;
          if (is_number_text(texts_line) && non_finite_text(v)) invalid_lines.push_back(t[i]);
          break;
        }
        case 2: t.erase(t.begin() + static_cast<long>(i)); break;
        case 3:
          t.insert(t.begin() + static_cast<long>(i), "fuzz_key = 1");
          invalid_lines.push_back("fuzz_key = 1");
          break;
        default: t.resize(i); break;  // a truncated file
      }
      what += " | " + (i < t.size() ? t[i] : std::string("(end)"));
    }
    bool known_invalid = false;
    for (const auto& l : t) known_invalid = known_invalid || std::find(invalid_lines.begin(), invalid_lines.end(), l) != invalid_lines.end();
    const std::string path = dir + "/fuzz-" + std::to_string(c) + ".toml";
    {
      std::ofstream out(path);
      for (const auto& l : t) out << l << "\n";
    }
    try {
      (void)tamp::load_observations(path);
      ++accepted;
      if (known_invalid) {
        ++wrong;
        failures.push_back("case " + std::to_string(c) + what + "\n  accepted, but an unknown key or a non-finite number is in it");
      }
    } catch (const tamp::DeckError& e) {
      const std::string msg = e.what();
      if (!documented_refusal(msg, path)) failures.push_back("case " + std::to_string(c) + what + "\n  message: " + msg);
      ++refused;
    } catch (const std::exception& e) {
      failures.push_back("case " + std::to_string(c) + what + "\n  escaped: " + e.what());
    }
    std::filesystem::remove(path);
  }
  std::printf("[fuzz] %d data-file cases (seed %u): %d accepted, %d refused in one line; %d wrong verdicts where known; "
              "%zu failures\n", cases, seed, accepted, refused, wrong, failures.size());
  for (const auto& f : failures) std::printf("[fuzz] %s\n", f.c_str());
  CHECK(failures.empty());
  CHECK(refused > cases / 4);
}

TEST_CASE("Fuzz: the command line exits 0 or 2 with one error line on mutated decks and data files", "[deck][fuzz]") {
  // The promise through the program itself (issue 13): `tamp check` on mutated copies of
  // every example deck and `tamp compare` on mutated data files (against a small finished
  // run folder written here) exit with 0 or 2, never a signal or 1, and a refusal is exactly
  // one "[tamp] error:" line naming the file. 1000 cases, half of each (a process each,
  // about 20 s); TAMP_FUZZ_CLI_CASES changes the count (scripts/fuzz runs more and reports).
  namespace fs = std::filesystem;
  const std::string src = std::string(TAMP_SOURCE_DIR), bin = TAMP_BINARY;
  const fs::path dir = fs::temp_directory_path() / "tamp_fuzz_cli";
  fs::remove_all(dir);
  fs::create_directories(dir / "run");
  {  // a finished run folder: summary.json and a blows.csv of two blows
    std::ofstream(dir / "run" / "summary.json")
        << "{\"column_length_m\": 0.3, \"head_diameter_m\": 0.1, \"max_diameter_m\": 0.2, \"uplift_m\": 0.05, "
           "\"aggregate_total_kg\": 8.0}\n";
    std::ofstream(dir / "run" / "blows.csv") << "blow,crater_depth_m,uplift_m\n1,0.05,0.01\n2,0.12,0.02\n";
  }
  const int cases = std::getenv("TAMP_FUZZ_CLI_CASES") ? std::atoi(std::getenv("TAMP_FUZZ_CLI_CASES")) : 1000;
  std::vector<std::vector<std::string>> decks;
  for (const char* d : {"ci-drop.toml", "lab-geostatic.toml", "lab-test.toml", "synthetic/tiny-drop.toml"})
    decks.push_back(lines_of(src + "/examples/" + d));
  for (auto& deck : decks)  // the copies are written outside examples/: the shared materials by absolute path
    for (auto& l : deck)
      if (l.rfind("materials_from = ", 0) == 0) l = "materials_from = \"" + src + "/examples/lab-test.toml\"";
  std::vector<std::string> data = lines_of(src + "/data/lab-observations.toml");
  for (auto& l : data)
    if (l.rfind("scenario = ", 0) == 0) l = "scenario = \"" + src + "/examples/lab-test.toml\"";
  std::mt19937 rng(std::getenv("TAMP_FUZZ_SEED") ? std::atoi(std::getenv("TAMP_FUZZ_SEED")) : 20261201u);
  auto pick = [&](std::size_t n) { return std::uniform_int_distribution<std::size_t>(0, n - 1)(rng); };
  auto mutate = [&](std::vector<std::string> t) {
    std::vector<std::size_t> keyed;
    for (std::size_t i = 0; i < t.size(); ++i)
      if (t[i].find(" = ") != std::string::npos && t[i][0] != '#') keyed.push_back(i);
    const std::size_t i = keyed[pick(keyed.size())];
    const std::string key = t[i].substr(0, t[i].find(" = "));
    switch (pick(3)) {
      case 0: t[i] = key + " = " + kNasty[pick(kNasty.size())]; break;
      case 1: t.erase(t.begin() + static_cast<long>(i)); break;
      default: t.insert(t.begin() + static_cast<long>(i), "fuzz_key = 1");
    }
    return t;
  };
  int exit0 = 0, exit2 = 0;
  std::vector<std::string> failures;
  for (int c = 0; c < cases && failures.size() < 5; ++c) {
    const bool is_deck = c % 2 == 0;
    const std::vector<std::string> t = mutate(is_deck ? decks[pick(decks.size())] : data);
    const std::string file = (dir / ("case-" + std::to_string(c) + ".toml")).string();
    {
      std::ofstream out(file);
      for (const auto& l : t) out << l << "\n";
    }
    const std::string log = (dir / "log.txt").string();
    // each case under a time limit: a hang (a FIFO read, an endless loop) is exit 124, a failure
    const std::string cmd = "timeout 30 " + bin + (is_deck ? " check " + file : " compare " + file + " --run " + (dir / "run").string()) +
                            " > " + log + " 2>&1";
    const int status = std::system(cmd.c_str());
    std::ifstream in(log);
    int errors = 0;
    bool names_file = false;
    for (std::string line; std::getline(in, line);)
      if (line.rfind("[tamp] error:", 0) == 0) {
        ++errors;
        names_file = line.find(file) != std::string::npos;
      }
    const int code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    if (code == 0) ++exit0;
    if (code == 2) ++exit2;
    if (!(code == 0 || code == 2) || (code == 2 && (errors != 1 || !names_file)))
      failures.push_back("case " + std::to_string(c) + " (" + file + "): exit " + std::to_string(code) + ", " +
                         std::to_string(errors) + " error lines");
    else
      fs::remove(file);
  }
  std::printf("[fuzz] command line: %d cases, %d exit 0, %d exit 2 with one error line naming the file; %zu failures "
              "(a hang over 30 s would be exit 124)\n",
              cases, exit0, exit2, failures.size());
  for (const auto& f : failures) std::printf("[fuzz] %s\n", f.c_str());
  CHECK(failures.empty());
  CHECK(exit2 > cases / 4);
}
