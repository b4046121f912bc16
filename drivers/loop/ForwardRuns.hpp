// Independent forward runs of a calibration or diagnosis (drivers/loop/Calibration.hpp), run side by
// side and remembered (docs/closing-the-loop.md "Forward runs side by side, remembered").
//
// A batch of decks is run in order of submission. With jobs = 1 each run is done in this
// process; with jobs = N > 1, N at a time, each a `tamp run DECK --forward` child process
// (posix_spawn, OMP_NUM_THREADS = threads_per_job): the operating system is the scheduler,
// no sockets or threads of our own. The outputs come back through the child's result
// folder, read with read_run_dir. Results are the same whatever N: every forward run is
// deterministic for any thread count (the reductions that feed the dynamics are summed in a
// fixed order, kernels/DeterministicSum.hpp), the batch's results are returned in the order
// of submission, and the deck a child reads (to_toml) round-trips the configuration exactly.
//
// Under MPI (`mpirun -n K tamp diagnose ...`, drivers/loop/Ranks.hpp) the K ranks share each
// batch: the k-th run to do goes to rank k mod K, which runs it as above, and the results
// are exchanged (MPI_Allgatherv of their JSON) so that every rank continues the same fit
// with the same numbers; rank 0 writes the result files.
//
// The run cache: every finished run (or failure) is kept under `cache/<key>/` with the
// deck it ran, the key a hash of that deck's text (the effective deck, after every --set
// and effect) and of the engine build (engine_fingerprint). A run whose deck is there is
// not redone: a diagnosis interrupted with Ctrl-C and started again with --resume skips
// what it had finished.
#pragma once
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "core/Config.hpp"
#include "drivers/loop/Calibration.hpp"

namespace tamp {

struct ForwardResult {
  RunOutputs outputs;
  bool ok = true;
  std::string failure;  // why not ok: the run's last error line (NaN, time-out, ...)
  bool cached = false;  // taken from the run cache
};

struct ForwardRunOptions {
  int jobs = 1;               // runs side by side
  int threads_per_job = 1;    // OMP_NUM_THREADS of a child (jobs > 1; a batch of one run: jobs x this)
  std::string scratch;        // folder for the runs' result folders
  std::string cache;          // run cache folder ("" = none)
  std::string tamp_binary;    // the `tamp` executable for the children (jobs > 1)
  double timeout_s = 0;       // a child running longer is stopped and recorded as failed (0 = none)
  std::string engine;         // the engine in the cache key ("" = engine_fingerprint of the executables
                              // that run the runs: this process's, and tamp_binary's when jobs > 1)
};

class ForwardRuns {
 public:
  explicit ForwardRuns(ForwardRunOptions opt);
  ~ForwardRuns();
  // The results of `batch`, in its order.
  std::vector<ForwardResult> run(const std::vector<Config>& batch);
  // Independent fits side by side: fn(0), ..., fn(n-1) each in a host thread of its own,
  // which prepares decks and reads results; the runs are done by the calling thread.
  // Whenever every unfinished fn waits in run(), their batches are run as one (in the order
  // of i), so that the sequential steps of n fits (a simplex's moves) share the workers. Each
  // fn sees the results of its own batches only: the answers are those of fn(0), ..., fn(n-1)
  // one after the other, in fewer rounds of runs. The first exception of an fn is rethrown.
  void side_by_side(size_t n, const std::function<void(size_t)>& fn);
  ForwardResult run(const Config& cfg) { return run(std::vector<Config>{cfg})[0]; }
  long runs() const { return runs_; }          // forward runs done (not from the cache)
  long cache_hits() const { return hits_; }
  long failures() const { return failures_; }
  // How many batches had how many runs to do (after the cache): the shape of a fit's work,
  // from which its wall time on W workers is sum over batches of ceil(size / W) run times.
  const std::map<long, long>& batch_sizes() const { return batch_sizes_; }
  const ForwardRunOptions& options() const { return opt_; }

 private:
  ForwardResult run_here(const Config& cfg, const std::string& dir);
  std::string run_dir_name();
  void store(const std::string& key, const std::string& deck, const std::string& run_dir, const ForwardResult& r);
  bool lookup(const std::string& key, const std::string& deck, ForwardResult& r) const;
  ForwardRunOptions opt_;
  std::string engine_;              // the engine in the cache key
  long runs_ = 0, hits_ = 0, failures_ = 0, serial_ = 0;
  std::map<long, long> batch_sizes_;
  struct Lanes;                     // the fits of side_by_side (ForwardRuns.cpp)
  Lanes* lanes_ = nullptr;
};

// The cache key of a deck's text: FNV-1a 64-bit, as 16 hex digits (the stored deck is
// compared in full, so a collision is never taken for a hit).
std::string deck_key(const std::string& deck_text);

// The engine build as 16 hex digits: FNV-1a 64-bit of the bytes of the executables (in
// order; "/proc/self/exe" for this process). Part of the cache key, so that a --resume after
// a rebuild never takes the old engine's runs for the new one's (the project version,
// TAMP_VERSION, does not change when the engine does). An unreadable file enters by its
// name, with a warning.
std::string engine_fingerprint(const std::vector<std::string>& executables);

}  // namespace tamp
