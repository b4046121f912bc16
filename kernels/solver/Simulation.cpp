#include "kernels/solver/Simulation.hpp"

#include <Kokkos_Sort.hpp>
#include "kernels/DeterministicSum.hpp"
#include "core/Format.hpp"
#include "core/ParticleGrid.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <sstream>
#include <type_traits>

namespace tamp {

Simulation::Simulation(const Config& config) : config_(config) {
  const double dp = config_.sph.spacing;
  sph_.h = config_.sph.h_factor * dp;
  sph_.alpha = config_.sph.alpha;
  sph_.beta = config_.sph.beta;
  sph_.artificial_stress_epsilon = config_.sph.artificial_stress;
  sph_.art_n = config_.sph.artificial_stress_n;
  sph_.inv_w_dp = 1.0 / Wendland2D(sph_.h).value(dp);
  sph_.r_min = config_.sph.axis_radius_factor * sph_.h;
  sph_.gravity = gravity_at(0.0);
  sph_.damping = config_.damping;
  sph_.kernel_correction = config_.sph.kernel_correction ? 1 : 0;
  skin_ = config_.sph.neighbour_skin * sph_.h;
  contact_law_.contact_distance = 0.5 * dp;
  contact_law_.penalty_scale = config_.contact.penalty_scale;
  contact_law_.damping_ratio = config_.contact.damping_ratio;
  contact_law_.static_friction = config_.contact.static_friction;
  contact_law_.dynamic_friction = config_.contact.dynamic_friction;
  contact_law_.decay = config_.contact.decay;
  artificial_stress_factors_ = artificial_stress_table(sph_);

  // Mirror planes: the axis first, then the walls the deck asks for.
  MirrorPlanes& planes = ghosts_.planes;
  planes.plane[planes.count++] = MirrorPlane{0, 0.0, +1, 0};
  auto add_wall = [&](const WallSpec& w, int axis, int side) {
    if (w.type == WallType::None) return;
    if (w.type == WallType::NonReflecting) {
      non_reflecting_.plane[non_reflecting_.count++] = MirrorPlane{axis, w.position, side, 0, spring_distance(w, axis, side)};
      return;
    }
    planes.plane[planes.count++] = MirrorPlane{axis, w.position, side, w.type == WallType::Fixed ? 1 : 0};
    if (w.type == WallType::Fixed) fixed_walls_ = true;
  };
  add_wall(config_.bottom, 1, +1);
  add_wall(config_.top, 1, -1);
  add_wall(config_.outer, 0, -1);

  build_materials();
  ledger_.heat_J.assign(materials_host_.size(), 0.0);
  build_particles();
  hold_boundary_stress();  // the non-reflecting boundaries' particles (zero traction yet)
  refresh_neighbours(true);
  ensure_pair_storage();
  Kokkos::parallel_for("tamp::sph::pair_kernel", Kokkos::RangePolicy<ExecSpace>(0, particles_.n_real),
                       PairKernelFactors(particles_, neighbours_, pair_gradient_factor_, sph_.h));
  if (config_.fem.enabled) build_fem();  // elements outside the SPH zone, tied to the particles
  if (config_.initial_stress == "geostatic") {
    set_geostatic_stress();  // also updates the pair stress and the accelerations
  } else {
    update_pair_stress();
    compute_acceleration();
  }
}

// Spring distance R of a non-reflecting wall: the deck's, or automatically the extent of the
// initial blocks normal to the plane (the distance to the farthest soil, where the blows
// act: Deeks & Randolph's R). side > 0: the soil lies on the + side of the plane.
double Simulation::spring_distance(const WallSpec& w, int axis, int side) const {
  if (w.spring_distance >= 0) return w.spring_distance;
  double R = 0;
  for (const BlockSpec& b : config_.blocks) {
    const double lo = axis == 0 ? b.r_min : b.z_min, hi = axis == 0 ? b.r_max : b.z_max;
    R = std::max(R, side > 0 ? hi - w.position : w.position - lo);
  }
  return R;
}

// The deck's [fem] mesh (kernels/FemMeshGenerator.hpp) with its materials and options; the
// deck's walls act on the sides of the mesh; the mesh is tied to the particles.
void Simulation::build_fem() {
  const FemSpec& f = config_.fem;
  const DeckMesh deck = deck_mesh(f, config_.blocks, [&](const std::string& name) { return material_index(name); });
  const fem::FemGrid& grid = deck.grid;
  std::vector<MaterialParams> mats;
  for (int dm : deck.deck_material) mats.push_back(materials_host_[dm]);
  const std::vector<std::string>& names = deck.material_name;
  fem::FemOptions opt;
  opt.cfl = f.cfl;
  opt.hourglass_coefficient = f.hourglass_coefficient;
  // Viscous by default: the stiffness form fed an instability of a tie at the axis
  // (docs/coupling.md); the viscous form damps hourglass modes instead of storing them.
  opt.hourglass = f.hourglass == "stiffness" ? fem::HOURGLASS_STIFFNESS : fem::HOURGLASS_VISCOUS;
  opt.gravity = gravity_at(time_);
  opt.damping = sph_.damping;
  own_fem_ = std::make_unique<fem::FemModel>(mats, grid, opt);
  fem::FemModel& m = *own_fem_;
  auto wall = [&](const WallSpec& w, const char* name, fem::FemSide side, double edge, int axis, int soil_side) {
    if (w.type == WallType::None) return;
    if (std::fabs(w.position - edge) > 1e-9)
      throw std::invalid_argument(std::string("boundaries.") + name + " at " + fmt_num(w.position) +
                                  " m is not on the edge of the element mesh (" + fmt_num(edge) +
                                  " m): with [fem] the walls bound the blocks");
    if (w.type == WallType::Fixed) m.set_side(side, fem::FemBc::Fixed);
    else if (w.type == WallType::Roller) m.set_side(side, fem::FemBc::Roller);
    else m.set_non_reflecting(side, spring_distance(w, axis, soil_side));
  };
  wall(config_.bottom, "bottom", fem::FemSide::Bottom, grid.z.front(), 1, +1);
  wall(config_.top, "top", fem::FemSide::Top, grid.z.back(), 1, -1);
  wall(config_.outer, "outer", fem::FemSide::Outer, grid.r.back(), 0, -1);
  m.hold_boundary_forces();
  tie_fem(m, names);
}

int Simulation::material_index(const std::string& name) const {
  int mat = -1;  // the last deck material of that name (names are unique in a valid deck)
  for (size_t k = 0; k < config_.materials.size(); ++k)
    if (config_.materials[k].name == name) mat = static_cast<int>(k);
  return mat;
}

void Simulation::ensure_pair_storage() {
  if (pair_gradient_factor_.extent(0) < neighbours_.neighbours.extent(0))
    pair_gradient_factor_ = View1<double>("tamp::pair_gradient_factor", neighbours_.neighbours.extent(0));
}

// pair_stress of the real particles from their stress, then every ghost's stress.
void Simulation::update_pair_stress() {
  Particles& P = particles_;
  Kokkos::parallel_for("tamp::sph::pair_stress", Kokkos::RangePolicy<ExecSpace>(0, P.n_real),
                       PairStress(P));
  ghosts_.sync_stress(P, sph_.gravity);
}

void Simulation::build_materials() {
  materials_host_.clear();
  for (const auto& s : config_.materials) materials_host_.push_back(make_material(s));
  materials_ = Kokkos::View<MaterialParams*, MemSpace>("tamp::materials", materials_host_.size());
  auto h = Kokkos::create_mirror_view(materials_);
  for (size_t k = 0; k < materials_host_.size(); ++k) h(k) = materials_host_[k];
  Kokkos::deep_copy(materials_, h);
  wave_speeds_ = Kokkos::View<double*, MemSpace>("tamp::wave_speeds", materials_host_.size());
  auto c = Kokkos::create_mirror_view(wave_speeds_);
  for (size_t k = 0; k < materials_host_.size(); ++k) c(k) = materials_host_[k].wave_speed();
  Kokkos::deep_copy(wave_speeds_, c);
}

// Particles on a regular grid of spacing dp in each block (centres at half spacings), ring
// mass m = rho0 * 2 pi r * dp^2. One kernel launch per block.
void Simulation::build_particles() {
  Particles& P = particles_;
  int thin = -1;
  const std::vector<BlockParticles> count = particle_grid(config_, &thin);  // core/ParticleGrid.hpp
  if (thin >= 0)
    throw std::invalid_argument("blocks[" + std::to_string(thin) + "] is thinner than one particle spacing");
  double asked = 0;
  for (const BlockParticles& c : count) asked += c.count();
  if (!(asked <= kMaxParticles))
    throw std::invalid_argument("the blocks ask for " + fmt_num(asked) + " particles; at most " +
                                fmt_num(kMaxParticles) + " (32-bit particle indices)");
  std::vector<int> mats;
  int total = 0;
  for (const BlockParticles& c : count) {
    const int mat = material_index(c.spec.material);
    if (mat < 0) throw std::invalid_argument("block refers to unknown material '" + c.spec.material + "'");
    mats.push_back(mat);
    total += static_cast<int>(c.count());
  }
  P.reserve(total + total / 2 + 64);
  P.n_real = total;
  P.n_total = total;
  P.fill_new(0, P.capacity);  // every field at a new particle's value (core/Particles.hpp)
  int first = 0;
  for (size_t k = 0; k < count.size(); ++k) {  // kernels/ParticleGenerator.hpp, one launch per block
    const int nr = static_cast<int>(count[k].nr), nz = static_cast<int>(count[k].nz);
    const FillBlock fill(P, first, nr, nz, mats[k], count[k].spec, materials_host_[mats[k]].density, config_.sph);
    Kokkos::parallel_for("tamp::build_block", Kokkos::RangePolicy<ExecSpace>(0, fill.count()), fill);
    first += nr * nz;
  }
  Kokkos::fence();
}

void Simulation::refresh_neighbours(bool force) {
  Particles& P = particles_;
  const double cutoff = 2.0 * sph_.h + skin_;
  bool rebuild = force;
  if (!rebuild) {
    const double dmax = max_displacement_sq(P.x, P.x_ref, P.n_real + P.n_tie);
    rebuild = std::sqrt(dmax) > 0.5 * skin_;
  }
  if (rebuild) {
    ghosts_.generate(P, cutoff, sph_.gravity);
    neighbours_.build(P.x, P.n_total, P.n_real + P.n_tie, cutoff);  // tie particles query too
    Kokkos::deep_copy(Kokkos::subview(P.x_ref, std::make_pair(0, P.n_real + P.n_tie), Kokkos::ALL),
                      Kokkos::subview(P.x, std::make_pair(0, P.n_real + P.n_tie), Kokkos::ALL));
    ++list_builds_;
  } else {
    ghosts_.sync_kinematics(P);
  }
}

void Simulation::compute_acceleration() {
  Particles& P = particles_;
  for (ViewN<double, 2>* s : {&a_wall_, &a_friction_, &a_boundary_, &a_art_})
    if (static_cast<int>(s->extent(0)) < P.capacity) {
      *s = ViewN<double, 2>("tamp::acceleration_part", P.capacity);
    }
  {
    Timed t(*this, &StepProfile::acceleration);
    Acceleration f(P, neighbours_, pair_gradient_factor_, materials_, sph_, artificial_stress_factors_, wave_speeds_);
    f.a_wall = a_wall_;
    f.a_art = a_art_;
    f.fixed_walls = fixed_walls_ ? 1 : 0;
    f.first_image = P.n_real + P.n_tie;
    if (P.n_tie > 0) f.first_tie = P.n_real;
    Kokkos::parallel_for("tamp::sph::acceleration", real_particles(), f);
  }
  if (fem_ && tie_.count > 0) {
    Timed t(*this, &StepProfile::tie);  // the interface traction from the stresses of both sides
    Kokkos::parallel_for("tamp::tie::traction", Kokkos::RangePolicy<ExecSpace>(0, tie_.count),
                         TieTraction(P, neighbours_, tie_, sph_.h));
    fem::FemMesh& mesh = fem_->mesh();
    Kokkos::deep_copy(mesh.f_tie, 0.0);
    Kokkos::parallel_for("tamp::tie::to_nodes", Kokkos::RangePolicy<ExecSpace>(0, tie_.node_count),
                         TieForceToNodes(tie_, mesh));
  }
  {
    Timed t(*this, &StepProfile::boundaries);
    if (non_reflecting_.count > 0) {
      NonReflectingBoundary f(P, materials_, non_reflecting_, config_.sph.spacing);
      f.a_boundary = a_boundary_;
      Kokkos::parallel_for("tamp::non_reflecting", real_particles(), f);
    }
    if (fixed_walls_) {
      const double dt = dt_ > 0 ? dt_ : 1e-30;  // before the first step: no stick limit
      WallFriction f(P, materials_, ghosts_.planes, config_.sph.spacing, dt);
      f.a_wall = a_wall_;
      f.a_friction = a_friction_;
      Kokkos::parallel_for("tamp::wall_friction", real_particles(), f);
    }
  }
  Timed t(*this, &StepProfile::contact);
  if (body_.active) apply_contact();
}

void Simulation::apply_contact() {
  Particles& P = particles_;
  if (static_cast<int>(contact_force_.extent(0)) < P.capacity)
    contact_force_ = ViewN<double, 2>("tamp::contact_force", P.capacity);
  const double dt = dt_ > 0 ? dt_ : 1e-30;  // before the first step: no stick limit
  PenaltyContact f(P, materials_, body_.state(), contact_law_, dt);
  f.force = contact_force_;
  Kokkos::parallel_for("tamp::contact::penalty", real_particles(), f);
  body_.take_contact(contact_sums(contact_force_, P.v, P.n_real, body_.v_r, body_.v_z), sph_.gravity);
}

void Simulation::set_rigid_body(const RigidProfile& profile, double mass, bool free_r, bool free_z) {
  if (profile.count < 3 || profile.count > max_profile_vertices)
    throw std::invalid_argument("rigid body profile needs 3.." + std::to_string(max_profile_vertices) + " vertices");
  if (!(mass > 0)) throw std::invalid_argument("rigid body mass must be > 0 kg");
  body_.profile = profile;
  body_.profile.finish();
  body_.mass = mass;
  body_.free_r = free_r;
  body_.free_z = free_z;
  body_.active = false;
}

void Simulation::place_body(double r0, double z0, double v_r, double v_z) {
  if (body_.mass <= 0) throw std::logic_error("place_body before set_rigid_body");
  body_.active = true;
  body_.r0 = r0; body_.z0 = z0;
  body_.v_r = v_r; body_.v_z = v_z;
  body_.a_r = body_.a_z = 0.0;
  // The mirror ghosts carry the half-step velocities of the last step; the accelerations here
  // are of the full-step state (as after a restart, which syncs them from the saved one).
  ghosts_.sync_kinematics(particles_);
  compute_acceleration();  // the contact forces (and body acceleration) of the new position
  damp_back_ = 0.0;        // from the full-step velocities
}

Simulation::Added Simulation::add_particles(const std::vector<NewParticle>& list) {
  if (list.empty()) {  // nothing added, nothing renumbered: the identity, so callers can always remap
    Added none;
    none.new_index_of_old.resize(particles_.n_real);
    std::iota(none.new_index_of_old.begin(), none.new_index_of_old.end(), 0);
    return none;
  }
  Particles& P = particles_;
  // The new particles go after the real ones, over the tie particles' slots; the tie
  // particles move up and are refilled from the elements below.
  const int n0 = P.n_real, count = static_cast<int>(list.size());
  const int n1 = n0 + count;
  P.reserve(n1 + P.n_tie + (n1 + P.n_tie) / 2 + 64);
  View1<double> hr_dev("tamp::new_r", count), hz_dev("tamp::new_z", count);
  View1<int> hm_dev("tamp::new_mat", count);
  auto hr = Kokkos::create_mirror_view(hr_dev);
  auto hz = Kokkos::create_mirror_view(hz_dev);
  auto hm = Kokkos::create_mirror_view(hm_dev);
  for (int k = 0; k < count; ++k) {
    if (list[k].material < 0 || list[k].material >= static_cast<int>(materials_host_.size()))
      throw std::invalid_argument("add_particles: unknown material index " + std::to_string(list[k].material));
    if (!(list[k].r >= 0)) throw std::invalid_argument("add_particles: negative radius");
    hr(k) = list[k].r; hz(k) = list[k].z; hm(k) = list[k].material;
  }
  Kokkos::deep_copy(hr_dev, hr);
  Kokkos::deep_copy(hz_dev, hz);
  Kokkos::deep_copy(hm_dev, hm);
  P.fill_new(n0, n1);  // every field at a new particle's value (core/Particles.hpp), then:
  const PlaceNewParticles place(P, n0, hr_dev, hz_dev, hm_dev, materials_, config_.sph);
  Kokkos::parallel_for(
      "tamp::add_particles", Kokkos::RangePolicy<ExecSpace>(0, count), KOKKOS_LAMBDA(int k) {
        double unused = 0;
        place(k, unused);
      });
  // the mass added, summed in a fixed order (the same on any thread count: a reduction's
  // last digit differed between 1 and 2 threads in the CI drop scenario's third charge)
  const auto mass = P.mass;
  const double added = fixed_order_sum<1>("tamp::added_mass", count, KOKKOS_LAMBDA(int k, double* out) {
    out[0] += mass(n0 + k);
  })[0];
  P.n_real = n1;
  P.n_total = n1 + P.n_tie;
  Added result{added, sort_by_cell()};
  result.new_index_of_old.resize(n0);  // the new particles' numbers are of no use to a caller
  if (fem_) {
    sync_tie_kinematics();
    sync_tie_stress();
  }
  rebuild_lists();
  update_pair_stress();
  compute_acceleration();
  damp_back_ = 0.0;  // from the full-step velocities
  return result;
}

namespace {
// The smallest and largest of coordinate c of the particles (a functor, not a lambda: CUDA
// takes no device lambda inside a host lambda).
template <class X>
struct CoordinateExtent {
  X x;
  int c;
  KOKKOS_INLINE_FUNCTION void operator()(int i, Kokkos::MinMax<double>::value_type& e) const {
    e.min_val = math::min(e.min_val, x(i, c));
    e.max_val = math::max(e.max_val, x(i, c));
  }
};
}  // namespace

std::vector<int> Simulation::sort_by_cell() {
  Particles& P = particles_;
  const int n = P.n_real;
  std::vector<int> new_of_old(n);
  if (n == 0) return new_of_old;
  // On the device: each particle's cell key (z row first), made unique by its index
  // (key * n + i), sorted; the order is that of a stable sort by cell, whatever the back end
  // or thread count (the keys are unique, so every sort gives the same order).
  const auto x = P.x;
  using MinMax = Kokkos::MinMax<double>;
  auto extent = [&](int c) {  // of coordinate c (0: r, 1: z) over the real particles
    MinMax::value_type v;
    Kokkos::parallel_reduce("tamp::sort::extent", Kokkos::RangePolicy<ExecSpace>(0, n),
                            CoordinateExtent<decltype(P.x)>{x, c}, MinMax(v));
    return v;
  };
  const MinMax::value_type rr = extent(0), zz = extent(1);
  const double r0 = rr.min_val, z0 = zz.min_val;
  const double cell = 2.0 * sph_.h + skin_;
  const long nr = static_cast<long>((rr.max_val - r0) / cell) + 1;
  const long nz = static_cast<long>((zz.max_val - z0) / cell) + 1;
  if (static_cast<double>(nr) * static_cast<double>(nz) * static_cast<double>(n) > 9.0e18)
    throw std::runtime_error("sort_by_cell: " + std::to_string(nr * nz) + " cells x " + std::to_string(n) +
                             " particles do not fit a 64-bit key");
  View1<long> key("tamp::cell_key", n);
  const long nl = n;
  Kokkos::parallel_for(
      "tamp::sort::keys", Kokkos::RangePolicy<ExecSpace>(0, n), KOKKOS_LAMBDA(int i) {
        const long cell_key = static_cast<long>((x(i, 1) - z0) / cell) * nr + static_cast<long>((x(i, 0) - r0) / cell);
        key(i) = cell_key * nl + i;
      });
  Kokkos::sort(key);
  View1<int> order("tamp::cell_order", n);
  Kokkos::parallel_for(
      "tamp::sort::order", Kokkos::RangePolicy<ExecSpace>(0, n),
      KOKKOS_LAMBDA(int j) { order(j) = static_cast<int>(key(j) % nl); });
  {  // the caller's map of old to new numbers (the tracers follow it)
    auto order_h = Kokkos::create_mirror_view_and_copy(HostSpace(), order);
    for (int j = 0; j < n; ++j) new_of_old[order_h(j)] = j;
  }
  P.permute_real(order);
  for (const auto& part : acceleration_parts())
    if (static_cast<int>(part.second->extent(0)) >= n) permute_rows(*part.second, order, n);
  if (static_cast<int>(a_wall_.extent(0)) >= n) permute_rows(a_wall_, order, n);
  Kokkos::fence();
  rebuild_lists();
  return new_of_old;
}

double Simulation::body_energy() const { return body_.energy(config_.gravity); }

double Simulation::stable_dt() const {
  const Particles& P = particles_;
  double dt = 1e30;
  StableStep s(P, materials_, sph_.h);
  Kokkos::parallel_reduce("tamp::stable_dt", Kokkos::RangePolicy<ExecSpace>(0, P.n_real), s,
                          Kokkos::Min<double>(dt));
  const double dt_sph = config_.run.cfl * dt;
  if (!fem_) return dt_sph;
  // subcycled elements keep their own step (element_substeps); otherwise the smaller rules
  return config_.fem.subcycle && P.n_real > 0 ? dt_sph : std::min(dt_sph, fem_->stable_dt());
}

// Substeps of the elements in a particle step of dt: 1, or with [fem] subcycle the fewest
// that keep each within the elements' stable step.
int Simulation::element_substeps(double dt) const {
  if (!fem_ || !config_.fem.subcycle) return 1;
  const double n = std::ceil(dt / fem_->stable_dt() * (1.0 - 1e-12));
  return static_cast<int>(std::min(1024.0, std::max(1.0, n)));
}

double Simulation::gravity_at(double t) const {
  const double ramp = config_.gravity_ramp;
  return ramp > 0 && t < ramp ? config_.gravity * t / ramp : config_.gravity;
}

// The step to take: dt_override, or the stable step; a collapsed or non-finite step ends the
// run with the worst particle named.
double Simulation::checked_step(double dt_override) const {
  const double dt = dt_override > 0 ? dt_override : stable_dt();
  const double dt_floor = 1e-6 * config_.run.cfl * sph_.h / 1e4;  // far below any soil's step
  if (!(dt > dt_floor) || !std::isfinite(dt)) {
    std::ostringstream msg;
    msg << "time step collapsed to " << dt << " s at t = " << time_ << " s, step " << steps_
        << " (a NaN or an exploding velocity in the particles)";
    // name the worst particle: the first non-finite one, else the fastest
    const ParticleSnapshot snap = snapshot();
    int worst = -1;
    double vmax = -1;
    for (size_t i = 0; i < snap.size(); ++i) {
      const double v2 = snap.v_r[i] * snap.v_r[i] + snap.v_z[i] * snap.v_z[i];
      const bool bad = !std::isfinite(v2) || !std::isfinite(snap.r[i]) || !std::isfinite(snap.s_zz[i]);
      if (bad) { worst = static_cast<int>(i); break; }
      if (v2 > vmax) { vmax = v2; worst = static_cast<int>(i); }
    }
    if (worst >= 0)
      msg << "; worst particle " << worst << " (material " << snap.material[worst] << ") at r = " << snap.r[worst]
          << " m, z = " << snap.z[worst] << " m, v = (" << snap.v_r[worst] << ", " << snap.v_z[worst]
          << ") m/s, density " << snap.density[worst] << " kg/m3";
    throw RunFailure(msg.str());
  }
  return dt;
}

// One leapfrog step, kick-drift-kick (docs/sph.md); the parts the model may not have (tied
// elements, the pounder) are named steps that do nothing without them.
void Simulation::step(double dt_override) {
  double dt;
  {
    Timed t(*this, &StepProfile::other);
    dt = checked_step(dt_override);
  }
  dt_ = dt;
  sph_.gravity = gravity_at(time_ + dt);  // the accelerations below are those at t + dt
  if (fem_) fem_->set_gravity(sph_.gravity);

  first_half_kick(dt);      // v^{n+1/2}, with the accelerations of x^n
  drift(dt);                // x^{n+1}: particles, pounder, element nodes, tie particles
  {
    Timed t(*this, &StepProfile::search);
    refresh_neighbours(false);
  }
  rates_and_stress(dt);     // velocity gradient, density and stress at x^{n+1}
  compute_acceleration();   // forces at x^{n+1}
  second_half_kick(dt);     // v^{n+1}

  if (profiling_) ++profile_.steps;
  time_ += dt;
  ++steps_;
}

void Simulation::first_half_kick(double dt) {
  {
    Timed t(*this, &StepProfile::energy_account);
    account_half_kick(dt, 0.25 * dt);  // the work of every force over this half kick
  }
  Timed t(*this, &StepProfile::kick_drift);
  Kokkos::parallel_for("tamp::kick", real_particles(), Kick(particles_, materials_, 0.5 * dt));
  body_.half_kick(0.5 * dt);
}

void Simulation::drift(double dt) {
  {
    Timed t(*this, &StepProfile::kick_drift);
    body_.drift(dt);
    Kokkos::parallel_for("tamp::drift", real_particles(),
                         Drift(particles_, ghosts_.planes, non_reflecting_, dt, planar_mass_floor(config_.sph)));
  }
  drift_elements(dt);
}


// The tied elements: v^{n+1/2}, x^{n+1} with the forces of x^n (tie forces included); the
// tie particles follow.
void Simulation::drift_elements(double dt) {
  if (!fem_) return;
  {
    Timed t(*this, &StepProfile::fem);
    // Subcycled (Belytschko, Yen & Mullen 1979): substeps of dt/n, each a central-difference
    // step of the elements with the tie forces of x^n held; the last stress update is
    // element_stress's, at x^{n+1}, with the particles'.
    fem_substeps_ = element_substeps(dt);
    const double ds = dt / fem_substeps_;
    for (int k = 0; k < fem_substeps_; ++k) {
      fem_->move_nodes(ds);
      if (k + 1 < fem_substeps_) fem_->update_elements(ds);
    }
  }
  Timed t(*this, &StepProfile::tie);
  sync_tie_kinematics();
}

void Simulation::rates_and_stress(double dt) {
  Particles& P = particles_;
  {
    Timed t(*this, &StepProfile::strain_rate_stress);
    ensure_pair_storage();
    StrainRateAndStress f(P, neighbours_, pair_gradient_factor_, materials_, sph_, dt);
    f.first_image = P.n_real + P.n_tie;
    Kokkos::parallel_for("tamp::sph::strain_rate_stress", real_particles(), f);
  }
  element_stress(dt);
  Timed t(*this, &StepProfile::pair_stress);
  update_pair_stress();
  const int every = config_.sph.regularise_every;
  if (every > 0 && (steps_ + 1) % every == 0) {
    Kokkos::parallel_for("tamp::sph::regularise", real_particles(), StressRegularisation(P, neighbours_, sph_.h));
    const auto reals = std::make_pair(0, P.n_real);
    Kokkos::deep_copy(Kokkos::subview(P.sigma, reals, Kokkos::ALL), Kokkos::subview(P.sigma_tmp, reals, Kokkos::ALL));
    update_pair_stress();
  }
}

// FEM stresses and internal forces at x^{n+1}; the tie particles take the stresses.
void Simulation::element_stress(double dt) {
  if (!fem_) return;
  {
    Timed t(*this, &StepProfile::fem);
    fem_->update_elements(dt / fem_substeps_);
  }
  Timed t(*this, &StepProfile::tie);
  sync_tie_stress();
}

void Simulation::second_half_kick(double dt) {
  {
    Timed t(*this, &StepProfile::kick_drift);
    damp_back_ = 0.5 * dt;  // the damping used v^{n+1/2} = v^{n+1} - dt/2 a^{n+1}
    Kokkos::parallel_for("tamp::kick", real_particles(), Kick(particles_, materials_, 0.5 * dt));
    body_.half_kick(0.5 * dt);
  }
  Timed t(*this, &StepProfile::energy_account);
  account_half_kick(dt, -0.25 * dt);
}

Simulation::Timed::Timed(Simulation& sim, double StepProfile::*part) : sim_(sim), part_(part) {
  if (!sim_.profiling_) return;
  Kokkos::fence();
  start_ = std::chrono::steady_clock::now();
}

Simulation::Timed::~Timed() {
  if (!sim_.profiling_) return;
  Kokkos::fence();
  sim_.profile_.*part_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void Simulation::advance_to(double end_time, const std::function<bool()>& on_step) {
  const long max_steps = config_.run.max_steps;
  while (time_ < end_time * (1.0 - 1e-12)) {
    if (max_steps > 0 && steps_ >= max_steps) break;
    const double dt = std::min(stable_dt(), end_time - time_);
    step(dt > 0 ? dt : 0.0);
    if (on_step && !on_step()) break;
  }
  Kokkos::fence();
}

Energies Simulation::energies() const { return energy_sums(particles_, materials_, config_.gravity); }

ImageWork Simulation::image_work() const {
  const Particles& P = particles_;
  auto w = P.image_work;
  auto m = P.mass;
  std::vector<double> s = fixed_order_sums("tamp::energy::images", P.n_real, 2,
                                           KOKKOS_LAMBDA(int i, double* sum) {
                                             sum[0] += m(i) * w(i, 0);
                                             sum[1] += m(i) * w(i, 1);
                                           });
  return {s[0], s[1]};
}

std::vector<std::pair<const char*, ViewN<double, 2>*>> Simulation::acceleration_parts() {
  return {{"acc_boundary", &a_boundary_}, {"acc_friction", &a_friction_}, {"acc_art", &a_art_},
          {"contact_force", &contact_force_}};
}

void Simulation::account_half_kick(double dt, double shift) {
  const Particles& P = particles_;
  const unsigned count = 5 + static_cast<unsigned>(materials_host_.size());
  std::vector<double> p(count, 0.0);
  const bool contact = body_.active && contact_force_.extent(0) > 0;
  const double ur = body_.kinematic ? body_.v_r : body_.v_r + shift * body_.a_r;
  const double uz = body_.kinematic ? body_.v_z : body_.v_z + shift * body_.a_z;
  EnergyFluxes f(P, materials_, static_cast<unsigned>(materials_host_.size()));
  f.a_boundary = a_boundary_;
  f.a_friction = a_friction_;
  f.contact_force = contact_force_;
  f.a_art = a_art_;
  f.damping = sph_.damping;
  f.shift = shift;
  f.damp_back = damp_back_;
  f.body_ur = ur;
  f.body_uz = uz;
  f.with_boundary = non_reflecting_.count > 0 ? 1 : 0;
  f.with_friction = fixed_walls_ ? 1 : 0;
  f.with_contact = contact ? 1 : 0;
  f.with_art = sph_.artificial_stress_epsilon > 0 ? 1 : 0;
  p = fixed_order_sums("tamp::energy::fluxes", P.n_real, static_cast<int>(count), f);  // same on any thread count
  const double h = 0.5 * dt;  // the half kick
  ledger_.damping_J += h * p[0];
  ledger_.boundary_J += h * p[1];
  ledger_.wall_friction_J += h * p[2];
  contact_energy_ -= h * p[3];
  ledger_.artificial_stress_J += h * p[4];
  for (size_t k = 0; k < ledger_.heat_J.size(); ++k) ledger_.heat_J[k] += h * p[5 + k];
}

std::vector<MaterialEnergy> Simulation::material_energies() const {
  const Particles& P = particles_;
  const size_t nm = materials_host_.size();
  const unsigned count = 4 * static_cast<unsigned>(nm);
  std::vector<double> sums(count, 0.0);
  MaterialEnergies f(P, static_cast<unsigned>(nm), materials_, config_.gravity);
  sums = fixed_order_sums("tamp::energy::materials", P.n_real, static_cast<int>(count), f);
  std::vector<MaterialEnergy> out(nm);
  for (size_t k = 0; k < nm; ++k) out[k] = {sums[4 * k], sums[4 * k + 1], sums[4 * k + 2], sums[4 * k + 3], 0.0};
  if (fem_) {
    const std::vector<fem::FemMaterialEnergy> fe = fem_->material_energies();
    for (size_t j = 0; j < fe.size(); ++j) {
      MaterialEnergy& e = out[fem_deck_material_[j]];
      e.internal += fe[j].internal + fe[j].hourglass;
      e.hourglass += fe[j].hourglass;
      e.elastic += fe[j].elastic;
    }
  }
  return out;
}

ElementNodeEnergy Simulation::element_node_energy() const {
  if (!fem_) return {};
  const fem::FemEnergies e = fem_->energies();
  return {e.kinetic + fem_->potential_energy(config_.gravity), e.boundary_work, e.damping_work, e.tie_work};
}

double Simulation::accounted_energy() const {
  double elements = 0;
  if (fem_) {
    const fem::FemEnergies e = fem_->energies();
    elements = e.kinetic + fem_->potential_energy(config_.gravity) + e.internal + e.hourglass - e.boundary_work -
               e.damping_work;
  }
  const ImageWork images = image_work();
  return energies().total() + elements + body_energy() + contact_energy() - ledger_.damping_J - ledger_.boundary_J -
         ledger_.wall_friction_J - ledger_.artificial_stress_J - images.axis_J - images.walls_J;
}

void Simulation::set_geostatic_stress(double k0) {
  // the layers: the deck's blocks (kernels/Geostatic.hpp)
  GeostaticLayers<> layers;
  layers.n = static_cast<int>(config_.blocks.size());
  layers.layer = LayerView("tamp::geostatic_layers", config_.blocks.size());
  auto layer_h = Kokkos::create_mirror_view(layers.layer);
  for (int k = 0; k < layers.n; ++k) {
    const BlockSpec& b = config_.blocks[k];
    const int mat = std::max(0, material_index(b.material));
    layer_h(k, 0) = b.z_min;
    layer_h(k, 1) = b.z_max;
    layer_h(k, 2) = materials_host_[mat].density * config_.gravity;
  }
  Kokkos::deep_copy(layers.layer, layer_h);
  Particles& P = particles_;
  Kokkos::parallel_for("tamp::geostatic_stress", real_particles(), GeostaticStress(P, materials_, layers, k0));
  if (own_fem_) {  // the deck's elements: the same layered state at their centres
    fem::FemModel& f = *own_fem_;
    f.set_geostatic_stress(layers, k0);
    f.hold_boundary_forces();
    sync_tie_stress();
  }
  hold_boundary_stress();
  update_pair_stress();
  compute_acceleration();
}

void Simulation::hold_boundary_stress() {
  Kokkos::parallel_for("tamp::hold_boundary_stress", real_particles(),
                       HoldBoundaryStress(particles_, non_reflecting_, config_.sph.spacing));
}

void Simulation::prescribe_velocity(const Box& box, double v_r, double v_z) {
  Kokkos::parallel_for("tamp::prescribe_velocity", real_particles(), PrescribeVelocity(particles_, box, v_r, v_z));
}

void Simulation::apply_surface_traction(const Box& box, double t_r, double t_z, double layer,
                                        double face_r) {
  Kokkos::parallel_for("tamp::surface_traction", real_particles(),
                       SurfaceTraction(particles_, box, t_r, t_z, layer, face_r));
  update_pair_stress();
}

namespace {
// Host copies of the first n rows of a view, row-major, into a checkpoint array.
template <class V, class Array>
void put_rows(const V& view, int n, Array& out) {
  auto h = Kokkos::create_mirror_view_and_copy(HostSpace(), view);
  const int w = V::rank == 2 ? static_cast<int>(view.extent(1)) : 1;
  out.width = w;
  out.values.resize(static_cast<size_t>(n) * w);
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < w; ++k) {
      if constexpr (V::rank == 2) out.values[size_t(i) * w + k] = h(i, k);
      else out.values[i] = h(i);
    }
}
template <class V, class Array>
void get_rows(const Array& in, const std::string& name, const V& view, int n) {
  const int w = V::rank == 2 ? static_cast<int>(view.extent(1)) : 1;
  if (in.width != w || in.values.size() != static_cast<size_t>(n) * w)
    throw std::invalid_argument("checkpoint field '" + name + "' has " + std::to_string(in.values.size()) +
                                " values of width " + std::to_string(in.width) + "; this deck needs " +
                                std::to_string(n) + " x " + std::to_string(w));
  auto h = Kokkos::create_mirror_view_and_copy(HostSpace(), view);
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < w; ++k) {
      if constexpr (V::rank == 2) h(i, k) = in.values[size_t(i) * w + k];
      else h(i) = in.values[i];
    }
  Kokkos::deep_copy(view, h);
}
}  // namespace

