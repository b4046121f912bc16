// Results output: HDF5 snapshots, XDMF series, CSV.
#include <algorithm>
#include <catch2/catch.hpp>

#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "core/Output.hpp"

namespace fs = std::filesystem;
using tamp::ParticleSnapshot;

namespace {

// The lines of a run's log that report an error (or, with also, that name that word too).
std::vector<std::string> error_lines(const std::string& log, const char* also = nullptr) {
  std::ifstream in(log);
  std::vector<std::string> errors;
  for (std::string line; std::getline(in, line);)
    if (line.find("error") != std::string::npos || (also && line.find(also) != std::string::npos)) errors.push_back(line);
  return errors;
}

fs::path temp_dir(const std::string& tag) {
  std::random_device rd;
  auto dir = fs::temp_directory_path() / ("tamp_" + tag + "_" + std::to_string(rd()));
  fs::create_directories(dir);
  return dir;
}

// Removes the directory when the test ends, pass or fail.
struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& tag) : path(temp_dir(tag)) {}
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

ParticleSnapshot make_snapshot(std::size_t n, long step, double time) {
  ParticleSnapshot s;
  s.step = step;
  s.time = time;
  s.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double x = static_cast<double>(i);
    s.r[i] = 0.001 * x + 1.0 / 3.0;
    s.z[i] = -0.5 + 1e-3 * std::sin(x);
    s.v_r[i] = 1e-7 * x;
    s.v_z[i] = -std::sqrt(x + 0.1);
    s.density[i] = 1800.0 + x / 7.0;
    s.s_rr[i] = -1e5 * (1 + x);
    s.s_zz[i] = -2e5 * (1 + x);
    s.s_tt[i] = -1.5e5 + x;
    s.s_rz[i] = 3.3e3 * std::cos(x);
    s.plastic_strain[i] = x * 1e-4;
    s.internal_energy[i] = 1e-12 * x * x;
    s.mass[i] = 0.012345678901234567 * (1 + x);
    s.material[i] = static_cast<int>(i % 3);
  }
  return s;
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t k = 0;
  for (auto pos = text.find(what); pos != std::string::npos; pos = text.find(what, pos + what.size())) ++k;
  return k;
}

}  // namespace

TEST_CASE("Output: a snapshot reads back identical", "[output]") {
  const TempDir dir("output");
  const std::string path = (dir.path / "snap.h5").string();
  const ParticleSnapshot a = make_snapshot(257, 4200, 0.0123456789);
  tamp::write_snapshot_h5(path, a);
  CHECK(fs::exists(path));
  CHECK_FALSE(fs::exists(path + ".tmp"));

  const ParticleSnapshot b = tamp::read_snapshot_h5(path);
  CHECK(b.step == a.step);
  CHECK(b.time == a.time);
  CHECK(b.size() == a.size());
  CHECK(b.r == a.r);
  CHECK(b.z == a.z);
  CHECK(b.v_r == a.v_r);
  CHECK(b.v_z == a.v_z);
  CHECK(b.density == a.density);
  CHECK(b.s_rr == a.s_rr);
  CHECK(b.s_zz == a.s_zz);
  CHECK(b.s_tt == a.s_tt);
  CHECK(b.s_rz == a.s_rz);
  CHECK(b.plastic_strain == a.plastic_strain);
  CHECK(b.internal_energy == a.internal_energy);
  CHECK(b.mass == a.mass);
  CHECK(b.material == a.material);

  SECTION("an existing file is replaced") {
    const ParticleSnapshot c = make_snapshot(3, 1, 2.0);
    tamp::write_snapshot_h5(path, c);
    const ParticleSnapshot d = tamp::read_snapshot_h5(path);
    CHECK(d.size() == 3);
    CHECK(d.step == 1);
    CHECK(d.r == c.r);
  }
  SECTION("an empty snapshot") {
    const std::string empty = (dir.path / "empty.h5").string();
    tamp::write_snapshot_h5(empty, make_snapshot(0, 0, 0.0));
    CHECK(tamp::read_snapshot_h5(empty).size() == 0);
  }
}

