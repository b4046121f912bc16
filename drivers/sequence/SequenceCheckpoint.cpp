// The drop sequence's checkpoint: the solver's state (Simulation::save_state) and the
// sequencer's own (stage, blow records, the current blow's watch and energy account, the
// tables' rows so far), and the resumption from it (docs/output.md "Restarts").
#include <cmath>
#include <string>

#include "core/Log.hpp"
#include "drivers/sequence/DropSequence.hpp"

namespace tamp {

Checkpoint DropSequence::checkpoint() {
  Checkpoint c = sim_.save_state();
  c.scalars["seq_next_stage"] = next_stage_;
  c.scalars["seq_in_stage"] = in_stage_ ? 1 : 0;
  c.scalars["seq_stage_t0"] = stage_t0_;
  c.scalars["seq_rest_since"] = rest_since_;
  c.scalars["seq_z_start"] = z_start_;
  c.scalars["seq_peak_dec"] = peak_dec_;
  c.scalars["seq_phase"] = phase_;
  c.scalars["seq_next_record"] = next_record_;
  c.scalars["seq_wall_done"] = wall_done_ + stage_wall_;
  c.scalars["seq_v_in"] = v_in_;
  c.scalars["seq_up_max"] = up_max_;
  c.scalars["seq_out_since"] = out_since_;
  c.scalars["seq_pending_return"] = pending_return_;
  c.scalars["seq_deepest_z"] = deepest_z_;
  c.scalars["seq_contacts"] = contacts_;
  c.scalars["seq_first_rebound_open"] = first_rebound_open_;
  c.scalars["seq_returned"] = returned_;
  c.scalars["seq_in_contact"] = in_contact_;
  c.scalars["seq_contact_time"] = contact_time_;
  c.scalars["seq_flight_time"] = flight_time_;
  c.scalars["seq_relax_since"] = relax_since_;
  c.scalars["seq_relaxed_flight"] = relaxed_flight_;
  c.scalars["seq_ballistic_time"] = ballistic_time_;
  c.reals["seq_energy0"].values = energy0_.flat();
  for (int k = 0; k < static_cast<int>(Phase::Count); ++k)  // steps, simulated s, wall s
    c.reals["seq_phase_time"].values.insert(c.reals["seq_phase_time"].values.end(),
                                            {double(phase_time_[k].steps), phase_time_[k].simulated_s,
                                             phase_time_[k].wall_s});
  c.reals["seq_phase_time"].width = 3;
  auto& br = c.reals["seq_blows"];
  const auto& cols = blow_columns();
  br.width = static_cast<int>(2 + cols.size() + cfg_.materials.size());
  for (const auto& b : blows_) {
    br.values.push_back(b.blow);
    for (const auto& col : cols) br.values.push_back(b.*col.field);
    for (size_t m = 0; m < cfg_.materials.size(); ++m) br.values.push_back(m < b.plastic_J.size() ? b.plastic_J[m] : 0.0);
    br.values.push_back(b.wall_s);
  }
  auto rows = [&](const char* name, const std::vector<std::vector<double>>& t, int width) {
    auto& a = c.reals[name];
    a.width = width;
    for (const auto& r : t) a.values.insert(a.values.end(), r.begin(), r.end());
  };
  rows("seq_tracers", tracer_rows_, 3 + 2 * static_cast<int>(tracer_index_.size()));
  rows("seq_pounder", pounder_rows_, 6);
  rows("seq_energy", energy_rows_, 11);
  auto& ti = c.ints["seq_tracer_index"];
  ti.values = tracer_index_;
  auto& t0 = c.reals["seq_tracer_origin"];
  t0.width = 2;
  for (size_t k = 0; k < tracer_index_.size(); ++k) {
    t0.values.push_back(tracer_r0_[k]);
    t0.values.push_back(tracer_z0_[k]);
  }
  return c;
}

void DropSequence::restore(const Checkpoint& c) {
  if (!is_drop_sequence_checkpoint(c))
    throw std::invalid_argument("the checkpoint is not from a drop sequence (no stage information)");
  sim_.load_state(c);
  auto s = [&](const char* k) { return c.scalars.at(k); };
  next_stage_ = static_cast<int>(s("seq_next_stage"));
  if (next_stage_ > static_cast<int>(stages_.size()))
    throw std::invalid_argument("the checkpoint is at stage " + std::to_string(next_stage_) + "; this deck has " +
                                std::to_string(stages_.size()) + " stages");
  in_stage_ = s("seq_in_stage") != 0;
  stage_t0_ = s("seq_stage_t0");
  rest_since_ = s("seq_rest_since");
  z_start_ = s("seq_z_start");
  peak_dec_ = s("seq_peak_dec");
  phase_ = static_cast<int>(s("seq_phase"));
  next_record_ = s("seq_next_record");
  wall_done_ = s("seq_wall_done");
  auto opt = [&](const char* k) { return c.scalars.count(k) ? c.scalars.at(k) : 0.0; };
  v_in_ = opt("seq_v_in");
  up_max_ = opt("seq_up_max");
  out_since_ = c.scalars.count("seq_out_since") ? c.scalars.at("seq_out_since") : -1.0;
  pending_return_ = opt("seq_pending_return");
  deepest_z_ = c.scalars.count("seq_deepest_z") ? c.scalars.at("seq_deepest_z") : 1e300;
  contacts_ = opt("seq_contacts");
  first_rebound_open_ = opt("seq_first_rebound_open");
  returned_ = opt("seq_returned");
  in_contact_ = opt("seq_in_contact");
  contact_time_ = opt("seq_contact_time");
  flight_time_ = opt("seq_flight_time");
  relax_since_ = c.scalars.count("seq_relax_since") ? c.scalars.at("seq_relax_since") : -1.0;
  relaxed_flight_ = c.scalars.count("seq_relaxed_flight") ? c.scalars.at("seq_relaxed_flight") : -1.0;
  ballistic_time_ = opt("seq_ballistic_time");
  energy0_ = BlowEnergies::from_flat(c.reals.count("seq_energy0") ? c.reals.at("seq_energy0").values : std::vector<double>{},
                                     cfg_.materials.size());
  if (c.reals.count("seq_phase_time")) {  // older checkpoints have none: timing starts at 0
    const auto& v = c.reals.at("seq_phase_time").values;
    for (int k = 0; k < static_cast<int>(Phase::Count) && 3 * k + 2 < static_cast<int>(v.size()); ++k)
      phase_time_[k] = {static_cast<long>(v[3 * k]), v[3 * k + 1], v[3 * k + 2]};
  }
  blows_.clear();
  const auto& br = c.reals.at("seq_blows");
  const auto& cols = blow_columns();
  const size_t nm = cfg_.materials.size();
  // A checkpoint written before the last columns were added reads them as 0 (ballistic_time_s,
  // 2026-12-02: no flight was jumped then; axis_images_J and wall_images_J, 2026-12-04: not
  // measured then). Any other width is another deck or an older Tamp.
  size_t first_added = 0;  // the columns before ballistic_time_s, the first one added later
  while (first_added < cols.size() && std::string(cols[first_added].name) != "ballistic_time_s") ++first_added;
  const long nc_read = static_cast<long>(br.width) - 2 - static_cast<long>(nm);
  if (nc_read < static_cast<long>(first_added) || nc_read > static_cast<long>(cols.size()))
    throw std::invalid_argument("the checkpoint's blow table has " + std::to_string(br.width) + " columns; this version writes " +
                                std::to_string(2 + cols.size() + nm) + " (a checkpoint of an older Tamp or of another deck)");
  const size_t nc = static_cast<size_t>(nc_read);
  const size_t width = 2 + nc + nm;
  for (size_t i = 0; i + width <= br.values.size(); i += width) {
    const double* v = &br.values[i];
    BlowRecord b;
    b.blow = static_cast<int>(v[0]);
    for (size_t k = 0; k < nc; ++k) b.*cols[k].field = v[1 + k];
    b.plastic_J.assign(v + 1 + nc, v + 1 + nc + nm);
    b.wall_s = v[width - 1];
    blows_.push_back(b);
  }
  auto rows = [&](const char* name, std::vector<std::vector<double>>& t) {
    t.clear();
    const auto& a = c.reals.at(name);
    for (size_t i = 0; a.width > 0 && i + a.width <= a.values.size(); i += a.width)
      t.emplace_back(a.values.begin() + i, a.values.begin() + i + a.width);
  };
  tracer_index_ = c.ints.at("seq_tracer_index").values;
  const auto& t0 = c.reals.at("seq_tracer_origin").values;
  tracer_r0_.clear();
  tracer_z0_.clear();
  for (size_t k = 0; k + 1 < t0.size(); k += 2) {
    tracer_r0_.push_back(t0[k]);
    tracer_z0_.push_back(t0[k + 1]);
  }
  rows("seq_tracers", tracer_rows_);
  rows("seq_pounder", pounder_rows_);
  rows("seq_energy", energy_rows_);
}

}  // namespace tamp
