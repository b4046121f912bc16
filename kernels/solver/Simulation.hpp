// The host driver of one SPH model: builds particles from a Config, then steps it in
// time. It only sequences kernels (kernels/) and holds state; physics lives in kernels
// and models.
#pragma once
#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>
#include "core/Config.hpp"
#include "core/Material.hpp"
#include "core/Output.hpp"
#include "core/Particles.hpp"
#include "kernels/BoundaryLoads.hpp"
#include "kernels/FemMeshGenerator.hpp"
#include "kernels/FemModel.hpp"
#include "kernels/EnergyAccount.hpp"
#include "kernels/Geostatic.hpp"
#include "kernels/ParticleGenerator.hpp"
#include "kernels/Integrate.hpp"
#include "kernels/Measurements.hpp"
#include "kernels/Mirror.hpp"
#include "kernels/NeighbourList.hpp"
#include "kernels/RigidContact.hpp"
#include "kernels/SphSolid.hpp"
#include "kernels/Tie.hpp"
#include "kernels/TieConstruction.hpp"
#include "kernels/WallFriction.hpp"
#include "core/MaterialModel.hpp"

namespace tamp {

// A particle to add (backfill): position (m) and material index; density is the material's.
struct NewParticle {
  double r, z;
  int material;
};

// Wall time of the parts of a step (s), summed over the steps taken while profiling is on
// (Simulation::set_profiling, `tamp run --profile`). Each part ends with a fence, so
// profiling slows a run a little.
struct StepProfile {
  double search = 0;             // neighbour lists and mirror ghosts
  double kick_drift = 0;         // half kicks and drift of particles and pounder
  double energy_account = 0;     // the work of every force per half kick (two reductions)
  double strain_rate_stress = 0; // velocity gradient, density, constitutive update
  double pair_stress = 0;        // m sigma / rho^2 per particle (and Shepard regularisation)
  double acceleration = 0;       // the pair force sum
  double boundaries = 0;         // non-reflecting boundaries and fixed-wall friction
  double contact = 0;            // pounder <-> particle contact
  double fem = 0;                // FEM node update and element pass (tied FEM)
  double tie = 0;                // tie particles' kinematics and stress, interface traction
  double other = 0;              // the stable time step
  long steps = 0;
  // The particle parts together.
  double sph() const {
    return kick_drift + energy_account + strain_rate_stress + pair_stress + acceleration + boundaries + contact;
  }
  double total() const { return sph() + search + fem + tie + other; }
  // (name, member) of every part, in the order of a step.
  static std::vector<std::pair<const char*, double StepProfile::*>> parts() {
    return {{"search", &StepProfile::search},           {"kick_drift", &StepProfile::kick_drift},
            {"energy_account", &StepProfile::energy_account}, {"strain_rate_stress", &StepProfile::strain_rate_stress},
            {"pair_stress", &StepProfile::pair_stress}, {"acceleration", &StepProfile::acceleration},
            {"boundaries", &StepProfile::boundaries},   {"contact", &StepProfile::contact},
            {"fem", &StepProfile::fem},                 {"tie", &StepProfile::tie},
            {"time_step", &StepProfile::other}};
  }
};

// Work done on the real particles since the start (J; < 0: energy taken out of them) by the
// forces outside the closed SPH system, summed kick by kick (kernels/EnergyAccount.hpp).
// heat_J[k] is the artificial-viscosity heat of material k, already part of the internal
// energy. (The contact's share is Simulation::contact_energy.)
struct EnergyLedger {
  double damping_J = 0;        // mass-proportional damping (rest and settling phases)
  double boundary_J = 0;       // non-reflecting boundaries: radiated (dashpots) + springs
  double wall_friction_J = 0;  // friction of the fixed walls
  double artificial_stress_J = 0;  // the artificial stress (a numerical force inside the soil)
  std::vector<double> heat_J;  // per material
};

// What the pairs with mirror images gave the real particles since the start, J: their stress
// terms are not energy-conjugate (numerical; kernels/SphSolid.hpp, docs/sph.md).
struct ImageWork {
  double axis_J = 0, walls_J = 0;
};

// Energies of the real particles of one material, J (kernels/EnergyAccount.hpp).
struct MaterialEnergy {
  double kinetic = 0, internal = 0, potential = 0, elastic = 0;
  double hourglass = 0;  // the tied elements' hourglass work (part of internal)
};

// Energies of the tied elements' nodes, J: kinetic + gravitational, and the work the
// non-reflecting boundary, the mass damping and the particles (through the tie) did on them.
struct ElementNodeEnergy {
  double motion = 0, boundary_work = 0, damping_work = 0, tie_work = 0;
};

// Thrown when the run cannot go on (NaN, collapsing time step): the message says what and where.
struct RunFailure : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class Simulation {
 public:
  explicit Simulation(const Config& config);

