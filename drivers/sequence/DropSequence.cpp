#include "drivers/sequence/DropSequence.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/Log.hpp"

namespace tamp {
namespace fs = std::filesystem;

namespace {

double wall_now() {
  using clock = std::chrono::steady_clock;
  static const clock::time_point t0 = clock::now();
  return std::chrono::duration<double>(clock::now() - t0).count();
}

const char* kind_name(StageKind k) {
  switch (k) {
    case StageKind::Relax: return "relax";
    case StageKind::Impact: return "impact";
    case StageKind::Extract: return "extract";
    default: return "backfill";
  }
}

}  // namespace

bool is_drop_sequence_checkpoint(const Checkpoint& c) { return c.scalars.count("seq_next_stage") > 0; }

DropSequence::DropSequence(Simulation& sim, const Config& cfg, std::string out)
    : sim_(sim), cfg_(cfg), out_(std::move(out)), series_(out_ + "/stages.xdmf") {
  const ScheduleSpec& sch = cfg_.schedule;
  if (!sch.enabled) throw std::invalid_argument("the deck has no [schedule]: nothing to sequence");
  double top = -1e300;
  for (const auto& b : cfg_.blocks) top = std::max(top, b.z_max);
  ground_ = sch.ground_level != 0.0 ? sch.ground_level : top;
  backfill_material_ = cfg_.backfill.material.empty() ? -1 : sim_.material_index(cfg_.backfill.material);

  stages_.push_back({StageKind::Relax, 0});
  for (size_t b = 1; b <= sch.drop_heights.size(); ++b) {
    stages_.push_back({StageKind::Impact, static_cast<int>(b)});
    stages_.push_back({StageKind::Extract, static_cast<int>(b)});
    if (std::find(sch.backfill_after.begin(), sch.backfill_after.end(), static_cast<int>(b)) != sch.backfill_after.end())
      stages_.push_back({StageKind::Backfill, static_cast<int>(b)});
  }
  const PounderSpec& p = cfg_.pounder;
  sim_.set_rigid_body(barrel_profile(p.base_diameter, p.max_diameter, p.height, p.profile_segments), p.mass);

  // Tracers: the particle nearest to each requested point.
  const ParticleSurvey at_start = survey();
  const auto x = Kokkos::create_mirror_view_and_copy(HostSpace(), sim_.particles().x);
  for (const auto& t : cfg_.tracers) {
    const int best = at_start.nearest(t.r, t.z);
    tracer_index_.push_back(best);
    tracer_r0_.push_back(x(best, 0));
    tracer_z0_.push_back(x(best, 1));
  }
  fs::create_directories(out_ + "/stages");
  fs::create_directories(out_ + "/checkpoints");
}

std::string DropSequence::stage_name(int k) const {
  char buf[64];
  const Stage& s = stages_.at(k);
  if (s.kind == StageKind::Relax) std::snprintf(buf, sizeof buf, "%03d-relax", k);
  else std::snprintf(buf, sizeof buf, "%03d-%s-blow%02d", k, kind_name(s.kind), s.blow);
  return buf;
}

BlowRecord& DropSequence::blow_record(int blow) {
  while (static_cast<int>(blows_.size()) < blow) {
    BlowRecord r;
    r.blow = static_cast<int>(blows_.size()) + 1;
    r.drop_height_m = cfg_.schedule.drop_heights[r.blow - 1];
    r.plastic_J.assign(cfg_.materials.size(), 0.0);
    blows_.push_back(r);
  }
  return blows_[blow - 1];
}

// Top of the particles under the pounder (centre of the highest particle whose column
// overlaps the pounder's widest radius), m.
double DropSequence::surface_under_pounder() const { return tamp::surface_under_pounder(survey(), geometry()); }

DropGeometry DropSequence::geometry() const {
  DropGeometry g;
  g.ground = ground_;
  g.spacing = cfg_.sph.spacing;
  g.pounder_max_diameter = cfg_.pounder.max_diameter;
  g.pounder_base_diameter = cfg_.pounder.base_diameter;
  for (const auto& b : cfg_.blocks) g.domain_r_max = std::max(g.domain_r_max, b.r_max);
  g.aggregate = backfill_material_;
  return g;
}

ParticleSurvey DropSequence::survey() const { return sim_.survey(); }

double DropSequence::crater_floor() const { return tamp::crater_floor(survey(), geometry()); }

double DropSequence::mean_soil_top(double r_in, double r_out, int neighbours) const {
  return tamp::mean_soil_top(survey(), geometry(), r_in, r_out, neighbours);
}

void DropSequence::begin_impact(const Stage& s) {
  const double dp = cfg_.sph.spacing;
  const double top = surface_under_pounder();
  // The base touches a particle when it is dp/2 above the particle's centre; start a
  // tenth of a spacing above that, with the speed of free fall from the drop height.
  const double z0 = top + 0.5 * dp + 0.1 * dp;
  double fall = cfg_.schedule.drop_heights[s.blow - 1];
  if (cfg_.schedule.drop_height_from == "ground") fall += std::max(0.0, ground_ - z0);
  const double v0 = std::sqrt(2.0 * cfg_.gravity * fall);
  sim_.set_damping(cfg_.damping);
  sim_.place_body(0.0, z0, 0.0, -v0);
  z_start_ = 1e300;  // set at the first contact
  peak_dec_ = 0;
  rest_since_ = -1;
  phase_ = 0;
  v_in_ = 0;
  up_max_ = 0;
  out_since_ = -1;
  pending_return_ = 0;
  deepest_z_ = z0;
  contacts_ = 0;
  first_rebound_open_ = 1;
  returned_ = 0;
  in_contact_ = 0;
  contact_time_ = flight_time_ = 0;
  relax_since_ = relaxed_flight_ = -1;
  ballistic_time_ = 0;
  energy0_ = energy_state();
  BlowRecord& rec = blow_record(s.blow);
  rec.drop_height_m = cfg_.schedule.drop_heights[s.blow - 1];
}

BlowEnergies DropSequence::energy_state() const {
  const EnergyLedger& L = sim_.ledger();
  BlowEnergies e;
  e.known = true;
  e.pounder = sim_.body_energy();
  e.contact = sim_.contact_energy();
  e.damping = L.damping_J;
  e.boundary = L.boundary_J;
  e.wall_friction = L.wall_friction_J;
  e.artificial_stress = L.artificial_stress_J;
  const std::vector<MaterialEnergy> me = sim_.material_energies();
  for (size_t k = 0; k < me.size(); ++k)
    e.materials.push_back({me[k].kinetic, me[k].internal, me[k].potential, me[k].elastic, L.heat_J[k] + me[k].hourglass});
  const ElementNodeEnergy n = sim_.element_node_energy();
  e.node_motion = n.motion;
  e.node_boundary = n.boundary_work;
  e.node_damping = n.damping_work;
  const ImageWork images = sim_.image_work();
  e.axis_images = images.axis_J;
  e.wall_images = images.walls_J;
  return e;
}

// A blow is followed until the pounder is at rest *in contact*: touching the soil with an
// upward contact force, speed below rest_speed and the contact force within
// rest_force_tolerance of its weight, all held for rest_hold; then rest_time of damped
// settling. A rebound is followed through its flight to the next impact. A contact phase
// is counted when the pounder lands again after at least min_flight out of contact (so
// that the chatter of single particles at the rim is not a rebound).
bool DropSequence::impact_step() {
  constexpr double min_flight = 1e-3;  // s
  const ScheduleSpec& sch = cfg_.schedule;
  const double t_before = sim_.time();
  sim_.step();
  const double dt = sim_.time() - t_before;
  const RigidBody& b = sim_.body();
  const double t = sim_.time() - stage_t0_;
  const double weight = b.mass * cfg_.gravity;
  const double lift = -b.contact.force_z;  // upward contact force on the pounder, N
  const bool touching = b.contact.touching > 0 && lift > 0.01 * weight;
  deepest_z_ = std::min(deepest_z_, b.z0);
  if (phase_ == 1) return sim_.time() - rest_since_ < sch.rest_time;

  peak_dec_ = std::max(peak_dec_, b.a_z);  // upward acceleration = deceleration of the fall
  if (touching) {
    if (z_start_ > 1e299) {  // first contact
      z_start_ = b.z0;
      v_in_ = std::fabs(b.v_z);
      contacts_ = 1;
    } else if (out_since_ >= 0 && sim_.time() - out_since_ >= min_flight) {
      // landing after a flight: a new contact; the first rebound is over once the pounder
      // has moved up (a first touch of a loose grain that did not turn it is no rebound)
      contacts_ += 1;
      if (up_max_ > 0) first_rebound_open_ = 0;
    }
    out_since_ = -1;
    in_contact_ = 1;
    contact_time_ += dt;
  } else {
    if (in_contact_ > 0) {  // leaving contact: the speed the soil gave back
      out_since_ = sim_.time();
      pending_return_ = b.v_z > 0 ? 0.5 * b.mass * b.v_z * b.v_z : 0.0;
    }
    if (out_since_ >= 0 && pending_return_ > 0 && sim_.time() - out_since_ >= min_flight) {
      returned_ += pending_return_;  // a real flight, not a flicker
      pending_return_ = 0;
    }
    in_contact_ = 0;
    flight_time_ += dt;
  }
  if (z_start_ < 1e299 && first_rebound_open_ > 0) up_max_ = std::max(up_max_, b.v_z);
  if (sch.flight == "ballistic") ballistic_flight(min_flight, touching);

  const bool at_rest = pounder_at_rest(touching, b.v_z, lift, weight, sch.rest_speed, sch.rest_force_tolerance);
  if (at_rest) {
    if (rest_since_ < 0) rest_since_ = sim_.time();
    if (sim_.time() - rest_since_ >= sch.rest_hold) {
      phase_ = 1;
      rest_since_ = sim_.time();
      sim_.set_damping(sch.damping);
      blow_record(stages_[next_stage_].blow).rest_in_contact = 1;
    }
  } else {
    rest_since_ = -1;
  }
  // At max_impact_time a pounder in flight is followed to its next landing (up to twice
  // that time), so that the crater depth of a blow that did not come to rest is where the
  // pounder stands on the soil, not a point of its flight (lab blow 33: 0.33 m/s upward).
  if (t >= sch.max_impact_time && (touching || t >= 2.0 * sch.max_impact_time)) {
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "blow %d: the pounder did not come to rest in contact within max_impact_time = %g s "
                  "(speed %.3f m/s, contact force %.1f N, weight %.1f N, %s); the blow is recorded as it stands",
                  stages_[next_stage_].blow, sch.max_impact_time, b.v_z, lift, weight,
                  touching ? "touching the soil" : "in the air");
    log::warn(buf);
    blow_record(stages_[next_stage_].blow).rest_in_contact = 0;
    return false;
  }
  return true;
}