void Simulation::rebuild_lists() {
  refresh_neighbours(true);
  ensure_pair_storage();
  // the pair kernel factors follow the new list (compute_acceleration reads them)
  Kokkos::parallel_for("tamp::sph::pair_kernel", Kokkos::RangePolicy<ExecSpace>(0, particles_.n_real),
                       PairKernelFactors(particles_, neighbours_, pair_gradient_factor_, sph_.h));
}

// The state that continues the run exactly (docs/output.md, "Restarts"). Saving changes
// nothing in the run: the neighbour list is not rebuilt here; the checkpoint holds where
// it was built (x_ref), and load_state rebuilds it there.
Checkpoint Simulation::save_state() {
  const Particles& P = particles_;
  const int n = P.n_real;
  Checkpoint c;
  // the fields core/Particles.hpp declares checkpointed
  particles_.for_each_field([&](const FieldInfo& f, auto& view, auto) {
    if (f.checkpoint == FieldCheckpoint::NotSaved) return;
    if constexpr (std::is_same_v<typename std::decay_t<decltype(view)>::value_type, int>)
      put_rows(view, n, c.ints[f.name]);
    else
      put_rows(view, n, c.reals[f.name]);
  });
  c.scalars["time"] = time_;
  c.scalars["steps"] = static_cast<double>(steps_);
  c.scalars["particles"] = n;
  c.scalars["damping"] = sph_.damping;
  c.scalars["body_active"] = body_.active ? 1.0 : 0.0;
  c.scalars["body_r0"] = body_.r0;
  c.scalars["body_z0"] = body_.z0;
  c.scalars["body_v_r"] = body_.v_r;
  c.scalars["body_v_z"] = body_.v_z;
  c.scalars["body_a_r"] = body_.a_r;
  c.scalars["body_a_z"] = body_.a_z;
  c.scalars["contact_energy"] = contact_energy_;
  c.scalars["damp_back"] = damp_back_;
  // the parts of the stored accelerations that the energy account of the next half kick reads
  for (const auto& [name, view] : acceleration_parts())
    if (static_cast<int>(view->extent(0)) >= n) put_rows(*view, n, c.reals[name]);
  c.scalars["last_dt"] = dt_;
  c.scalars["ledger_damping"] = ledger_.damping_J;
  c.scalars["ledger_boundary"] = ledger_.boundary_J;
  c.scalars["ledger_wall_friction"] = ledger_.wall_friction_J;
  c.scalars["ledger_artificial_stress"] = ledger_.artificial_stress_J;
  c.reals["ledger_heat"].values = ledger_.heat_J;
  c.reals["ledger_heat"].width = 1;

  if (fem_) {  // the tied elements: node motion, element state, the held boundary forces
    const fem::FemMesh& m = fem_->mesh();
    put_rows(m.x, m.n_nodes, c.reals["fem_x"]);
    put_rows(m.v, m.n_nodes, c.reals["fem_v"]);
    put_rows(m.f_hold, m.n_nodes, c.reals["fem_f_hold"]);
    put_rows(m.f_tie, m.n_nodes, c.reals["fem_f_tie"]);  // of the stored accelerations' state
    put_rows(m.stress, m.n_elements, c.reals["fem_stress"]);
    put_rows(m.strain_rate, m.n_elements, c.reals["fem_strain_rate"]);
    put_rows(m.plastic_strain, m.n_elements, c.reals["fem_plastic_strain"]);
    put_rows(m.compaction, m.n_elements, c.reals["fem_compaction"]);
    put_rows(m.history, m.n_elements, c.reals["fem_history"]);
    put_rows(m.hourglass_force, m.n_elements, c.reals["fem_hourglass_force"]);
    put_rows(m.internal_energy, m.n_elements, c.reals["fem_internal_energy"]);
    put_rows(m.hourglass_energy, m.n_elements, c.reals["fem_hourglass_energy"]);
    put_rows(m.node_work, m.n_nodes, c.reals["fem_node_work"]);
    c.scalars["fem_time"] = fem_->time();
    c.scalars["fem_steps"] = static_cast<double>(fem_->steps());
    c.scalars["fem_last_dt"] = fem_->last_dt();
    // where the tie particles stood at the last list build (the rows after the real ones)
    const auto ties = Kokkos::subview(particles_.x_ref, std::make_pair(n, n + particles_.n_tie), Kokkos::ALL);
    ViewN<double, 2> tie_ref("tamp::tie_x_ref", particles_.n_tie);
    Kokkos::deep_copy(tie_ref, ties);
    put_rows(tie_ref, particles_.n_tie, c.reals["tie_x_ref"]);
  }
  return c;
}