  // One leapfrog step with the stable time step (or `dt_override` if > 0).
  void step(double dt_override = 0.0);
  // Steps until time >= end_time (or max_steps); `on_step` runs after every step and may
  // return false to stop early.
  void advance_to(double end_time, const std::function<bool()>& on_step = {});

  double time() const { return time_; }
  // Moves the clock on by dt without a step: nothing moves. The drop sequence's ballistic
  // flight uses it and places the body itself.
  void skip_time(double dt) {
    time_ += dt;
    sph_.gravity = gravity_at(time_);
  }
  long steps() const { return steps_; }
  double last_dt() const { return dt_; }
  double stable_dt() const;
  // Element substeps in a particle step of dt (1 unless [fem] subcycle).
  int element_substeps(double dt) const;
  double gravity_at(double t) const;  // m/s2, with the deck's linear ramp
  double smoothing_length() const { return sph_.h; }
  double spacing() const { return config_.sph.spacing; }
  int particle_count() const { return particles_.n_real; }
  // The real particles binned for measurements (kernels/Measurements.hpp).
  ParticleSurvey survey() const { return ParticleSurvey(particles_, config_.sph.spacing); }
  int ghost_count() const { return ghosts_.ghost_count(); }
  long neighbour_list_builds() const { return list_builds_; }
  double mean_neighbours() const { return double(neighbours_.pair_count()) / particles_.n_real; }
  const Config& config() const { return config_; }
  Particles& particles() { return particles_; }
  const std::vector<MaterialParams>& materials() const { return materials_host_; }
  int material_index(const std::string& name) const;  // index in the deck's materials, -1: none

  Energies energies() const;
  // The energy the mirror images' pairs gave the real particles (Particles::image_work).
  ImageWork image_work() const;
  // Per deck material: kinetic, internal, gravitational and elastic strain energy; with
  // tied elements, their stress work, hourglass work and elastic energy are added to their
  // deck material (the nodes' motion is element_node_energy()).
  std::vector<MaterialEnergy> material_energies() const;
  ElementNodeEnergy element_node_energy() const;
  const EnergyLedger& ledger() const { return ledger_; }
  // The energy of the whole model, which stays constant up to time-integration error:
  // particles (kinetic + internal + potential) + body + contact, minus the work the
  // damping, the non-reflecting boundaries, the wall friction and the artificial stress did
  // on the particles; with tied elements also their energies, less the work their
  // boundary and damping did (the tie's work is internal to the whole).
  double accounted_energy() const;

  // The rigid body: set its shape and mass once, then place / remove it.
  void set_rigid_body(const RigidProfile& profile, double mass, bool free_r = false, bool free_z = true);
  void place_body(double r0, double z0, double v_r, double v_z);
  void remove_body() { body_.active = false; }
  void set_body_kinematic(bool k) { body_.kinematic = k; }
  const RigidBody& body() const { return body_; }
  // Kinetic + gravitational energy of the body (J, potential relative to z0 = 0; 0 when out).
  double body_energy() const;
  // Energy taken up by the contact so far (stored in the penalty springs + dissipated by
  // friction and contact damping), J: minus the time integral of sum F_i . (v_i - V).
  double contact_energy() const { return contact_energy_; }

