// What one blow did, and its energy account: the record blows.csv writes (BlowRecord, its
// columns by name), the energies the account differences (BlowEnergies) and the account
// itself (account_blow_energy), apart from the sequencer so that each can be tested alone
// (tests/test_drop_sequence.cpp). Definitions: docs/drop-sequence.md.
#pragma once
#include <cstddef>
#include <vector>

namespace tamp {

// What one blow did (blows.csv; definitions in docs/drop-sequence.md). Lengths in m,
// below the original ground level where they are depths; energies in J over the impact
// stage (placement of the pounder to the end of its damped rest).
struct BlowRecord {
  int blow = 0;
  double drop_height_m = 0;
  double crater_depth_m = 0;           // original ground level - pounder base at rest in contact
  double deepest_m = 0;                // original ground level - lowest pounder base of the blow
  double penetration_m = 0;            // pounder base at its first contact - at rest
  double contacts = 0;                 // contact phases: 1 + rebounds that left the soil >= 1 ms
  double restitution = 0;              // first rebound: largest upward speed / speed at first contact
  double peak_deceleration_m_s2 = 0;   // largest upward acceleration of the pounder
  double rest_in_contact = 0;          // 1: ended at rest in contact; 0: at max_impact_time
  double crater_floor_m = 0;           // after extraction: ground - top of the material under the base
  double uplift_m = 0;                 // largest heave of the soil surface beside the pounder
  double aggregate_added_kg = 0;       // charge poured after this blow
  // energy account of the impact stage
  double energy_in_J = 0;              // brought by the pounder: its kinetic + potential energy lost
  double elastic_J = 0;                // elastic strain energy stored in the soil (all materials)
  double soil_motion_J = 0;            // kinetic + gravitational energy of the soil
  double viscous_heat_J = 0;           // artificial-viscosity heat (all materials)
  double radiated_J = 0;               // out through the non-reflecting boundaries
  double damping_J = 0;                // taken by the damping of the rest phase
  double wall_friction_J = 0;          // taken by the fixed walls' friction
  double contact_J = 0;                // contact damping, friction and stored penalty energy
  double artificial_stress_J = 0;      // work of the artificial stress (numerical; > 0: fed in)
  double returned_J = 0;               // elastic energy returned to the pounder (its rebounds' kinetic energy)
  double residual_J = 0;               // energy_in + artificial stress work - every sink (plastic work included)
  std::vector<double> plastic_J;       // per deck material: internal - elastic - viscous heat
  // simulated time of the impact stage
  double contact_time_s = 0, flight_time_s = 0, rest_time_s = 0;
  double ballistic_time_s = 0;         // the part of flight_time_s advanced in ballistic jumps
  // work of the stress pair terms with the mirror images (numerical, > 0: fed in; docs/sph.md)
  double axis_images_J = 0;            // of the axis images
  double wall_images_J = 0;            // of the wall images
  double wall_s = 0;                   // wall time of this blow's stages
};

// The scalar columns of BlowRecord in blows.csv order (the per-material plastic work
// follows as plastic_<material>_J, then wall_s): one list for the table, the checkpoint
// and the loop's per-blow quantities.
struct BlowColumn {
  const char* name;
  double BlowRecord::*field;
};
const std::vector<BlowColumn>& blow_columns();

// The energies a blow's energy account differences (J), by name: the pounder's (kinetic +
// potential), the contact's, the work of damping, of the non-reflecting boundaries, of wall
// friction and of the artificial stress (EnergyLedger); per material the kinetic, internal,
// potential and elastic energies and the numerical heat (the particles' viscous heat and the
// tied elements' hourglass work); the tied elements' nodes: motion, boundary work, damping
// work (zero without elements); the work of the axis and wall images. A checkpoint holds them
// as flat() writes them (new terms appended last): a term an older checkpoint lacks is NaN
// after from_flat, and its difference counts from the restart (zero).
struct BlowEnergies {
  double pounder = 0, contact = 0, damping = 0, boundary = 0, wall_friction = 0, artificial_stress = 0;
  struct Material {
    double kinetic = 0, internal = 0, potential = 0, elastic = 0, numerical_heat = 0;
  };
  std::vector<Material> materials;
  double node_motion = 0, node_boundary = 0, node_damping = 0;
  double axis_images = 0, wall_images = 0;
  bool known = false;  // taken from the model (a default one, never taken, is written as nothing)
  std::vector<double> flat() const;
  static BlowEnergies from_flat(const std::vector<double>& v, size_t n_materials);
};

// The energy terms of rec (energy_in_J ... residual_J, plastic_J per material) from the
// energies at the placement of the pounder (before) and at the end of the blow (after). A term
// that is NaN in before (a checkpoint from before the term existed) counts from the restart.
void account_blow_energy(const BlowEnergies& before, const BlowEnergies& after, BlowRecord& rec);

}  // namespace tamp
