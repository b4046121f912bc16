#include "drivers/sequence/PlainRun.hpp"

#include <algorithm>
#include <cstdio>

namespace tamp {

namespace {
constexpr long kEnergyEvery = 50;  // steps between rows of energy.csv
}

PlainRun::PlainRun(Simulation& sim, const Config& cfg, std::string out)
    : sim_(sim), cfg_(cfg), out_(std::move(out)), checkpoint_path_(out_ + "/checkpoint.h5"),
      series_(out_ + "/particles.xdmf") {
  next_output_ = cfg_.run.output_interval > 0 ? cfg_.run.output_interval : 1e300;
  while (next_output_ <= sim_.time()) next_output_ += cfg_.run.output_interval;  // after a restart
  record_energy();
  write_snapshot();
  t0_ = last_progress_ = std::chrono::steady_clock::now();
}

void PlainRun::record_energy() {
  const Energies e = sim_.energies();
  energy_rows_.push_back({sim_.time(), e.kinetic, e.internal, e.potential, e.total()});
}

void PlainRun::write_energy() const {
  write_csv(out_ + "/energy.csv", {"time_s", "kinetic_J", "internal_J", "potential_J", "total_J"}, energy_rows_);
}

void PlainRun::write_snapshot() {
  if (sim_.steps() == last_snapshot_step_) return;
  last_snapshot_step_ = sim_.steps();
  char name[64];
  std::snprintf(name, sizeof name, "snapshot_%05d.h5", n_snap_++);
  const ParticleSnapshot s = sim_.snapshot();
  write_snapshot_h5(out_ + "/" + name, s);
  series_.add(name, s);
  series_.write();
  write_energy();
  write_checkpoint_h5(checkpoint_path_, sim_.save_state());  // the last good state on failure
  checkpoint_time_ = sim_.time();
}

bool PlainRun::step() {
  if (done_) return false;
  const double end = cfg_.run.end_time;
  const long max_steps = cfg_.run.max_steps;
  if (!(sim_.time() < end * (1.0 - 1e-12)) || (max_steps > 0 && sim_.steps() >= max_steps)) {
    record_energy();
    write_energy();
    write_snapshot();
    done_ = true;
    return false;
  }
  const double dt = std::min(sim_.stable_dt(), end - sim_.time());
  sim_.step(dt > 0 ? dt : 0.0);
  if (sim_.steps() % kEnergyEvery == 0) record_energy();
  if (sim_.time() >= next_output_) {
    write_snapshot();
    next_output_ += cfg_.run.output_interval;
  }
  progress();
  return true;
}

void PlainRun::progress() {
  const auto now = std::chrono::steady_clock::now();
  if (std::chrono::duration<double>(now - last_progress_).count() < cfg_.run.progress_interval) return;
  const double wall = std::chrono::duration<double>(now - t0_).count();
  const double rate = sim_.steps() / wall;
  const double left = (cfg_.run.end_time - sim_.time()) / sim_.last_dt() / rate;
  std::fprintf(stderr, "[tamp] stage dynamics | t = %.5f s of %.5f | step %ld | %.0f steps/s | %.0f s left\n",
               sim_.time(), cfg_.run.end_time, sim_.steps(), rate, left);
  last_progress_ = now;
}

void PlainRun::interrupt() {
  record_energy();
  write_energy();
  write_snapshot();
}

void PlainRun::write_partial() {
  record_energy();
  write_energy();
}

std::string PlainRun::where() const {
  char buf[64];
  std::snprintf(buf, sizeof buf, "at t = %.6g s, step %ld", sim_.time(), sim_.steps());
  return buf;
}

std::string PlainRun::finished_line(double wall_s) const {
  char buf[256];
  std::snprintf(buf, sizeof buf, "finished: %ld steps, t = %g s, wall %.2f s, %.3g particle-steps/s", sim_.steps(),
                sim_.time(), wall_s, sim_.particle_count() * double(sim_.steps()) / wall_s);
  return buf;
}

}  // namespace tamp