// schedule.flight = "ballistic": a rebound flight that would last more than twice
// flight_relax_time (back to its take-off height, 2 v / g) is not followed step by step.
// Once the pounder has been out of contact for min_flight, the soil relaxes under
// the schedule's damping for flight_relax_time while the pounder flies on; then the clock
// jumps over the rest of the flight: the pounder is placed where its free fall meets the
// soil (a tenth of a spacing above the highest particle under it, as at the drop) with the
// speed of that fall, and the blow goes on undamped. Its kinetic + potential energy is that
// of the flight, so the energy account is untouched; the soil's, after the relaxation, is
// what the damping left (booked as damping work). Contact during the relaxation (a force
// above 1 % of the weight) ends it: the flight is then followed.
void DropSequence::ballistic_flight(double min_flight, bool touching) {
  const ScheduleSpec& sch = cfg_.schedule;
  const RigidBody& b = sim_.body();
  const double g = sim_.gravity_at(sim_.time());
  // clear of the soil: not touching by the contact phases' rule (force below 1 % of the
  // weight: a grain grazing the barrel's side must not keep a long flight from being jumped;
  // the landing height is above every particle within the widest radius, so none is overlapped)
  const bool clear = !touching;
  if (relax_since_ < 0) {
    if (clear && out_since_ >= 0 && out_since_ != relaxed_flight_ && sim_.time() - out_since_ >= min_flight &&
        b.v_z > 0 && 2.0 * b.v_z / g > 2.0 * sch.flight_relax_time) {
      relax_since_ = sim_.time();
      relaxed_flight_ = out_since_;
      sim_.set_damping(sch.damping);
    }
    return;
  }
  if (!clear) {  // the soil reached the pounder: follow the flight
    relax_since_ = -1;
    sim_.set_damping(cfg_.damping);
    return;
  }
  if (sim_.time() - relax_since_ < sch.flight_relax_time) return;
  relax_since_ = -1;
  sim_.set_damping(cfg_.damping);
  const double dp = cfg_.sph.spacing;
  const double z_land = surface_under_pounder() + 0.5 * dp + 0.1 * dp;
  const double z = b.z0, v = b.v_z;
  if (!(z > z_land)) return;  // already down at the soil: follow the landing
  // z + v tau - g tau^2 / 2 = z_land, the later root; the jump stops where the stage must
  // end (twice max_impact_time, see impact_step)
  double tau = landing_time(z, v, g, z_land);
  tau = std::min(tau, std::max(0.0, 2.0 * sch.max_impact_time - (sim_.time() - stage_t0_)));
  // pounder.csv keeps its rows through the jump (the free fall, no contact force)
  const double t0 = sim_.time(), blow = stages_[next_stage_].blow;
  for (double t = next_record_; t < t0 + tau; t += sch.tracer_interval) {
    const double s = t - t0;
    pounder_rows_.push_back({t, blow, z + v * s - 0.5 * g * s * s, v - g * s, -g, 0.0});
  }
  sim_.skip_time(tau);
  sim_.place_body(0.0, z + v * tau - 0.5 * g * tau * tau, 0.0, v - g * tau);
  flight_time_ += tau;
  ballistic_time_ += tau;
}

