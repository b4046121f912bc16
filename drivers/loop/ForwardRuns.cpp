#include "drivers/loop/ForwardRuns.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "core/Deck.hpp"
#include "core/Log.hpp"
#include "drivers/loop/Ranks.hpp"

#include <nlohmann/json.hpp>

extern char** environ;

namespace tamp {
namespace fs = std::filesystem;

namespace {
// FNV-1a 64-bit: h from the offset basis 1469598103934665603, bytes added in turn.
struct Fnv1a {
  unsigned long long h = 1469598103934665603ull;
  void add(const char* p, size_t n) {
    for (size_t i = 0; i < n; ++i) {
      h ^= static_cast<unsigned char>(p[i]);
      h *= 1099511628211ull;
    }
  }
  std::string hex() const {
    char out[17];
    std::snprintf(out, sizeof out, "%016llx", h);
    return out;
  }
};
}  // namespace

std::string deck_key(const std::string& text) {
  Fnv1a f;
  f.add(text.data(), text.size());
  return f.hex();
}

std::string engine_fingerprint(const std::vector<std::string>& executables) {
  Fnv1a f;  // over every file in turn
  std::vector<char> buf(1 << 16);
  for (const std::string& path : executables) {
    std::ifstream in(path, std::ios::binary);
    if (!in) {
      log::warn("run cache: cannot read " + path + " to tell engine builds apart; its name stands for it");
      f.add(path.data(), path.size());
      continue;
    }
    while (in.read(buf.data(), static_cast<std::streamsize>(buf.size())) || in.gcount() > 0)
      f.add(buf.data(), static_cast<size_t>(in.gcount()));
  }
  return f.hex();
}

namespace {

// A forward result as JSON for the ranks' exchange (doubles to full precision; NaN as null).
nlohmann::json to_json(size_t index, const ForwardResult& r) {
  nlohmann::json j;
  j["index"] = index;
  j["ok"] = r.ok;
  j["failure"] = r.failure;
  j["summary"] = r.outputs.summary;
  j["blows"] = r.outputs.blows;
  return j;
}

double number_or_nan(const nlohmann::json& v) {
  return v.is_number() ? v.get<double>() : std::numeric_limits<double>::quiet_NaN();
}

ForwardResult from_json(const nlohmann::json& j) {
  ForwardResult r;
  r.ok = j.at("ok").get<bool>();
  r.failure = j.at("failure").get<std::string>();
  for (const auto& [k, v] : j.at("summary").items()) r.outputs.summary[k] = number_or_nan(v);
  for (const auto& row : j.at("blows")) {
    std::map<std::string, double> m;
    for (const auto& [k, v] : row.items()) m[k] = number_or_nan(v);
    r.outputs.blows.push_back(m);
  }
  return r;
}

std::string read_text(const std::string& path) {
  std::ifstream f(path);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream f(path);
  f << text;
  if (!f) throw std::runtime_error("cannot write " + path);
}

// The last line of a child's log that says what went wrong (or its last line).
std::string last_error_line(const std::string& log_path) {
  std::ifstream f(log_path);
  std::string line, last, last_error;
  while (std::getline(f, line)) {
    if (line.empty()) continue;
    last = line;
    if (line.find("error") != std::string::npos || line.find("failed") != std::string::npos) last_error = line;
  }
  return !last_error.empty() ? last_error : (!last.empty() ? last : "no output");
}

// A running child: its process, its folders, when it started.
struct Child {
  pid_t pid = -1;
  size_t index = 0;
  std::string key, deck, dir, log;
  std::chrono::steady_clock::time_point start;
};

}  // namespace

ForwardRuns::ForwardRuns(ForwardRunOptions opt) : opt_(std::move(opt)) {
  if (opt_.jobs < 1) throw std::invalid_argument("--jobs " + std::to_string(opt_.jobs) + ": allowed: 1 or more");
  if (opt_.threads_per_job < 1) opt_.threads_per_job = 1;
  if (opt_.jobs > 1 && opt_.tamp_binary.empty())
    throw std::invalid_argument("forward runs: jobs > 1 needs the path of the tamp executable");
  if (!opt_.scratch.empty()) fs::create_directories(opt_.scratch);
  if (!opt_.cache.empty()) fs::create_directories(opt_.cache);
  engine_ = opt_.engine;
  if (engine_.empty() && !opt_.cache.empty()) {
    // the executable that runs the runs: with jobs > 1 the children alone (this process only
    // reads their files), so that a loop rebuilt around a frozen engine (--engine) keeps its runs
    engine_ = engine_fingerprint({opt_.jobs > 1 ? opt_.tamp_binary : std::string("/proc/self/exe")});
  }
}

bool ForwardRuns::lookup(const std::string& key, const std::string& deck, ForwardResult& r) const {
  if (opt_.cache.empty()) return false;
  const std::string d = opt_.cache + "/" + key;
  if (!fs::exists(d + "/deck.toml") || read_text(d + "/deck.toml") != deck) return false;
  if (fs::exists(d + "/failed.txt")) {
    r = ForwardResult{};
    r.ok = false;
    r.failure = read_text(d + "/failed.txt");
    r.cached = true;
    return true;
  }
  try {
    r = ForwardResult{};
    r.outputs = read_run_dir(d);
    r.cached = true;
    return true;
  } catch (const std::exception&) {
    return false;  // a damaged entry (a run killed while it was stored) is run again
  }
}

void ForwardRuns::store(const std::string& key, const std::string& deck, const std::string& run_dir,
                        const ForwardResult& r) {
  if (opt_.cache.empty()) return;
  const std::string d = opt_.cache + "/" + key, tmp = d + ".tmp";
  fs::remove_all(tmp);
  fs::create_directories(tmp);
  if (r.ok) {
    for (const char* f : {"summary.json", "blows.csv"})
      if (fs::exists(run_dir + "/" + f)) fs::copy_file(run_dir + "/" + f, tmp + "/" + f);
  } else {
    write_text(tmp + "/failed.txt", r.failure);
  }
  write_text(tmp + "/deck.toml", deck);  // last: an entry with its deck is complete
  fs::remove_all(d);
  fs::rename(tmp, d);
}

std::string ForwardRuns::run_dir_name() {
  // rank in the name: ranks on a shared file system never write the same folder
  return opt_.scratch + "/run-" + (ranks().size > 1 ? "r" + std::to_string(ranks().rank) + "-" : std::string()) +
         std::to_string(serial_++);
}

ForwardResult ForwardRuns::run_here(const Config& cfg, const std::string& dir) {
  ForwardResult r;
  try {
    (void)run_forward(cfg, dir);  // writes summary.json and blows.csv
    r.outputs = read_run_dir(dir);  // the same reading as for a child's folder
  } catch (const std::exception& e) {
    r.ok = false;
    r.failure = e.what();
  }
  return r;
}

namespace {
thread_local long t_lane = -1;  // the fit of side_by_side this thread runs (-1: none)
}  // namespace

struct ForwardRuns::Lanes {
  std::mutex m;
  std::condition_variable cv;
  size_t active = 0;                                     // fits not finished
  std::vector<const std::vector<Config>*> pending;       // a fit's batch waiting to run
  std::vector<std::vector<ForwardResult>> results;
  std::vector<bool> ready;
  size_t waiting() const {
    size_t k = 0;
    for (const auto* p : pending) k += p != nullptr;
    return k;
  }
};

ForwardRuns::~ForwardRuns() = default;

void ForwardRuns::side_by_side(size_t n, const std::function<void(size_t)>& fn) {
  if (lanes_ || t_lane >= 0) throw std::logic_error("ForwardRuns::side_by_side: not re-entrant");
  if (n == 0) return;
  Lanes lanes;
  lanes.active = n;
  lanes.pending.assign(n, nullptr);
  lanes.results.resize(n);
  lanes.ready.assign(n, false);
  std::vector<std::exception_ptr> errors(n);
  lanes_ = &lanes;
  std::vector<std::thread> threads;
  for (size_t i = 0; i < n; ++i)
    threads.emplace_back([&, i] {
      t_lane = static_cast<long>(i);
      try {
        fn(i);
      } catch (...) {
        errors[i] = std::current_exception();
      }
      std::lock_guard<std::mutex> g(lanes.m);
      --lanes.active;
      lanes.cv.notify_all();
    });
  // this thread: run the merged batches until every fit has finished
  std::exception_ptr run_error;
  for (;;) {
    std::vector<Config> merged;
    std::vector<size_t> owner, offset(n, 0);
    {
      std::unique_lock<std::mutex> lk(lanes.m);
      lanes.cv.wait(lk, [&] { return lanes.active == 0 || lanes.waiting() == lanes.active; });
      if (lanes.active == 0) break;
      for (size_t i = 0; i < n; ++i)
        if (lanes.pending[i]) {
          offset[i] = merged.size();
          owner.push_back(i);
          merged.insert(merged.end(), lanes.pending[i]->begin(), lanes.pending[i]->end());
        }
    }
    std::vector<ForwardResult> out;
    try {
      out = run(merged);  // this thread is no fit's (t_lane -1): a plain batch
    } catch (...) {
      run_error = std::current_exception();
      out.assign(merged.size(), ForwardResult{});
      for (auto& r : out) {
        r.ok = false;
        r.failure = "the forward runs of this batch failed";
      }
    }
    std::lock_guard<std::mutex> g(lanes.m);
    for (size_t i : owner) {
      const size_t k = lanes.pending[i]->size();
      lanes.results[i].assign(out.begin() + static_cast<long>(offset[i]), out.begin() + static_cast<long>(offset[i] + k));
      lanes.pending[i] = nullptr;
      lanes.ready[i] = true;
    }
    lanes.cv.notify_all();
  }
  for (auto& t : threads) t.join();
  lanes_ = nullptr;
  if (run_error) std::rethrow_exception(run_error);
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
}

std::vector<ForwardResult> ForwardRuns::run(const std::vector<Config>& batch) {
  if (lanes_ && t_lane >= 0) {  // a fit of side_by_side: wait for the merged batch
    Lanes& l = *lanes_;
    const size_t i = static_cast<size_t>(t_lane);
    std::unique_lock<std::mutex> lk(l.m);
    l.ready[i] = false;
    l.pending[i] = &batch;
    l.cv.notify_all();
    l.cv.wait(lk, [&] { return l.ready[i]; });
    l.ready[i] = false;
    return std::move(l.results[i]);
  }
  std::vector<ForwardResult> out(batch.size());
  std::vector<std::string> decks(batch.size()), keys(batch.size());
  std::vector<size_t> todo;
  std::vector<long> same_as(batch.size(), -1);  // the same deck earlier in the batch: run once
  const long hits_before = hits_;
  for (size_t i = 0; i < batch.size(); ++i) {
    // the key: the effective deck and the engine that runs it
    decks[i] = "# forward run of tamp " TAMP_VERSION ", engine " + engine_ + "\n" + to_toml(batch[i]);
    keys[i] = deck_key(decks[i]);
    for (size_t j = 0; j < i && same_as[i] < 0; ++j)
      if (decks[j] == decks[i]) same_as[i] = same_as[j] >= 0 ? same_as[j] : static_cast<long>(j);
    if (same_as[i] >= 0) continue;
    if (lookup(keys[i], decks[i], out[i])) {
      ++hits_;
      continue;
    }
    todo.push_back(i);
  }
  const Ranks& rk = ranks();
  if (rk.size > 1) {
    // Rank 0's cache decides (the ranks' caches need not be one shared folder): it sends
    // what it found cached, and every rank then runs its share of the same list.
    nlohmann::json found = nlohmann::json::array();
    if (rk.rank == 0)
      for (size_t i = 0; i < batch.size(); ++i)
        if (same_as[i] < 0 && std::find(todo.begin(), todo.end(), i) == todo.end()) found.push_back(to_json(i, out[i]));
    const nlohmann::json from0 = nlohmann::json::parse(allgather(rk.rank == 0 ? found.dump() : std::string("[]"))[0]);
    if (rk.rank > 0) {
      todo.clear();
      std::vector<bool> cached(batch.size(), false);
      for (const auto& j : from0) {
        const size_t i = j.at("index").get<size_t>();
        out[i] = from_json(j);
        out[i].cached = true;
        cached[i] = true;
      }
      for (size_t i = 0; i < batch.size(); ++i)
        if (same_as[i] < 0 && !cached[i]) todo.push_back(i);
      hits_ = hits_before + static_cast<long>(from0.size());  // counted as rank 0 counts them
    }
  }
  if (!todo.empty()) ++batch_sizes_[static_cast<long>(todo.size())];
  auto finish = [&](size_t i, const ForwardResult& r, const std::string& dir) {
    out[i] = r;
    ++runs_;
    if (!r.ok) {
      ++failures_;
      log::warn("forward run failed (recorded as a failed point): " + r.failure);
    }
    store(keys[i], decks[i], dir, r);
    if (r.ok) {  // kept in the cache; a failed run's folder, deck and log stay for a look
      std::error_code ec;
      fs::remove_all(dir, ec);
      fs::remove(dir + ".toml", ec);
      fs::remove(dir + ".log", ec);
    }
  };
  // Under MPI the ranks share the batch (item k of the runs to do goes to rank k mod size)
  // and exchange the results; each rank runs its share as below.
  std::vector<size_t> mine;
  for (size_t k = 0; k < todo.size(); ++k)
    if (static_cast<int>(k % static_cast<size_t>(rk.size)) == rk.rank) mine.push_back(todo[k]);
  if (opt_.jobs == 1) {
    for (size_t i : mine) {
      const std::string dir = run_dir_name();
      finish(i, run_here(batch[i], dir), dir);
    }
  } else {
    std::vector<Child> running;
    size_t next = 0;
    // the children's environment: ours with OMP_NUM_THREADS replaced; a batch of one run
    // (a step of a simplex) gets the threads of all the workers, since it runs alone (its
    // result does not depend on the thread count)
    std::vector<std::string> env_text;
    for (char** e = environ; *e; ++e)
      if (std::strncmp(*e, "OMP_NUM_THREADS=", 16) != 0) env_text.push_back(*e);
    const int threads = mine.size() == 1 ? opt_.threads_per_job * opt_.jobs : opt_.threads_per_job;
    env_text.push_back("OMP_NUM_THREADS=" + std::to_string(threads));
    std::vector<char*> envp;
    for (auto& s : env_text) envp.push_back(s.data());
    envp.push_back(nullptr);
    while (next < mine.size() || !running.empty()) {
      while (next < mine.size() && static_cast<int>(running.size()) < opt_.jobs) {
        Child c;
        c.index = mine[next++];
        const std::string base = run_dir_name();
        c.deck = base + ".toml";
        c.dir = base;
        c.log = base + ".log";
        write_text(c.deck, decks[c.index]);
        std::vector<std::string> args{opt_.tamp_binary, "run", c.deck, "--out", c.dir, "--force", "--forward"};
        std::vector<char*> argv;
        for (auto& a : args) argv.push_back(a.data());
        argv.push_back(nullptr);
        posix_spawn_file_actions_t fa;
        posix_spawn_file_actions_init(&fa);
        posix_spawn_file_actions_addopen(&fa, 1, c.log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        posix_spawn_file_actions_adddup2(&fa, 1, 2);
        const int rc = posix_spawn(&c.pid, opt_.tamp_binary.c_str(), &fa, nullptr, argv.data(), envp.data());
        posix_spawn_file_actions_destroy(&fa);
        if (rc != 0)
          throw std::runtime_error("cannot start " + opt_.tamp_binary + ": " + std::strerror(rc));
        c.start = std::chrono::steady_clock::now();
        running.push_back(c);
      }
      bool reaped = false;
      for (size_t k = 0; k < running.size(); ++k) {
        Child& c = running[k];
        int status = 0;
        const pid_t w = waitpid(c.pid, &status, WNOHANG);
        const double age = std::chrono::duration<double>(std::chrono::steady_clock::now() - c.start).count();
        if (w == 0 && opt_.timeout_s > 0 && age > opt_.timeout_s) {
          kill(c.pid, SIGKILL);
          waitpid(c.pid, &status, 0);
          ForwardResult r;
          r.ok = false;
          r.failure = "time-out after " + std::to_string(static_cast<long>(opt_.timeout_s)) + " s (" + c.deck + ")";
          finish(c.index, r, c.dir);
        } else if (w == c.pid) {
          ForwardResult r;
          if (WIFEXITED(status) && WEXITSTATUS(status) == 0) {
            try {
              r.outputs = read_run_dir(c.dir);
            } catch (const std::exception& e) {
              r.ok = false;
              r.failure = e.what();
            }
          } else {
            r.ok = false;
            r.failure = last_error_line(c.log) + " (" + c.log + ")";
          }
          finish(c.index, r, c.dir);
        } else {
          continue;
        }
        running.erase(running.begin() + static_cast<long>(k));
        reaped = true;
        break;
      }
      if (!reaped) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }
  if (rk.size > 1) {
    nlohmann::json part = nlohmann::json::array();
    for (size_t i : mine) part.push_back(to_json(i, out[i]));
    for (const std::string& text : allgather(part.dump())) {
      for (const auto& j : nlohmann::json::parse(text)) {
        const size_t i = j.at("index").get<size_t>();
        if (std::find(mine.begin(), mine.end(), i) != mine.end()) continue;
        out[i] = from_json(j);
        ++runs_;  // counted on every rank, so that every rank reports the same figures
        if (!out[i].ok) ++failures_;
      }
    }
  }
  for (size_t i = 0; i < batch.size(); ++i)
    if (same_as[i] >= 0) {
      out[i] = out[same_as[i]];
      out[i].cached = true;
      ++hits_;
    }
  return out;
}

}  // namespace tamp