void Simulation::load_state(const Checkpoint& c) {
  Particles& P = particles_;
  const int n = P.n_real;
  auto scalar = [&](const char* name) {
    auto it = c.scalars.find(name);
    if (it == c.scalars.end()) throw std::invalid_argument(std::string("checkpoint has no '") + name + "'");
    return it->second;
  };
  // Backfill adds particles: a checkpoint may hold more than the deck makes, never fewer.
  const int n_saved = static_cast<int>(scalar("particles"));
  if (n_saved < n)
    throw std::invalid_argument("checkpoint has " + std::to_string(n_saved) +
                                " particles; the deck makes " + std::to_string(n));
  if (n_saved > n) {
    P.reserve(n_saved + P.n_tie + (n_saved + P.n_tie) / 2 + 64);
    P.n_real = n_saved;
    P.n_total = n_saved + P.n_tie;
    Kokkos::deep_copy(P.hoop_factor, 1.0);
    Kokkos::deep_copy(P.art_stress, 0.0);
  }
  const int n_new = n_saved;
  auto real = [&](const char* name) -> const Checkpoint::Real& {
    auto it = c.reals.find(name);
    if (it == c.reals.end()) throw std::invalid_argument(std::string("checkpoint has no field '") + name + "'");
    return it->second;
  };
  auto integer = [&](const char* name) -> const Checkpoint::Int& {
    auto it = c.ints.find(name);
    if (it == c.ints.end()) throw std::invalid_argument(std::string("checkpoint has no field '") + name + "'");
    return it->second;
  };
  // the fields core/Particles.hpp declares checkpointed; an optional one missing from an
  // older checkpoint takes a new particle's value
  P.for_each_field([&](const FieldInfo& f, auto& view, auto value) {
    if (f.checkpoint == FieldCheckpoint::NotSaved) return;
    constexpr bool is_int = std::is_same_v<typename std::decay_t<decltype(view)>::value_type, int>;
    const bool present = is_int ? c.ints.count(f.name) > 0 : c.reals.count(f.name) > 0;
    if (!present && f.checkpoint == FieldCheckpoint::SavedOptional) {
      Kokkos::deep_copy(view, value);
      return;
    }
    if constexpr (is_int) get_rows(integer(f.name), f.name, view, n_new);
    else get_rows(real(f.name), f.name, view, n_new);
  });
  if (!c.reals.count("x_hold")) hold_boundary_stress();  // a checkpoint from before the springs: hold them here
  time_ = scalar("time");
  steps_ = static_cast<long>(scalar("steps"));
  sph_.gravity = gravity_at(time_);
  auto optional = [&](const char* name, double fallback) {
    auto it = c.scalars.find(name);
    return it == c.scalars.end() ? fallback : it->second;
  };
  sph_.damping = optional("damping", sph_.damping);
  body_.active = optional("body_active", 0.0) != 0.0;
  if (body_.active && body_.mass <= 0)
    throw std::invalid_argument("checkpoint has a rigid body in the model; this deck defines none");
  body_.r0 = optional("body_r0", 0.0);
  body_.z0 = optional("body_z0", 0.0);
  body_.v_r = optional("body_v_r", 0.0);
  body_.v_z = optional("body_v_z", 0.0);
  body_.a_r = optional("body_a_r", 0.0);
  body_.a_z = optional("body_a_z", 0.0);
  contact_energy_ = optional("contact_energy", 0.0);
  damp_back_ = optional("damp_back", 0.0);
  {
    for (const auto& [name, view] : acceleration_parts()) {
      if (static_cast<int>(view->extent(0)) < P.capacity) *view = ViewN<double, 2>("tamp::acceleration_part", P.capacity);
      if (c.reals.count(name)) get_rows(real(name), name, *view, n_new);
      else Kokkos::deep_copy(*view, 0.0);
    }
  }
  dt_ = optional("last_dt", 0.0);
  ledger_.damping_J = optional("ledger_damping", 0.0);
  ledger_.boundary_J = optional("ledger_boundary", 0.0);
  ledger_.wall_friction_J = optional("ledger_wall_friction", 0.0);
  ledger_.artificial_stress_J = optional("ledger_artificial_stress", 0.0);
  if (c.reals.count("ledger_heat") && c.reals.at("ledger_heat").values.size() == ledger_.heat_J.size())
    ledger_.heat_J = c.reals.at("ledger_heat").values;

  refresh_planar_mass();
  if (fem_) {
    if (!c.reals.count("fem_x")) throw std::invalid_argument("checkpoint has no element state; this deck ties elements ([fem])");
    fem::FemMesh& m = fem_->mesh();
    get_rows(real("fem_x"), "fem_x", m.x, m.n_nodes);
    get_rows(real("fem_v"), "fem_v", m.v, m.n_nodes);
    get_rows(real("fem_f_hold"), "fem_f_hold", m.f_hold, m.n_nodes);
    get_rows(real("fem_f_tie"), "fem_f_tie", m.f_tie, m.n_nodes);
    get_rows(real("fem_stress"), "fem_stress", m.stress, m.n_elements);
    get_rows(real("fem_strain_rate"), "fem_strain_rate", m.strain_rate, m.n_elements);
    get_rows(real("fem_plastic_strain"), "fem_plastic_strain", m.plastic_strain, m.n_elements);
    get_rows(real("fem_compaction"), "fem_compaction", m.compaction, m.n_elements);
    if (c.reals.count("fem_history")) get_rows(real("fem_history"), "fem_history", m.history, m.n_elements);
    else Kokkos::deep_copy(m.history, 0.0);  // a checkpoint from before the models' history slots
    get_rows(real("fem_hourglass_force"), "fem_hourglass_force", m.hourglass_force, m.n_elements);
    get_rows(real("fem_internal_energy"), "fem_internal_energy", m.internal_energy, m.n_elements);
    get_rows(real("fem_hourglass_energy"), "fem_hourglass_energy", m.hourglass_energy, m.n_elements);
    if (c.reals.count("fem_node_work")) get_rows(real("fem_node_work"), "fem_node_work", m.node_work, m.n_nodes);
    else Kokkos::deep_copy(m.node_work, 0.0);  // a checkpoint from before the elements' energy account
    fem_->set_damping(sph_.damping);
    fem_->set_gravity(sph_.gravity);
    fem_->restore_clock(scalar("fem_time"), static_cast<long>(scalar("fem_steps")), scalar("fem_last_dt"));
    fem_->compute_forces(0.0);
    sync_tie_kinematics();
    sync_tie_stress();
  } else if (c.reals.count("fem_x")) {
    throw std::invalid_argument("checkpoint holds elements ([fem]); this deck has none");
  }
  // The neighbour list as the saved run had it: built where the particles stood at its last
  // build (x_ref; a checkpoint from before x_ref was saved: here). The same ghosts and pairs
  // in the same order, so the restarted run sums as the saved one would have. The pair
  // quantities of the restored state follow; the stored accelerations are kept (they were
  // computed with the half-step velocities, which a full-step state cannot reproduce).
  {
    const auto reals = std::make_pair(0, n_new), ties = std::make_pair(n_new, n_new + P.n_tie);
    if (!c.reals.count("x_ref"))
      Kokkos::deep_copy(Kokkos::subview(P.x_ref, reals, Kokkos::ALL), Kokkos::subview(P.x, reals, Kokkos::ALL));
    if (P.n_tie > 0) {
      if (c.reals.count("tie_x_ref")) {
        ViewN<double, 2> tie_ref("tamp::tie_x_ref", P.n_tie);
        get_rows(real("tie_x_ref"), "tie_x_ref", tie_ref, P.n_tie);
        Kokkos::deep_copy(Kokkos::subview(P.x_ref, ties, Kokkos::ALL), tie_ref);
      } else {
        Kokkos::deep_copy(Kokkos::subview(P.x_ref, ties, Kokkos::ALL), Kokkos::subview(P.x, ties, Kokkos::ALL));
      }
    }
  }
  rebuild_lists_at_reference();
  update_pair_stress();
}

