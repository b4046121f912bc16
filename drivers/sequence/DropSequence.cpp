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

const std::vector<BlowColumn>& blow_columns() {
  using B = BlowRecord;
  static const std::vector<BlowColumn> columns{
      {"drop_height_m", &B::drop_height_m},       {"crater_depth_m", &B::crater_depth_m},
      {"deepest_m", &B::deepest_m},               {"penetration_m", &B::penetration_m},
      {"contacts", &B::contacts},                 {"restitution", &B::restitution},
      {"peak_deceleration_m_s2", &B::peak_deceleration_m_s2},
      {"rest_in_contact", &B::rest_in_contact},   {"crater_floor_m", &B::crater_floor_m},
      {"uplift_m", &B::uplift_m},                 {"aggregate_added_kg", &B::aggregate_added_kg},
      {"energy_in_J", &B::energy_in_J},           {"elastic_J", &B::elastic_J},
      {"soil_motion_J", &B::soil_motion_J},       {"viscous_heat_J", &B::viscous_heat_J},
      {"radiated_J", &B::radiated_J},             {"damping_J", &B::damping_J},
      {"wall_friction_J", &B::wall_friction_J},   {"contact_J", &B::contact_J},
      {"artificial_stress_J", &B::artificial_stress_J},
      {"returned_J", &B::returned_J},             {"residual_J", &B::residual_J},
      {"contact_time_s", &B::contact_time_s},     {"flight_time_s", &B::flight_time_s},
      {"rest_time_s", &B::rest_time_s},           {"ballistic_time_s", &B::ballistic_time_s},
      {"axis_images_J", &B::axis_images_J},       {"wall_images_J", &B::wall_images_J}};
  return columns;
}

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

std::vector<double> BlowEnergies::flat() const {
  if (!known) return {};
  std::vector<double> e{pounder, contact, damping, boundary, wall_friction, artificial_stress};
  for (const Material& m : materials)
    for (double v : {m.kinetic, m.internal, m.potential, m.elastic, m.numerical_heat}) e.push_back(v);
  for (double v : {node_motion, node_boundary, node_damping, axis_images, wall_images}) e.push_back(v);
  return e;
}

BlowEnergies BlowEnergies::from_flat(const std::vector<double>& v, size_t n_materials) {
  size_t k = 0;
  auto next = [&] { return k < v.size() ? v[k++] : std::numeric_limits<double>::quiet_NaN(); };
  BlowEnergies e;
  e.known = !v.empty();
  for (double* x : {&e.pounder, &e.contact, &e.damping, &e.boundary, &e.wall_friction, &e.artificial_stress}) *x = next();
  e.materials.resize(n_materials);
  for (Material& m : e.materials)
    for (double* x : {&m.kinetic, &m.internal, &m.potential, &m.elastic, &m.numerical_heat}) *x = next();
  for (double* x : {&e.node_motion, &e.node_boundary, &e.node_damping, &e.axis_images, &e.wall_images}) *x = next();
  return e;
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

  const bool at_rest = touching && std::fabs(b.v_z) < sch.rest_speed &&
                       std::fabs(lift - weight) < sch.rest_force_tolerance * weight;
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
  double tau = (v + std::sqrt(v * v + 2.0 * g * (z - z_land))) / g;
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
  const BlowEnergies e1 = energy_state();
  const BlowEnergies& e0 = energy0_;
  // (a term a checkpoint from before it lacks is NaN in e0: it counts from the restart)
  auto d = [](double now, double then) { return std::isnan(then) ? 0.0 : now - then; };
  rec.energy_in_J = -d(e1.pounder, e0.pounder);
  rec.contact_J = d(e1.contact, e0.contact);
  rec.damping_J = -d(e1.damping, e0.damping);
  rec.radiated_J = -d(e1.boundary, e0.boundary);
  rec.wall_friction_J = -d(e1.wall_friction, e0.wall_friction);
  rec.artificial_stress_J = d(e1.artificial_stress, e0.artificial_stress);
  rec.elastic_J = rec.soil_motion_J = rec.viscous_heat_J = 0;
  const size_t nm = cfg_.materials.size();
  rec.plastic_J.assign(nm, 0.0);
  double internal = 0;
  for (size_t m = 0; m < nm; ++m) {
    const BlowEnergies::Material& now = e1.materials[m];
    const BlowEnergies::Material then = m < e0.materials.size() ? e0.materials[m] : BlowEnergies::Material{NAN, NAN, NAN, NAN, NAN};
    rec.soil_motion_J += d(now.kinetic, then.kinetic) + d(now.potential, then.potential);
    rec.elastic_J += d(now.elastic, then.elastic);
    rec.viscous_heat_J += d(now.numerical_heat, then.numerical_heat);
    rec.plastic_J[m] = d(now.internal, then.internal) - d(now.elastic, then.elastic) - d(now.numerical_heat, then.numerical_heat);
    internal += d(now.internal, then.internal);
  }
  rec.soil_motion_J += d(e1.node_motion, e0.node_motion);  // the tied elements' nodes
  rec.radiated_J -= d(e1.node_boundary, e0.node_boundary);
  rec.damping_J -= d(e1.node_damping, e0.node_damping);
  rec.axis_images_J = d(e1.axis_images, e0.axis_images);
  rec.wall_images_J = d(e1.wall_images, e0.wall_images);
  rec.residual_J = rec.energy_in_J + rec.artificial_stress_J + rec.axis_images_J + rec.wall_images_J -
                   (rec.soil_motion_J + internal + rec.contact_J + rec.radiated_J + rec.damping_J + rec.wall_friction_J);
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

double DropSequence::heave_volume() const { return heave_volume(survey()); }

double DropSequence::heave_volume(const ParticleSurvey& survey) const { return tamp::heave_volume(survey, geometry()); }

double DropSequence::aggregate_volume_below_ground() const {
  return survey().volume_below(backfill_material_, ground_);  // sum of m / rho below the ground
}

}  // namespace tamp
