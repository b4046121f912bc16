// The stage sequencer of a dynamic-replacement run: a thin host loop over the stages of
// the deck's [schedule] (docs/drop-sequence.md):
//   relax            damped relaxation of the initial (geostatic) state
//   impact  (blow)   the pounder placed just above the crater floor with the speed of free
//                    fall from the drop height; undamped, through its rebounds, until it is
//                    at rest in contact (touching, |v| < rest_speed, contact force within
//                    rest_force_tolerance of its weight, for rest_hold) or max_impact_time,
//                    then rest_time of damped settling
//   extract (blow)   the pounder lifted out; extract_time of damped settling
//   backfill(blow)   aggregate particles created in the crater without overlap (up to the
//                    ground level, or a given mass), then settle_time of damped settling
// Every stage ends with a particle snapshot and a checkpoint; a run can resume from any.
#pragma once
#include <functional>
#include <utility>
#include <string>
#include <vector>
#include "core/Config.hpp"
#include "core/Output.hpp"
#include "core/RunSummary.hpp"
#include "kernels/DropMeasures.hpp"
#include "drivers/sequence/BlowAccount.hpp"
#include "drivers/sequence/RunLoop.hpp"
#include "kernels/solver/Simulation.hpp"
#include "kernels/Measurements.hpp"

namespace tamp {

// ColumnRow, ColumnSummary, measure_column and the other measurements: kernels/DropMeasures.hpp.

enum class StageKind { Relax, Impact, Extract, Backfill };
// Where the steps and the wall time of a drop sequence go (timing.csv): the impact stages
// split by what the pounder does in the step.
enum class Phase { Relax, Contact, Flight, Rest, Extract, Settle, Count };
struct PhaseTime {
  long steps = 0;
  double simulated_s = 0, wall_s = 0;
};

struct Stage {
  StageKind kind;
  int blow;  // 1-based; 0 for relax
};

class DropSequence : public Run {
 public:
  // `out` is the result folder (exists); outputs and checkpoints go there.
  DropSequence(Simulation& sim, const Config& cfg, std::string out);

  const std::vector<Stage>& stages() const { return stages_; }
  std::string stage_name(int k) const;
  int next_stage() const { return next_stage_; }
  const std::vector<BlowRecord>& blows() const { return blows_; }

  // Resume from a checkpoint written by this class (stage end or interruption).
  void restore(const Checkpoint& c);

  // Runs the remaining stages (through run_steps, drivers/sequence/RunLoop.hpp). Stops after stage
  // `stop_after` (0-based) if >= 0, or when `keep_going` returns false (checked every step;
  // the state is then checkpointed to checkpoints/interrupted.h5). Returns true when every
  // stage is done. Throws RunFailure (NaN, collapsing step) after writing what is known so far.
  bool run(int stop_after = -1, const std::function<bool()>& keep_going = {});
  // Stop after stage k (0-based; -1: run every stage).
  void set_stop_after(int k) { stop_after_ = k; }

  // Run (drivers/sequence/RunLoop.hpp): one step of the current stage, starting and ending stages.
  bool step() override;
  void interrupt() override;      // checkpoints/interrupted.h5 and the tables so far
  void write_partial() override;  // the tables so far
  std::string where() const override;
  std::string finished_line(double wall_s) const override;

  // Writes blows.csv, tracers.csv, pounder.csv, energy.csv and, when every stage is done,
  // column.csv and summary.json.
  void write_tables(double wall_s) const;
  ColumnSummary column() const;
  // The keys of summary.json (numbers), e.g. for the closed loop (drivers/loop/Calibration.hpp).
  RunSummary summary(double wall_s) const;
  // Volume balance (the trace of compaction): heave volume of the soil surface above the
  // ground level, and the volume of the aggregate below it, m3.
  double heave_volume() const;
  double aggregate_volume_below_ground() const;
  double uplift() const;
  std::string last_checkpoint() const override { return last_checkpoint_; }
  // false: no per-stage snapshots and checkpoints (forward runs of a calibration)
  void set_stage_files(bool on) { stage_files_ = on; }

 private:
  void begin_stage(int k);
  bool stage_step(int k);  // one step of stage k; false when the stage is done
  void begin_impact(const Stage& s);
  bool impact_step();       // false when the stage is done
  void end_impact(BlowRecord& rec);
  double crater_floor() const;
  // Mean top of the soil (any material; particles with at least `neighbours` within 1.5 dp)
  // over the radial columns of width dp whose centres lie in [r_in, r_out), m; NaN where no
  // column there has soil.
  double mean_soil_top(double r_in, double r_out, int neighbours) const;
  BlowEnergies energy_state() const;  // what the blow's energy account differences
  void backfill(const Stage& s);
  void end_stage(int k);
  void record(bool force);  // tracer, pounder and energy rows
  void progress(int k, bool force);
  Checkpoint checkpoint();
  double surface_under_pounder() const;
  DropGeometry geometry() const;  // what the measurements need of the deck
  // The measurements from one binning of the particles (kernels/Measurements.hpp).
  ParticleSurvey survey() const;
  ColumnSummary column(const ParticleSurvey& s) const;
  double uplift(const ParticleSurvey& s) const;
  double heave_volume(const ParticleSurvey& s) const;
  BlowRecord& blow_record(int blow);

  Simulation& sim_;
  Config cfg_;
  std::string out_;
  std::vector<Stage> stages_;
  int next_stage_ = 0;
  double ground_ = 0;        // m, original ground level
  int backfill_material_ = -1;
  // stage-internal state (saved with an interrupted stage)
  bool in_stage_ = false;
  int stop_after_ = -1;
  bool started_ = false;  // the first step() of this object has run
  double stage_t0_ = 0, rest_since_ = -1, z_start_ = 0, peak_dec_ = 0;
  int phase_ = 0;            // impact: 0 moving, 1 damped rest
  // impact: contact tracking (see impact_step)
  double v_in_ = 0, up_max_ = 0, out_since_ = -1, pending_return_ = 0, deepest_z_ = 1e300;
  double contacts_ = 0, first_rebound_open_ = 1, returned_ = 0, in_contact_ = 0;
  double contact_time_ = 0, flight_time_ = 0;
  // impact, schedule.flight = "ballistic": the damped relaxation of the soil in a flight
  // (start time, -1 none; out_since_ of the flight it was for) and the time jumped
  double relax_since_ = -1, relaxed_flight_ = -1, ballistic_time_ = 0;
  void ballistic_flight(double min_flight, bool touching);
  BlowEnergies energy0_;  // energy_state() at the placement of the pounder
  double stage_wall_ = 0;    // wall seconds of the current blow so far
  std::vector<BlowRecord> blows_;
  std::vector<int> tracer_index_;
  std::vector<double> tracer_r0_, tracer_z0_;
  std::vector<std::vector<double>> tracer_rows_, pounder_rows_, energy_rows_;
  double next_record_ = 0;
  double wall_done_ = 0;     // wall seconds of finished stages (this and earlier runs)
  std::string last_checkpoint_;
  XdmfSeries series_;
  double last_progress_wall_ = 0;
  bool stage_files_ = true;
  PhaseTime phase_time_[static_cast<int>(Phase::Count)];
  Phase step_phase(const Stage& s) const;  // what the last step of stage s was
};

// Reads the restart file of `tamp run --restart` for a drop sequence.
bool is_drop_sequence_checkpoint(const Checkpoint& c);

}  // namespace tamp