TEST_CASE("Output: snapshot errors name the file", "[output]") {
  const TempDir dir("output");
  SECTION("missing file") {
    const std::string path = (dir.path / "nope.h5").string();
    try {
      tamp::read_snapshot_h5(path);
      FAIL("expected an exception");
    } catch (const std::runtime_error& e) {
      CHECK_THAT(e.what(), Catch::Contains(path));
    }
  }
  SECTION("not an HDF5 file") {
    const std::string path = (dir.path / "text.h5").string();
    std::ofstream(path) << "not hdf5\n";
    try {
      tamp::read_snapshot_h5(path);
      FAIL("expected an exception");
    } catch (const std::runtime_error& e) {
      CHECK_THAT(e.what(), Catch::Contains(path));
    }
  }
  SECTION("folder does not exist") {
    const std::string path = (dir.path / "no" / "such" / "dir.h5").string();
    try {
      tamp::write_snapshot_h5(path, make_snapshot(2, 0, 0.0));
      FAIL("expected an exception");
    } catch (const std::runtime_error& e) {
      CHECK_THAT(e.what(), Catch::Contains(path));
    }
  }
  SECTION("inconsistent field sizes") {
    ParticleSnapshot s = make_snapshot(5, 0, 0.0);
    s.s_tt.pop_back();
    const std::string path = (dir.path / "bad.h5").string();
    CHECK_THROWS_WITH(tamp::write_snapshot_h5(path, s), Catch::Contains("s_tt"));
    CHECK_FALSE(fs::exists(path));
  }
}

TEST_CASE("Output: the XDMF series is well formed", "[output]") {
  const TempDir dir("output");
  const fs::path xdmf = dir.path / "series.xdmf";
  tamp::XdmfSeries series(xdmf.string());
  const std::size_t n = 17;
  const double times[] = {0.0, 0.25, 0.5};
  for (int k = 0; k < 3; ++k) {
    const std::string name = "snap_" + std::to_string(k) + ".h5";
    const ParticleSnapshot s = make_snapshot(n, 10L * k, times[k]);
    tamp::write_snapshot_h5((dir.path / name).string(), s);
    if (k < 2)
      series.add(name, s);
    else
      series.add((dir.path / name).string(), s);  // absolute: stored relative to the xdmf
    series.write();
  }
  series.add("snap_1.h5", make_snapshot(n, 10, 0.25));  // same file again: replaces
  series.write();
  CHECK(series.size() == 3);

  const std::string text = read_text(xdmf);
  INFO(text);
  CHECK(text.rfind("<?xml", 0) == 0);
  CHECK(count(text, "<Xdmf") == 1);
  CHECK(count(text, "</Xdmf>") == 1);
  CHECK(count(text, "CollectionType=\"Temporal\"") == 1);
  CHECK(count(text, "<Grid ") == 4);  // the collection and 3 snapshots
  CHECK(count(text, "</Grid>") == 4);
  CHECK(count(text, "<Time ") == 3);
  CHECK(count(text, "<Time Value=\"0\"/>") == 1);
  CHECK(count(text, "<Time Value=\"0.25\"/>") == 1);
  CHECK(count(text, "<Time Value=\"0.5\"/>") == 1);
  CHECK(count(text, "TopologyType=\"Polyvertex\" NumberOfElements=\"17\"") == 3);
  CHECK(count(text, "<Attribute ") == count(text, "</Attribute>"));
  CHECK(count(text, "<DataItem ") == count(text, "</DataItem>"));
  for (int k = 0; k < 3; ++k) {
    const std::string f = "snap_" + std::to_string(k) + ".h5";
    CHECK(count(text, ">" + f + ":/particles/coordinates</DataItem>") == 1);
    CHECK(count(text, ">" + f + ":/particles/s_zz</DataItem>") == 1);
    CHECK(count(text, ">" + f + ":/particles/material</DataItem>") == 1);
  }
  CHECK(count(text, "Dimensions=\"17 3\"") == 3);
  CHECK(text.find(dir.path.string()) == std::string::npos);  // no absolute paths
  CHECK_FALSE(fs::exists(xdmf.string() + ".tmp"));

  // Every dataset named in the XDMF exists in the snapshot it points to.
  const ParticleSnapshot back = tamp::read_snapshot_h5((dir.path / "snap_2.h5").string());
  CHECK(back.size() == n);
  CHECK(back.time == 0.5);
}

