#include "drivers/sequence/RunLoop.hpp"

#include <chrono>
#include <stdexcept>

#include "core/Log.hpp"
#include "kernels/solver/Simulation.hpp"

namespace tamp {

RunEnd run_steps(Run& run, const std::function<bool()>& keep_going) {
  try {
    while (run.step())
      if (keep_going && !keep_going()) {
        run.interrupt();
        return RunEnd::Interrupted;
      }
  } catch (const RunFailure&) {  // not a result file that failed: writing again would fail too
    run.write_partial();
    throw;
  }
  return RunEnd::Finished;
}

int run_to_end(Run& run, const std::function<bool()>& keep_going) {
  const auto t0 = std::chrono::steady_clock::now();
  auto last_good = [&] { return run.last_checkpoint().empty() ? std::string("none") : run.last_checkpoint(); };
  RunEnd end;
  try {
    end = run_steps(run, keep_going);
  } catch (const RunFailure& e) {
    log::error("run failed " + run.where() + ": " + e.what() + "; last good state: " + last_good() +
               " (resume with: tamp run DECK --restart CHECKPOINT --out NEWDIR)");
    return 1;
  } catch (const std::runtime_error& e) {  // a result file could not be written (a full disk)
    log::error("writing results failed " + run.where() + ": " + e.what() + "; last good checkpoint: " + last_good());
    return 1;
  }
  if (end == RunEnd::Interrupted) {
    log::error("interrupted (Ctrl-C) " + run.where() + "; checkpoint " + run.last_checkpoint() +
               " (resume with: tamp run DECK --restart " + run.last_checkpoint() + " --out NEWDIR)");
    return 1;
  }
  log::info(run.finished_line(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()));
  return 0;
}

}  // namespace tamp