// The blow's record at the end of its impact stage: position, contacts and energy account.
void DropSequence::end_impact(BlowRecord& rec) {
  const RigidBody& b = sim_.body();
  rec.crater_depth_m = ground_ - b.z0;
  rec.deepest_m = ground_ - deepest_z_;
  rec.penetration_m = z_start_ < 1e299 ? z_start_ - b.z0 : 0.0;
  rec.contacts = contacts_;
  rec.restitution = v_in_ > 0 ? std::max(0.0, up_max_) / v_in_ : 0.0;
  rec.peak_deceleration_m_s2 = peak_dec_;
  rec.returned_J = returned_ + pending_return_;
  rec.contact_time_s = contact_time_;
  rec.flight_time_s = flight_time_;
  rec.ballistic_time_s = ballistic_time_;
  rec.rest_time_s = phase_ == 1 ? sim_.time() - rest_since_ : 0.0;
  account_blow_energy(energy0_, energy_state(), rec);
}

void DropSequence::backfill(const Stage& s) {
  const double dp = cfg_.sph.spacing;
  const BackfillSpec& bf = cfg_.backfill;
  const double radius = bf.radius > 0 ? bf.radius : 0.5 * cfg_.pounder.max_diameter + 2.0 * dp;
  const double z_lo = cfg_.blocks.empty() ? ground_ - 1.0 : [&] {
    double lo = 1e300;
    for (const auto& b : cfg_.blocks) lo = std::min(lo, b.z_min);
    return lo;
  }();
  // The level a charge fills to: the original ground ("fill"), the surface around the crater
  // ("surface": the mean top of the soil, any material, in the two radial columns of width dp
  // just outside the fill radius, as a worker fills a hole level with the heaved ground
  // beside it; never below the original ground), or up to 0.5 m above it ("mass").
  double z_hi = ground_;
  if (bf.mode == "mass") z_hi = ground_ + 0.5;
  if (bf.mode == "surface") {
    const double level = mean_soil_top(radius, radius + 2.0 * dp, 3);
    if (!std::isnan(level)) z_hi = std::max(ground_, level);
  }
  std::vector<CraterSite> sites;  // cell centres of a grid of spacing dp
  std::vector<double> cr, cz;
  auto site = [&](int k, double z) {
    sites.push_back({k, z});
    cr.push_back((k + 0.5) * dp);
    cz.push_back(z);
  };
  for (int k = 0; (k + 0.5) * dp < radius; ++k)
    for (int j = 0; ground_ - (j + 0.5) * dp > z_lo; ++j) site(k, ground_ - (j + 0.5) * dp);
  if (z_hi > ground_)  // sites above the original ground, their centres below the level
    for (int k = 0; (k + 0.5) * dp < radius; ++k)
      for (int j = 0; ground_ + (j + 0.5) * dp < z_hi; ++j) site(k, ground_ + (j + 0.5) * dp);
  const int nc = static_cast<int>(sites.size());
  const std::vector<int> is_free = survey().free_sites(sites, 0.9 * dp);
  std::vector<int> order;
  for (int c = 0; c < nc; ++c)
    if (is_free[c]) order.push_back(c);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return cz[a] < cz[b] || (cz[a] == cz[b] && cr[a] < cr[b]); });
  const double rho = cfg_.materials[backfill_material_].density;
  std::vector<NewParticle> add;
  double mass = 0;
  for (int c : order) {
    const double m = rho * 2.0 * pi * cr[c] * dp * dp;
    if (bf.mode == "mass" && mass + 0.5 * m > bf.mass) break;
    add.push_back({cr[c], cz[c], backfill_material_});
    mass += m;
  }
  const Simulation::Added result = sim_.add_particles(add);
  for (int& k : tracer_index_) k = result.new_index_of_old[k];  // the particles were put in cell order
  const double added = result.mass_kg;
  blow_record(s.blow).aggregate_added_kg += added;
  log::info("blow " + std::to_string(s.blow) + ": backfill of " + std::to_string(add.size()) + " particles, " +
            std::to_string(added) + " kg" +
            (bf.mode == "surface" ? ", up to " + std::to_string(1e3 * (z_hi - ground_)) + " mm above the ground" : ""));
  sim_.set_damping(cfg_.schedule.damping);
}