TEST_CASE("Output: CSV has the header and full-precision rows", "[output]") {
  const TempDir dir("output");
  const fs::path path = dir.path / "table.csv";
  const std::vector<std::vector<double>> rows = {{0.0, 1.0 / 3.0, -2.5e-12}, {1e300, 42, 0.1}};
  tamp::write_csv(path.string(), {"time", "force, N", "u"}, rows);
  std::ifstream in(path);
  std::string line;
  REQUIRE(std::getline(in, line));
  CHECK(line == "time,\"force, N\",u");
  for (const auto& row : rows) {
    REQUIRE(std::getline(in, line));
    std::stringstream ss(line);
    std::string cell;
    std::vector<double> values;
    while (std::getline(ss, cell, ',')) values.push_back(std::stod(cell));
    CHECK(values == row);  // exact: written with round-trip precision
  }
  CHECK_FALSE(std::getline(in, line));

  CHECK_THROWS_AS(tamp::write_csv(path.string(), {"a", "b"}, {{1.0}}), std::invalid_argument);
}

TEST_CASE("Output: a result file that cannot be written ends the run with one line, the last checkpoint intact",
          "[output]") {
  // Issue 13's reproducer 2: on a full disk HDF5's error came over two lines, then the
  // library crashed (SIGSEGV) or looped while closing. Here the file-size limit (ulimit -f,
  // with SIGXFSZ ignored: writes fail with EFBIG, as on a full disk with ENOSPC) stops the
  // CI drop scenario at its first checkpoint over 280 KiB (the relaxation's is 262 kB, blow 1's
  // 307 kB since checkpoints also hold the images' force and work, 2026-12-04, next session).
  // Expected: exit code 1, exactly
  // one error line naming the file and the reason, and the checkpoint before it readable.
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "tamp-test-write-failure";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string out = (dir / "run").string(), log = (dir / "log.txt").string();
  const std::string cmd = "bash -c 'ulimit -f 280; trap \"\" XFSZ; exec " + std::string(TAMP_BINARY) + " run " +
                          std::string(TAMP_SOURCE_DIR) + "/examples/ci-drop.toml --out " + out + "' > " + log + " 2>&1";
  const int status = std::system(cmd.c_str());
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 1);
  const std::vector<std::string> errors = error_lines(log, "HDF5");
  REQUIRE(errors.size() == 1);
  INFO(errors[0]);
  CHECK_THAT(errors[0], Catch::Contains(".h5: cannot close the HDF5 file (File too large)"));
  const std::string tag = "last good checkpoint: ";
  const auto at = errors[0].find(tag);
  REQUIRE(at != std::string::npos);
  const std::string last = errors[0].substr(at + tag.size());
  CHECK_THAT(last, Catch::EndsWith("000-relax.h5"));
  const tamp::Checkpoint c = tamp::read_checkpoint_h5(last);  // complete and readable
  CHECK(c.scalars.at("particles") > 0);
  fs::remove_all(dir);
}

TEST_CASE("Output: a run killed with SIGKILL at any moment leaves every checkpoint readable and resumable",
          "[output]") {
  // Issue 13's fault test: kill -9 during the CI drop scenario at five moments (0.5-4.5 s of
  // wall time, across its stage ends, where the checkpoints are written). Checkpoints and
  // snapshots are written to "<file>.tmp" and renamed, so whatever the moment, every .h5
  // left in checkpoints/ must read back whole, and the last one must resume: one more stage
  // from it runs to the end with exit code 0.
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "tamp-test-kill";
  fs::remove_all(dir);
  fs::create_directories(dir);
  int checked = 0;
  for (int k = 0; k < 5; ++k) {
    const std::string out = (dir / ("run" + std::to_string(k))).string();
    const double after = 0.5 + k;  // s
    const std::string cmd = "bash -c '" + std::string(TAMP_BINARY) + " run " + std::string(TAMP_SOURCE_DIR) +
                            "/examples/ci-drop.toml --out " + out + " > /dev/null 2>&1 & pid=$!; sleep " +
                            std::to_string(after) + "; kill -9 $pid 2>/dev/null; wait $pid'";
    (void)std::system(cmd.c_str());
    std::vector<std::string> files;
    if (fs::exists(out + "/checkpoints"))
      for (const auto& e : fs::directory_iterator(out + "/checkpoints"))
        if (e.path().extension() == ".h5") files.push_back(e.path().string());
    std::sort(files.begin(), files.end());
    for (const auto& f : files) {
      INFO("killed after " << after << " s: " << f);
      CHECK_NOTHROW(tamp::read_checkpoint_h5(f));
      ++checked;
    }
    if (k == 2 && !files.empty()) {  // resume the last one for one stage
      const std::string stage = fs::path(files.back()).stem().string();
      const int next = std::stoi(stage.substr(0, 3)) + 1;
      const std::string resume = std::string(TAMP_BINARY) + " run " + std::string(TAMP_SOURCE_DIR) +
                                 "/examples/ci-drop.toml --out " + out + "-resumed --restart " + files.back() +
                                 " --stop-after-stage " + std::to_string(next) + " > /dev/null 2>&1";
      const int status = std::system(resume.c_str());
      CHECK(WIFEXITED(status));
      CHECK(WEXITSTATUS(status) == 0);
    }
  }
  std::printf("[kill -9] %d checkpoints left by five killed runs, every one readable\n", checked);
  CHECK(checked > 0);
  fs::remove_all(dir);
}