  // Mass-proportional damping (1/s) from now on (the deck's value at the start).
  void set_damping(double d) {
    sph_.damping = d;
    if (fem_) fem_->set_damping(d);
  }
  double damping() const { return sph_.damping; }

  // Appends particles at rest with zero stress, each of ring mass rho 2 pi r dp^2, puts
  // every real particle in cell order again (sort_by_cell) and rebuilds the lists.
  struct Added {
    double mass_kg = 0;                 // the mass added
    std::vector<int> new_index_of_old;  // the renumbering of the particles that were there
  };
  Added add_particles(const std::vector<NewParticle>& list);
  // Renumbers the real particles in the order of the cells (2h + skin wide, rows of r in
  // z, each cell in the old order) so that the pair loops read neighbours close in
  // memory: new particles are appended, and flow scrambles the order over the blows.
  // The state is only renumbered (accelerations and their parts too); the lists are
  // rebuilt. Returns the new index of every old particle.
  std::vector<int> sort_by_cell();
  ParticleSnapshot snapshot() const;

  // The full restartable state of the real particles (positions, velocities, the
  // accelerations of the last half-kick, stresses, histories, loads) and the clock. Also
  // rebuilds the neighbour list and ghosts now, so that a run restarted from this state
  // and this run continue from identical lists: restarts reproduce the uninterrupted run
  // bit for bit on a deterministic back end.
  Checkpoint save_state();
  // Replaces the particle state and clock by a checkpoint of a run of the same deck
  // (same particle count); throws std::invalid_argument naming what does not match.
  void load_state(const Checkpoint& c);
  // Planar masses m / (2 pi r) of the real particles from their ring masses and radii.
  void refresh_planar_mass();

  // Initial geostatic stress for horizontally layered blocks: sigma_zz = -(weight of the
  // blocks above the particle per unit area) with the deck's gravity, sigma_rr = sigma_tt
  // = k0 sigma_zz, where k0 < 0 means nu / (1 - nu) of each particle's material. The
  // state still needs a short dynamic relaxation (SPH is not in exact discrete equilibrium).
  void set_geostatic_stress(double k0 = -1.0);

  // Records, on the particles next to each non-reflecting boundary, the traction sigma.n
  // that the removed far field exerts now, and keeps it as a constant load (the dashpots
  // act on top of it). Called by set_geostatic_stress; call it after setting another
  // initial stress by hand.
  void hold_boundary_stress();

  // Ties the particles to an FEM mesh along every element edge on the mesh's boundary with
  // particles just beyond it (docs/coupling.md): from now on step() advances both in one
  // time loop with the smaller stable step. fem_materials[k] names the deck material of the
  // mesh's material k (the tie particles take it). The FEM model must outlive the tie.
  void tie_fem(fem::FemModel& fem, const std::vector<std::string>& fem_materials);
  int tie_particle_count() const { return tie_.count; }
  int tie_edge_count() const { return tie_edges_; }
  // The tied FEM mesh (the deck's [fem] one or one given to tie_fem), or nullptr.
  fem::FemModel* fem() { return fem_; }
  const fem::FemModel* fem() const { return fem_; }

  // Per-part wall times of the steps (perf); off by default (it adds fences).
  void set_profiling(bool on) { profiling_ = on; profile_ = StepProfile{}; }
  const StepProfile& profile() const { return profile_; }