// The ghosts and the neighbour list built at x_ref (for a restart), then the particles back
// at x: what refresh_neighbours built when they stood there.
void Simulation::rebuild_lists_at_reference() {
  Particles& P = particles_;
  const int m = P.n_real + P.n_tie;
  const auto rows = std::make_pair(0, m);
  ViewN<double, 2> now("tamp::x_now", m);
  Kokkos::deep_copy(now, Kokkos::subview(P.x, rows, Kokkos::ALL));
  Kokkos::deep_copy(Kokkos::subview(P.x, rows, Kokkos::ALL), Kokkos::subview(P.x_ref, rows, Kokkos::ALL));
  refresh_neighbours(true);  // copies x (= x_ref) into x_ref: unchanged
  Kokkos::deep_copy(Kokkos::subview(P.x, rows, Kokkos::ALL), now);
  ghosts_.sync_kinematics(P);
  ensure_pair_storage();
  Kokkos::parallel_for("tamp::sph::pair_kernel", Kokkos::RangePolicy<ExecSpace>(0, P.n_real),
                       PairKernelFactors(P, neighbours_, pair_gradient_factor_, sph_.h));
}

void Simulation::refresh_planar_mass() {
  Kokkos::parallel_for("tamp::planar_mass", real_particles(), PlanarMass(particles_, config_.sph));
}