TEST_CASE("Output: a result folder that cannot be created is one error line and exit code 2", "[output]") {
  // A folder under a regular file (the case a read-only folder gives a non-root user; root
  // writes through permissions, so that case is not testable as root).
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "tamp-test-unwritable";
  fs::remove_all(dir);
  fs::create_directories(dir);
  { std::ofstream((dir / "file").string()) << "not a folder\n"; }
  const std::string log = (dir / "log.txt").string();
  const std::string cmd = std::string(TAMP_BINARY) + " run " + std::string(TAMP_SOURCE_DIR) +
                          "/examples/ci-drop.toml --out " + (dir / "file" / "out").string() + " > " + log + " 2>&1";
  const int status = std::system(cmd.c_str());
  REQUIRE(WIFEXITED(status));
  const std::vector<std::string> errors = error_lines(log);
  INFO("exit code " << WEXITSTATUS(status));
  REQUIRE(errors.size() == 1);
  INFO(errors[0]);
  CHECK(WEXITSTATUS(status) == 2);
  CHECK_THAT(errors[0], Catch::Contains((dir / "file" / "out").string()));
  fs::remove_all(dir);
}

namespace {

// The rows of a CSV file without the columns named in `skip` (wall-clock columns).
std::vector<std::vector<std::string>> csv_rows(const std::string& path, const std::vector<std::string>& skip) {
  std::ifstream in(path);
  std::vector<std::vector<std::string>> rows;
  std::vector<bool> keep;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    if (keep.empty())
      for (const auto& c : cells) keep.push_back(std::find(skip.begin(), skip.end(), c) == skip.end());
    std::vector<std::string> kept;
    for (size_t k = 0; k < cells.size(); ++k)
      if (k < keep.size() && keep[k]) kept.push_back(cells[k]);
    rows.push_back(kept);
  }
  return rows;
}

// Runs `tamp run deck --out out`, interrupts it with SIGINT after `after_s` seconds of wall
// time; returns the exit status and the log.
int interrupted_run(const std::string& deck, const std::string& out, const std::string& log, double after_s) {
  const std::string cmd = "bash -c '" + std::string(TAMP_BINARY) + " run " + deck + " --out " + out + " > " + log +
                          " 2>&1 & pid=$!; sleep " + std::to_string(after_s) + "; kill -INT $pid; wait $pid'";
  return std::system(cmd.c_str());
}

}  // namespace

