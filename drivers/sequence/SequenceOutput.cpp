// The drop sequence's output: the rows recorded as it runs (tracers, pounder, energies), the
// tables written at each stage end (blows, tracers, pounder, timing, energy, column) and the
// run summary (core/RunSummary.hpp).
#include <algorithm>
#include <cstdio>
#include <fstream>

#include "drivers/sequence/DropSequence.hpp"

namespace tamp {

void DropSequence::record(bool force) {
  if (!force && sim_.time() < next_record_) return;
  next_record_ = sim_.time() + cfg_.schedule.tracer_interval;
  const Stage& st = stages_[std::min<int>(next_stage_, static_cast<int>(stages_.size()) - 1)];
  if (!tracer_index_.empty()) {
    std::vector<double> row{sim_.time(), double(st.blow), double(next_stage_)};
    // Copy only the tracers' coordinates, one value at a time: a row of x is not contiguous
    // on the GPU (LayoutLeft), and Kokkos has no device-to-host copy of a strided view.
    const auto& x = sim_.particles().x;
    for (size_t k = 0; k < tracer_index_.size(); ++k) {
      double r = 0, z = 0;
      Kokkos::deep_copy(r, Kokkos::subview(x, tracer_index_[k], 0));
      Kokkos::deep_copy(z, Kokkos::subview(x, tracer_index_[k], 1));
      row.push_back(z - tracer_z0_[k]);
      row.push_back(r - tracer_r0_[k]);
    }
    tracer_rows_.push_back(row);
  }
  const RigidBody& b = sim_.body();
  if (b.active)
    pounder_rows_.push_back({sim_.time(), double(st.blow), b.z0, b.v_z, b.a_z, -b.contact.force_z});
  const Energies e = sim_.energies();
  const EnergyLedger& L = sim_.ledger();
  energy_rows_.push_back({sim_.time(), e.kinetic, e.internal, e.potential, sim_.body_energy(), sim_.contact_energy(),
                          e.total() + sim_.body_energy() + sim_.contact_energy(), -L.damping_J, -L.boundary_J,
                          -L.wall_friction_J, sim_.accounted_energy()});
}

void DropSequence::write_tables(double wall_s) const {
  std::vector<std::string> header{"blow"};
  for (const auto& col : blow_columns()) header.push_back(col.name);
  for (const auto& m : cfg_.materials) header.push_back("plastic_" + m.name + "_J");
  header.push_back("wall_s");
  std::vector<std::vector<double>> rows;
  for (const auto& b : blows_) {
    std::vector<double> r{double(b.blow)};
    for (const auto& col : blow_columns()) r.push_back(b.*col.field);
    for (size_t m = 0; m < cfg_.materials.size(); ++m) r.push_back(m < b.plastic_J.size() ? b.plastic_J[m] : 0.0);
    r.push_back(b.wall_s);
    rows.push_back(r);
  }
  write_csv(out_ + "/blows.csv", header, rows);
  std::vector<std::string> th{"time_s", "blow", "stage"};
  for (const auto& t : cfg_.tracers) {
    th.push_back(t.name + "_dz_m");
    th.push_back(t.name + "_dr_m");
  }
  write_csv(out_ + "/tracers.csv", th, tracer_rows_);
  write_csv(out_ + "/pounder.csv", {"time_s", "blow", "base_z_m", "v_z_m_s", "a_z_m_s2", "force_z_N"}, pounder_rows_);
  {
    static const char* names[] = {"relax", "impact_contact", "impact_flight", "impact_rest", "extract", "settle"};
    PhaseTime all;
    for (int k = 0; k < static_cast<int>(Phase::Count); ++k) {
      const PhaseTime& p = phase_time_[k];
      all.steps += p.steps;
      all.simulated_s += p.simulated_s;
      all.wall_s += p.wall_s;
    }
    std::ofstream f(out_ + "/timing.csv");
    f << "phase,steps,simulated_s,wall_s,share_of_wall\n";
    char line[160];
    for (int k = 0; k < static_cast<int>(Phase::Count); ++k) {
      const PhaseTime& p = phase_time_[k];
      std::snprintf(line, sizeof line, "%s,%ld,%.9g,%.6g,%.4f\n", names[k], p.steps, p.simulated_s, p.wall_s,
                    all.wall_s > 0 ? p.wall_s / all.wall_s : 0.0);
      f << line;
    }
    std::snprintf(line, sizeof line, "all,%ld,%.9g,%.6g,1\n", all.steps, all.simulated_s, all.wall_s);
    f << line;
  }
  write_csv(out_ + "/energy.csv",
            {"time_s", "kinetic_J", "internal_J", "potential_J", "pounder_J", "contact_J", "total_J", "damped_J",
             "radiated_J", "wall_friction_J", "accounted_J"},
            energy_rows_);
  if (next_stage_ < static_cast<int>(stages_.size())) return;
  const ColumnSummary c = column();
  std::vector<std::vector<double>> crow;
  for (const auto& r : c.rows) crow.push_back({r.depth_m, r.diameter_m, r.solid_diameter_m});
  write_csv(out_ + "/column.csv", {"depth_m", "diameter_m", "solid_diameter_m"}, crow);
  std::ofstream(out_ + "/summary.json") << run_summary_json(summary(wall_s));
}

RunSummary DropSequence::summary(double wall_s) const {
  const ParticleSurvey now = survey();  // one binning for every measurement
  const ColumnSummary c = column(now);
  RunSummary s;
  for (const auto& b : blows_) s.blows_completed += b.crater_depth_m != 0.0 ? 1 : 0;
  s.column_length_m = c.length_m;
  s.head_diameter_m = c.head_diameter_m;
  s.max_diameter_m = c.max_diameter_m;
  s.base_diameter_m = c.base_diameter_m;
  s.head_solid_diameter_m = c.head_solid_diameter_m;
  s.max_solid_diameter_m = c.max_solid_diameter_m;
  s.uplift_m = uplift(now);
  s.aggregate_total_kg = c.aggregate_kg;
  s.steps = sim_.steps();
  s.wall_s = wall_s;
  s.particles = static_cast<long>(sim_.particle_count());
  s.simulated_time_s = sim_.time();
  s.spacing_m = cfg_.sph.spacing;
  s.heave_volume_m3 = heave_volume(now);
  s.aggregate_volume_below_ground_m3 = now.volume_below(backfill_material_, ground_);
  return s;
}

}  // namespace tamp
