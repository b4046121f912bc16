// The one run loop of `tamp run`. A plain run (drivers/sequence/PlainRun.hpp: one stage of dynamics
// with snapshots at output_interval) and a drop sequence (drivers/sequence/DropSequence.hpp: relax,
// impacts, extractions, backfills) are both a Run: each knows how to take one step, what to
// write when it is interrupted or fails, and where its last good checkpoint is. The loop, the
// Ctrl-C handling and the one-line error messages are written once, here.
#pragma once
#include <functional>
#include <string>

namespace tamp {

class Run {
 public:
  virtual ~Run() = default;
  // One step (a stage's start and end included); false when there is nothing left to run
  // (every stage done, or the stage the run was asked to stop after has ended).
  virtual bool step() = 0;
  // Interrupted between two steps (Ctrl-C): checkpoint the state now; last_checkpoint()
  // then names it.
  virtual void interrupt() = 0;
  // A step failed (NaN, a collapsing step): write the tables known so far; the state is not
  // checkpointed (it is the bad one).
  virtual void write_partial() = 0;
  // The last good checkpoint written, "" when none yet.
  virtual std::string last_checkpoint() const = 0;
  // Where the run stands, for messages: "in stage 3", "at t = 0.012 s".
  virtual std::string where() const = 0;
  // The line `tamp run` prints when the run ends without error (wall: seconds of this run).
  virtual std::string finished_line(double wall_s) const = 0;
};

enum class RunEnd { Finished, Interrupted };

// Steps `run` until step() says there is nothing left (Finished) or keep_going() returns
// false after a step (Interrupted: run.interrupt() has checkpointed the state). A RunFailure
// propagates after run.write_partial(); a result file that failed (std::runtime_error)
// propagates as it is.
RunEnd run_steps(Run& run, const std::function<bool()>& keep_going);

// `tamp run`'s use of run_steps: the finished line on stderr and exit code 0; on Ctrl-C or a
// failure one error line (what, where, the last good checkpoint and how to resume) and 1.
int run_to_end(Run& run, const std::function<bool()>& keep_going);

}  // namespace tamp