TEST_CASE("Output: Ctrl-C ends a run with a checkpoint and one line, and the run resumes from it to the same answer",
          "[output]") {
  // Both kinds of run go through the one run loop (drivers/sequence/RunLoop.hpp): a drop sequence
  // (the CI drop scenario, about 10 s) and a plain run (the same model without pounder and
  // schedule, 0.25 s of settling). Each is interrupted with SIGINT after 2 s of wall time.
  // Expected: exit code 1, exactly one error line "interrupted (Ctrl-C) ... checkpoint PATH",
  // PATH readable, and the run resumed from it ends with exit code 0 and the uninterrupted
  // run's table (blows.csv without its wall-clock column; the plain run's last energy row)
  // bit for bit: every sum is in a fixed order and the checkpoint holds the whole state,
  // the place of the last neighbour-list build included. The sequence's forward run (the
  // loop's kind: no stage files) must give the same blows.csv too.
  const fs::path dir = fs::temp_directory_path() / "tamp-test-ctrl-c";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string sequence_deck = std::string(TAMP_SOURCE_DIR) + "/examples/ci-drop.toml";
  const std::string plain_deck = (dir / "plain.toml").string();
  {
    std::ifstream in(sequence_deck);
    std::ofstream out(plain_deck);
    for (std::string line; std::getline(in, line);) {
      if (line.rfind("[pounder]", 0) == 0) break;  // the model only: no pounder, no schedule
      if (line.rfind("materials_from", 0) == 0)     // relative to examples/, which this copy is not in
        line = "materials_from = \"" + std::string(TAMP_SOURCE_DIR) + "/examples/lab-test.toml\"";
      out << line << "\n";
      if (line == "[run]") out << "end_time = 0.25\noutput_interval = 0.05\n";
    }
  }
  struct Kind {
    std::string name, deck, table;
    bool last_row_only;
  };
  for (const Kind& kind : {Kind{"sequence", sequence_deck, "blows.csv", false}, Kind{"plain", plain_deck, "energy.csv", true}}) {
    INFO(kind.name << " run");
    const std::string ref = (dir / (kind.name + "-ref")).string(), cut = (dir / (kind.name + "-cut")).string();
    const std::string resumed = (dir / (kind.name + "-resumed")).string(), log = (dir / (kind.name + ".log")).string();
    const int ref_status = std::system((std::string(TAMP_BINARY) + " run " + kind.deck + " --out " + ref + " > /dev/null 2>&1").c_str());
    REQUIRE(WIFEXITED(ref_status));
    REQUIRE(WEXITSTATUS(ref_status) == 0);

    if (!kind.last_row_only) {
      // A forward run of the loop (no stage files, no checkpoints) gives the same table:
      // writing checkpoints does not change a run.
      const std::string fwd = (dir / (kind.name + "-forward")).string();
      const int fwd_status =
          std::system((std::string(TAMP_BINARY) + " run " + kind.deck + " --out " + fwd + " --forward > /dev/null 2>&1").c_str());
      REQUIRE(WIFEXITED(fwd_status));
      REQUIRE(WEXITSTATUS(fwd_status) == 0);
      CHECK(csv_rows(fwd + "/" + kind.table, {"wall_s"}) == csv_rows(ref + "/" + kind.table, {"wall_s"}));
    }

    const int status = interrupted_run(kind.deck, cut, log, 2.0);
    REQUIRE(WIFEXITED(status));
    CHECK(WEXITSTATUS(status) == 1);
    const std::vector<std::string> errors = error_lines(log);
    REQUIRE(errors.size() == 1);
    INFO(errors[0]);
    CHECK_THAT(errors[0], Catch::Contains("interrupted (Ctrl-C)"));
    const std::string tag = "; checkpoint ";
    const auto at = errors[0].find(tag), end = errors[0].find(" (resume with");
    REQUIRE(at != std::string::npos);
    REQUIRE(end != std::string::npos);
    const std::string checkpoint = errors[0].substr(at + tag.size(), end - at - tag.size());
    CHECK_NOTHROW(tamp::read_checkpoint_h5(checkpoint));

    const int resume_status = std::system((std::string(TAMP_BINARY) + " run " + kind.deck + " --out " + resumed +
                                           " --restart " + checkpoint + " > /dev/null 2>&1").c_str());
    REQUIRE(WIFEXITED(resume_status));
    CHECK(WEXITSTATUS(resume_status) == 0);
    auto a = csv_rows(ref + "/" + kind.table, {"wall_s"}), b = csv_rows(resumed + "/" + kind.table, {"wall_s"});
    REQUIRE(!a.empty());
    REQUIRE(!b.empty());
    if (kind.last_row_only) {
      CHECK(a.back() == b.back());
    } else {
      CHECK(a == b);
    }
    std::printf("[ctrl-c] %s run: interrupted after 2 s, resumed from %s, %s %s\n", kind.name.c_str(),
                fs::path(checkpoint).filename().string().c_str(), kind.table.c_str(),
                (kind.last_row_only ? a.back() == b.back() : a == b) ? "identical" : "DIFFERENT");
  }
  fs::remove_all(dir);
}
