// The validated content of an input deck (TOML). Produced by load_deck() in Deck.cpp, or
// filled in directly by tests and scenarios. SI units throughout.
#pragma once
#include <map>
#include <string>
#include <vector>

namespace tamp {

struct RunSpec {
  std::string name = "tamp";
  double end_time = 0.1;          // s, simulated time
  double output_interval = 0.0;   // s between HDF5 snapshots; 0 = final state only
  double cfl = 0.3;               // Courant number, (0, 1]
  double progress_interval = 2.0; // s of wall time between progress lines
  long max_steps = 0;             // 0 = unlimited
};

struct SphSpec {
  double spacing = 0.01;          // m, initial particle spacing dp
  double h_factor = 1.5;          // h = h_factor * spacing, kernel support 2h (Wendland C2);
                                  // 1.3 left a 2.5 % lattice error in geostatic stresses
  double alpha = 0.5;             // Monaghan artificial viscosity, linear term
  double beta = 0.0;              // Monaghan artificial viscosity, quadratic term
  double artificial_stress = 0.3; // Gray-Monaghan-Swift epsilon, 0 = off
  double artificial_stress_n = 2.55; // exponent n of f_ab = W(r)/W(dp)
  int regularise_every = 0;       // steps between Shepard stress regularisation, 0 = off
  bool kernel_correction = false; // first-order gradient correction (Randles-Libersky) in
                                  // the strain rate: better at free surfaces, but the
                                  // strain rate is then no longer conjugate to the forces
                                  // and total energy is not conserved (about 4 % per 10^4
                                  // steps in the free-vibration test)
  double neighbour_skin = 0.1;    // Verlet skin as a fraction of h (lists rebuilt when a
                                  // particle has moved half of it)
  double axis_radius_factor = 0.25;// 1/r regularised as 1/max(r, factor*h); below the first
                                   // particle ring (0.5 dp) or an axis mode goes unstable
};

struct MaterialSpec {
  std::string name;
  std::string model = "elastic";  // a registered model (models/ModelList.hpp): "elastic",
                                  // "mohr-coulomb", "tresca", "modified-cam-clay"
  double density = 0;             // kg/m3 (deck gives density or unit_weight)
  double shear_modulus = 0;       // G, Pa
  double poisson_ratio = 0;       // nu, [0, 0.5)
  double cohesion = 0;            // c (Su for tresca), Pa
  double phi_deg = 0;             // friction angle, degrees, [0, 90)
  double psi_deg = 0;             // dilation angle, degrees, [0, phi]
  double tension_cutoff = 0;      // Pa, >= 0
  double separation_density = 0;  // kg/m3, below it the grains carry no stress (0 = never)
  double mass_scaling = 1;        // inertia / mass (weight not scaled), >= 1 (docs/models.md "Mass scaling")
  double viscosity = 1;           // artificial viscosity relative to [sph] alpha, beta (docs/sph.md)
  double viscosity_head_on = 0;   // 0..1: the viscosity on a pair's head-on approach only (docs/sph.md)
  // effects (models/Effects.hpp, docs/effects.md); defaults = off
  double crush_pressure = 0;      // Pa, compaction starts above this mean pressure
  double crush_hardening = 0;     // Pa per unit compaction strain
  double air_voids = 0;           // -, largest compaction strain
  double rate_coefficient = 0;    // -, strength gain per decade of shear strain rate
  double reference_strain_rate = 1.0; // 1/s
  double remoulded_ratio = 1.0;   // -, remoulded / intact strength
  double remoulding_strain = 1.0; // -, plastic shear strain at 95 % of the loss
  // The keys of models that declare no member above (core/MaterialModel.hpp, ModelKey).
  std::map<std::string, double> params;
};

// K from the deck's engineering inputs (G, nu): K = 2G(1+nu)/(3(1-2nu)). Here, without
// Kokkos, so that the deck validator and the kernel parameters share it.
inline double bulk_from_shear(double G, double nu) {
  return 2.0 * G * (1.0 + nu) / (3.0 * (1.0 - 2.0 * nu));
}

struct BlockSpec {
  std::string material;           // name of a MaterialSpec
  double r_min = 0, r_max = 0;    // m
  double z_min = 0, z_max = 0;    // m
  double velocity_r = 0, velocity_z = 0; // m/s, initial velocity
};

// Fixed / Roller: rigid walls represented by mirror particles. NonReflecting: no mirror;
// Lysmer-Kuhlemeyer dashpots on the boundary layer of particles (the far field).
enum class WallType { None, Fixed, Roller, NonReflecting };

struct WallSpec {
  WallType type = WallType::None;
  double position = 0;            // m: z of the bottom/top wall, r of the outer wall
  // NonReflecting only: distance R (m) from the wave source to the boundary, which sets the
  // static springs of the viscous-spring boundary, K_n = 4G/(3R), K_t = 2G/(3R) (Pa/m).
  // < 0: automatic (the extent of the initial blocks normal to the boundary); 0: no springs
  // (pure Lysmer-Kuhlemeyer dashpots, which let soil creep out under a lasting load).
  double spring_distance = -1.0;
};

// Finite elements for the soil outside a zone of particles (docs/coupling.md): the blocks
// are meshed with 4-node axisymmetric quads everywhere except inside the SPH zone, which
// keeps its particles; elements and particles are tied along the zone's boundary. The
// deck's walls act on the element nodes (and on particles where the zone reaches them).
struct FemSpec {
  bool enabled = false;
  double element_size = 0.0;      // m, element edge next to the SPH zone; 0 = the particle spacing
  double grading = 1.0;           // growth of the element edge per element away from the zone (1 = uniform)
  double zone_r_min = 0, zone_r_max = 0;  // m, the SPH zone (particles inside, elements outside)
  double zone_z_min = 0, zone_z_max = 0;  // m
  std::string hourglass = "viscous";      // hourglass control: "viscous" | "stiffness" (docs/fem.md)
  double hourglass_coefficient = 0.1;     // its coefficient kappa
  double cfl = 0.8;               // element time step fraction of L/c_p (the run's cfl for particles)
  // Multi-rate stepping: the elements take n substeps of their own stable step inside each
  // step of the particles (n = ceil(particle step / element step)), the tie forces of the
  // particles held over them (docs/coupling.md "Subcycled elements"). false: one step for all.
  bool subcycle = false;
};

// Pounder <-> particle contact (kernels/RigidContact.hpp, docs/contact.md).
struct ContactSpec {
  double static_friction = 0.5;   // FS
  double dynamic_friction = 0.4;  // FD
  double decay = 0.0;             // DC, s/m: mu = FD + (FS - FD) exp(-DC |v_t|)
  double penalty_scale = 1.0;     // contact stiffness / (soil P-wave modulus per spacing)
  double damping_ratio = 0.2;     // of the normal contact, -
};

// The rigid pounder: a barrel, radius growing from base_diameter/2 at the base and the top
// to max_diameter/2 at mid-height along a parabola.
struct PounderSpec {
  double mass = 10.55;            // kg
  double base_diameter = 0.090;   // m
  double max_diameter = 0.100;    // m
  double height = 0.200;          // m
  int profile_segments = 16;      // straight pieces of the barrel side
};

// Aggregate charges poured into the crater after the blows listed in the schedule.
struct BackfillSpec {
  std::string material;           // name of a MaterialSpec ("" = no backfill)
  std::string mode = "fill";      // "fill": up to the original ground level; "surface": up to the
                                  // surface around the crater (heaved); "mass": a given mass
  double mass = 1.0;              // kg per charge, mode "mass"
  double radius = 0.0;            // m, fill inside this radius; 0 = pounder max radius + 2 spacings
};

// The staged drop sequence (drivers/sequence/DropSequence.hpp). enabled = the deck has [schedule].
struct ScheduleSpec {
  bool enabled = false;
  std::vector<double> drop_heights;    // m, one per blow
  std::vector<int> backfill_after;     // blow numbers (1-based) followed by a charge
  std::string drop_height_from = "ground"; // "ground": release height above the original
                                           // ground level; "surface": above the crater floor
  double ground_level = 0.0;      // m, z of the original ground surface (0 = top of the blocks)
  double relax_time = 0.2;        // s, damped relaxation before the first blow
  double damping = 60.0;          // 1/s, mass-proportional damping of the rest/settle phases
  double rest_speed = 0.05;       // m/s: the pounder is at rest in contact below this speed ...
  double rest_force_tolerance = 0.2;  // ... with the contact force within this fraction of its weight ...
  double rest_hold = 0.003;       // s: ... both held for this long
  double rest_time = 0.02;        // s of damped settling with the pounder in place
  double max_impact_time = 1.0;   // s: an impact stage ends here even without rest (warning)
  double extract_time = 0.01;     // s of damped settling after the pounder is lifted out
  double settle_time = 0.03;      // s of damped settling after a charge
  double tracer_interval = 0.001; // s of simulated time between tracer records
  // A rebound flight: "followed" step by step (soil undamped, the exact path), or
  // "ballistic": after flight_relax_time of damped relaxation of the soil, the rest of the
  // flight is the pounder's free fall, advanced in one jump (docs/drop-sequence.md).
  std::string flight = "followed";
  double flight_relax_time = 0.02;  // s of damped soil relaxation before the ballistic jump
};

// A material point followed through the run (like the paper's Figs. 8 and 10): the
// particle nearest to (r, z) at the start.
struct TracerSpec {
  std::string name;
  double r = 0, z = 0;            // m
};

struct Config {
  std::string source_file;        // the deck this came from ("" when built in code)
  RunSpec run;
  SphSpec sph;
  double gravity = 9.81;          // m/s2, acting in -z
  double damping = 0.0;           // 1/s, mass-proportional damping (dynamic relaxation)
  double gravity_ramp = 0.0;      // s: gravity grows linearly from 0 over this time (0 = at once)
  std::string initial_stress = "zero"; // "zero" | "geostatic" (K0 = nu/(1-nu) for layered
                                       // blocks, then dynamic relaxation)
  std::vector<MaterialSpec> materials;
  std::vector<BlockSpec> blocks;
  WallSpec bottom, top, outer;    // the axis r = 0 is always a symmetry line
  FemSpec fem;
  ContactSpec contact;
  PounderSpec pounder;
  BackfillSpec backfill;
  ScheduleSpec schedule;
  std::vector<TracerSpec> tracers;
};

}  // namespace tamp