void DropSequence::progress(int k, bool force) {
  if (log::level() == log::Level::Quiet) return;
  const double now = wall_now();
  if (!force && now - last_progress_wall_ < cfg_.run.progress_interval) return;
  last_progress_wall_ = now;
  const Stage& s = stages_[k];
  const double done_frac = double(k) / stages_.size();
  // Wall time of this and earlier runs (restored from a checkpoint), so that the step rate
  // of a restarted run counts the steps before the restart against the time they took.
  const double elapsed = wall_done_ + stage_wall_;
  // Time left from the stages done so far (none done yet: no estimate).
  char left[48] = "time left unknown yet";
  if (k > 0) std::snprintf(left, sizeof left, "~%.0f s left", elapsed / done_frac * (1.0 - done_frac));
  char buf[256];
  std::snprintf(buf, sizeof buf, "[tamp] stage %d/%zu %-8s blow %d/%zu | t = %.4f s | step %ld | %.0f steps/s | %s",
                k + 1, stages_.size(), kind_name(s.kind), s.blow, cfg_.schedule.drop_heights.size(), sim_.time(),
                sim_.steps(), sim_.steps() / std::max(1e-9, elapsed), left);
  std::fprintf(stderr, "%s\n", buf);
}

void DropSequence::end_stage(int k) {
  const Stage& s = stages_[k];
  const ScheduleSpec& sch = cfg_.schedule;
  (void)sch;
  if (s.kind == StageKind::Impact) end_impact(blow_record(s.blow));
  if (s.kind == StageKind::Extract) {
    blow_record(s.blow).uplift_m = uplift();
    blow_record(s.blow).crater_floor_m = crater_floor();
  }
  if (s.blow > 0) blow_record(s.blow).wall_s += stage_wall_;
  wall_done_ += stage_wall_;
  stage_wall_ = 0;
  in_stage_ = false;
  next_stage_ = k + 1;
  record(true);
  if (!stage_files_) return;
  // snapshot + checkpoint of the stage end
  const std::string name = stage_name(k);
  const ParticleSnapshot snap = sim_.snapshot();
  write_snapshot_h5(out_ + "/stages/" + name + ".h5", snap);
  series_.add("stages/" + name + ".h5", snap);
  series_.write();
  const std::string path = out_ + "/checkpoints/" + name + ".h5";
  write_checkpoint_h5(path, checkpoint());
  last_checkpoint_ = path;  // only once it is written (a full disk leaves the previous one)
  write_tables(wall_done_);
}

