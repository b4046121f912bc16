// A plain run: a deck without [schedule], one stage of dynamics to run.end_time (or
// run.max_steps), with a snapshot, the energy table and a checkpoint every output_interval
// of simulated time (docs/output.md). Stepped by the one run loop (drivers/sequence/RunLoop.hpp).
#pragma once
#include <chrono>
#include <string>
#include <vector>

#include "core/Config.hpp"
#include "core/Output.hpp"
#include "drivers/sequence/RunLoop.hpp"
#include "kernels/solver/Simulation.hpp"

namespace tamp {

class PlainRun : public Run {
 public:
  // `out` is the result folder (exists). Writes the first snapshot (the state now, also after
  // a restart) at once.
  PlainRun(Simulation& sim, const Config& cfg, std::string out);

  bool step() override;
  void interrupt() override;      // a snapshot with its checkpoint
  void write_partial() override;  // the energy table
  std::string last_checkpoint() const override { return checkpoint_time_ >= 0 ? checkpoint_path_ : std::string(); }
  std::string where() const override;
  std::string finished_line(double wall_s) const override;

 private:
  void write_snapshot();  // with the energy table and the checkpoint, unless this step has one
  void record_energy();
  void write_energy() const;
  void progress();

  Simulation& sim_;
  Config cfg_;
  std::string out_, checkpoint_path_;
  XdmfSeries series_;
  double checkpoint_time_ = -1;  // simulated time of the last checkpoint, s
  int n_snap_ = 0;
  long last_snapshot_step_ = -1;
  double next_output_ = 0;
  std::vector<std::vector<double>> energy_rows_;
  bool done_ = false;
  std::chrono::steady_clock::time_point t0_, last_progress_;
};

}  // namespace tamp