ParticleSnapshot Simulation::snapshot() const {
  const Particles& P = particles_;
  const int n = P.n_real;
  auto hx = Kokkos::create_mirror_view_and_copy(HostSpace(), P.x);
  auto hv = Kokkos::create_mirror_view_and_copy(HostSpace(), P.v);
  auto hs = Kokkos::create_mirror_view_and_copy(HostSpace(), P.sigma);
  auto hrho = Kokkos::create_mirror_view_and_copy(HostSpace(), P.rho);
  auto hep = Kokkos::create_mirror_view_and_copy(HostSpace(), P.plastic_strain);
  auto hu = Kokkos::create_mirror_view_and_copy(HostSpace(), P.internal_energy);
  auto hm = Kokkos::create_mirror_view_and_copy(HostSpace(), P.mass);
  auto hmat = Kokkos::create_mirror_view_and_copy(HostSpace(), P.material);
  ParticleSnapshot s;
  s.step = steps_;
  s.time = time_;
  auto take = [n](auto&& f, auto& out) {
    out.resize(n);
    for (int i = 0; i < n; ++i) out[i] = f(i);
  };
  take([&](int i) { return hx(i, 0); }, s.r);
  take([&](int i) { return hx(i, 1); }, s.z);
  take([&](int i) { return hv(i, 0); }, s.v_r);
  take([&](int i) { return hv(i, 1); }, s.v_z);
  take([&](int i) { return hrho(i); }, s.density);
  take([&](int i) { return hs(i, 0); }, s.s_rr);
  take([&](int i) { return hs(i, 1); }, s.s_zz);
  take([&](int i) { return hs(i, 2); }, s.s_tt);
  take([&](int i) { return hs(i, 3); }, s.s_rz);
  take([&](int i) { return hep(i); }, s.plastic_strain);
  take([&](int i) { return hu(i); }, s.internal_energy);
  take([&](int i) { return hm(i); }, s.mass);
  take([&](int i) { return hmat(i); }, s.material);
  if (fem_) {
    const fem::FemMesh& m = fem_->mesh();
    auto nx = Kokkos::create_mirror_view_and_copy(HostSpace(), m.x);
    auto conn = Kokkos::create_mirror_view_and_copy(HostSpace(), m.conn);
    auto st = Kokkos::create_mirror_view_and_copy(HostSpace(), m.stress);
    auto ep = Kokkos::create_mirror_view_and_copy(HostSpace(), m.plastic_strain);
    ElementSnapshot& e = s.elements;
    for (int i = 0; i < m.n_nodes; ++i) {
      e.node_r.push_back(nx(i, 0));
      e.node_z.push_back(nx(i, 1));
    }
    for (int k = 0; k < m.n_elements; ++k) {
      for (int q = 0; q < 4; ++q) e.connectivity.push_back(conn(k, q));
      e.s_rr.push_back(st(k, 0)); e.s_zz.push_back(st(k, 1)); e.s_tt.push_back(st(k, 2)); e.s_rz.push_back(st(k, 3));
      e.plastic_strain.push_back(ep(k));
      e.material.push_back(fem_deck_material_[fem_->element_material(k)]);
    }
  }
  return s;
}

}  // namespace tamp