void DropSequence::begin_stage(int k) {
  const Stage& s = stages_[k];
  const ScheduleSpec& sch = cfg_.schedule;
  in_stage_ = true;
  stage_t0_ = sim_.time();
  switch (s.kind) {
    case StageKind::Relax: sim_.set_damping(sch.damping); break;
    case StageKind::Impact: begin_impact(s); break;
    case StageKind::Extract: sim_.remove_body(); sim_.set_damping(sch.damping); break;
    case StageKind::Backfill: backfill(s); break;
  }
}

bool DropSequence::stage_step(int k) {
  const Stage& s = stages_[k];
  const ScheduleSpec& sch = cfg_.schedule;
  const double duration = s.kind == StageKind::Relax     ? sch.relax_time
                          : s.kind == StageKind::Extract ? sch.extract_time
                          : s.kind == StageKind::Backfill ? sch.settle_time
                                                          : 0.0;
  bool more;
  const double t_before = sim_.time();
  const long steps_before = sim_.steps();
  const double w0 = wall_now();
  if (s.kind == StageKind::Impact) {
    more = impact_step();
  } else {
    more = sim_.time() - stage_t0_ < duration * (1.0 - 1e-12);
    if (more) sim_.step();
  }
  const double now = wall_now();
  PhaseTime& pt = phase_time_[static_cast<int>(step_phase(s))];
  pt.steps += sim_.steps() - steps_before;
  pt.simulated_s += sim_.time() - t_before;
  pt.wall_s += now - w0;
  record(false);
  progress(k, false);
  return more;
}