  // Particles inside `box` take the velocity (v_r, v_z) from now on (m/s).
  void prescribe_velocity(const Box& box, double v_r, double v_z);
  // A surface traction (t_r, t_z) in Pa on the particles in `box`, which form a boundary
  // layer of thickness `layer` (m). `face_r` > 0: the loaded face is the cylinder r =
  // face_r (the force on the ring is t * 2 pi face_r * dz); otherwise a face z = const.
  void apply_surface_traction(const Box& box, double t_r, double t_z, double layer, double face_r = -1.0);

 private:
  void build_materials();
  void build_particles();
  void refresh_neighbours(bool force);
  void rebuild_lists();  // forced neighbour rebuild + pair kernel factors
  void rebuild_lists_at_reference();  // the same, as built at x_ref (a restart)
  void compute_acceleration();
  void ensure_pair_storage();
  void update_pair_stress();

  Config config_;
  SphParams sph_;
  std::vector<MaterialParams> materials_host_;
  Kokkos::View<MaterialParams*, MemSpace> materials_;
  Kokkos::View<double*, MemSpace> wave_speeds_;  // m/s, per material (MaterialParams::wave_speed)
  Particles particles_;
  MirrorGhosts ghosts_;
  MirrorPlanes non_reflecting_;  // boundaries with Lysmer dashpots (no mirror particles)
  NeighbourList neighbours_;
  Kokkos::View<double*, MemSpace> artificial_stress_factors_;  // artificial-stress factor against q
  View1<double> pair_gradient_factor_;  // (dW/dr)/r per listed pair, written by the strain-rate loop
  ViewN<double, 2> contact_force_;  // per particle ring, N
  // Parts of the acceleration kept apart for the wall friction and the energy account
  ViewN<double, 2> a_wall_, a_friction_, a_boundary_, a_art_;
  // The parts the energy account of the next half kick reads, by checkpoint name.
  std::vector<std::pair<const char*, ViewN<double, 2>*>> acceleration_parts();
  bool fixed_walls_ = false;  // a fixed (rough) wall: WallFriction runs
  EnergyLedger ledger_;
  double damp_back_ = 0;  // half the step of the last acceleration (its damping used v - damp_back a)
  // The energy account of one half kick of length dt/2 with mid-kick velocities v + shift a.
  void account_half_kick(double dt, double shift);
  bool profiling_ = false;
  StepProfile profile_;
  // Adds the wall time of its scope to one part of the profile (when profiling).
  class Timed {
   public:
    Timed(Simulation& sim, double StepProfile::*part);
    ~Timed();
    Timed(const Timed&) = delete;
    Timed& operator=(const Timed&) = delete;
   private:
    Simulation& sim_;
    double StepProfile::*part_;
    std::chrono::steady_clock::time_point start_;
  };
  // The named parts of step(): the scheme of docs/sph.md.
  double checked_step(double dt_override) const;
  void first_half_kick(double dt);
  void drift(double dt);
  void drift_elements(double dt);
  void rates_and_stress(double dt);
  void element_stress(double dt);
  void second_half_kick(double dt);
  Kokkos::RangePolicy<ExecSpace> real_particles() const { return Kokkos::RangePolicy<ExecSpace>(0, particles_.n_real); }
  fem::FemModel* fem_ = nullptr;  // tied FEM mesh, or none
  int fem_substeps_ = 1;          // element substeps in the current particle step ([fem] subcycle)
  std::unique_ptr<fem::FemModel> own_fem_;  // the deck's [fem] mesh (fem_ points to it)
  void build_fem();
  double spring_distance(const WallSpec& w, int axis, int side) const;
  TieParticles tie_;
  int tie_edges_ = 0;
  std::vector<int> fem_deck_material_;  // FEM material -> deck material index
  void sync_tie_kinematics();
  void sync_tie_stress();
  RigidBody body_;
  ContactLaw contact_law_;
  double contact_energy_ = 0;
  void apply_contact();
  double skin_ = 0;
  double time_ = 0, dt_ = 0;
  long steps_ = 0, list_builds_ = 0;
};

}  // namespace tamp