namespace tamp {

void Simulation::sync_tie_kinematics() {
  Particles& P = particles_;
  const fem::FemMesh& mesh = fem_->mesh();
  Kokkos::parallel_for("tamp::tie::kinematics", Kokkos::RangePolicy<ExecSpace>(0, tie_.count),
                       SyncTieKinematics(P, tie_, mesh, planar_mass_floor(config_.sph)));
}

void Simulation::sync_tie_stress() {
  Particles& P = particles_;
  const fem::FemMesh& mesh = fem_->mesh();
  Kokkos::parallel_for("tamp::tie::stress", Kokkos::RangePolicy<ExecSpace>(0, tie_.count),
                       SyncTieStress(P, tie_, mesh));
}

void Simulation::tie_fem(fem::FemModel& fem, const std::vector<std::string>& fem_materials) {
  if (fem_) throw std::logic_error("tie_fem: already tied to an FEM mesh");
  if (fem_materials.size() != fem.materials().size())
    throw std::invalid_argument("tie_fem: give one deck material per FEM material (" +
                                std::to_string(fem.materials().size()) + ")");
  std::vector<int> sph_mat;
  for (const std::string& name : fem_materials) {
    const int mat = material_index(name);
    if (mat < 0) throw std::invalid_argument("tie_fem: material '" + name + "' is not in the deck");
    sph_mat.push_back(mat);
  }
  fem_deck_material_ = sph_mat;
  Particles& P = particles_;
  fem.compute_forces(0.0);  // element volumes at the current positions
  const double band = 2.0 * sph_.h + skin_ + config_.sph.spacing;  // the kernel reach, with a margin for motion
  tie_ = build_tie_particles(fem, sph_mat, ParticleSurvey(P, config_.sph.spacing), config_.sph.spacing, band, &tie_edges_);

  const int n = tie_.count;
  fem_ = &fem;
  P.reserve(P.n_real + n + (P.n_total - P.n_real) + 64);
  P.n_tie = n;
  P.n_total = P.n_real + n;
  sync_tie_kinematics();
  sync_tie_stress();
  rebuild_lists();
  update_pair_stress();
  compute_acceleration();  // also the first tie forces on the FEM
}

}  // namespace tamp