bool DropSequence::step() {
  if (!started_) {
    started_ = true;
    if (next_stage_ == 0 && !in_stage_) record(true);
  }
  if (next_stage_ >= static_cast<int>(stages_.size())) {
    // Tables and summary of the finished run (also after a restart from its last checkpoint:
    // that re-measures a finished run with the current measurement code).
    write_tables(wall_done_);
    return false;
  }
  const int k = next_stage_;
  const double w0 = wall_now();
  if (!in_stage_) begin_stage(k);
  const bool more = stage_step(k);
  stage_wall_ += wall_now() - w0;
  if (more) return true;
  end_stage(k);
  progress(k, true);
  if (stop_after_ >= 0 && k >= stop_after_) return false;
  return true;
}

void DropSequence::interrupt() {
  const std::string path = out_ + "/checkpoints/interrupted.h5";
  write_checkpoint_h5(path, checkpoint());
  last_checkpoint_ = path;
  write_tables(wall_done_ + stage_wall_);
}

void DropSequence::write_partial() { write_tables(wall_done_ + stage_wall_); }

std::string DropSequence::where() const { return "in stage " + std::to_string(next_stage_); }

std::string DropSequence::finished_line(double wall_s) const {
  const bool done = next_stage_ >= static_cast<int>(stages_.size());
  std::ostringstream msg;
  char wall[32];
  std::snprintf(wall, sizeof wall, "%.1f", wall_s);
  msg << (done ? "finished: " : "stopped after stage " + std::to_string(next_stage_ - 1) + ": ") << sim_.steps()
      << " steps, t = " << sim_.time() << " s, " << sim_.particle_count() << " particles, wall " << wall
      << " s this run; results in " << out_;
  return msg.str();
}

Phase DropSequence::step_phase(const Stage& s) const {
  switch (s.kind) {
    case StageKind::Relax: return Phase::Relax;
    case StageKind::Extract: return Phase::Extract;
    case StageKind::Backfill: return Phase::Settle;
    case StageKind::Impact: break;
  }
  if (phase_ == 1) return Phase::Rest;
  return in_contact_ > 0 ? Phase::Contact : Phase::Flight;
}

bool DropSequence::run(int stop_after, const std::function<bool()>& keep_going) {
  stop_after_ = stop_after;
  run_steps(*this, keep_going);  // drivers/sequence/RunLoop.hpp
  return next_stage_ >= static_cast<int>(stages_.size());
}

double DropSequence::uplift() const { return uplift(survey()); }

double DropSequence::uplift(const ParticleSurvey& survey) const { return tamp::uplift(survey, geometry()); }

ColumnSummary DropSequence::column() const { return column(survey()); }

ColumnSummary DropSequence::column(const ParticleSurvey& survey) const {
  if (backfill_material_ < 0) return {};
  return measure_column(survey, backfill_material_, ground_, cfg_.sph.spacing);
}

double DropSequence::heave_volume() const { return heave_volume(survey()); }

double DropSequence::heave_volume(const ParticleSurvey& survey) const { return tamp::heave_volume(survey, geometry()); }

double DropSequence::aggregate_volume_below_ground() const {
  return survey().volume_below(backfill_material_, ground_);  // sum of m / rho below the ground
}

}  // namespace tamp
