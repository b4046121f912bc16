// Helpers shared by the SPH verification tests: decks built in code, host probes.
#pragma once
#include <vector>
#include "core/Config.hpp"
#include "drivers/LabMaterials.hpp"
#include "drivers/Simulation.hpp"

namespace tamp::testing {

// The lab clay of the reference paper, elastic (drivers/LabMaterials.hpp).
inline MaterialSpec lab_clay_elastic() { return lab::clay("elastic"); }

inline Config column_config(double radius, double height, double spacing) {
  Config c;
  c.run.name = "test";
  c.sph.spacing = spacing;
  c.gravity = 0.0;
  c.materials = {lab_clay_elastic()};
  BlockSpec b;
  b.material = "clay";
  b.r_min = 0; b.r_max = radius; b.z_min = 0; b.z_max = height;
  c.blocks = {b};
  c.bottom = {WallType::Fixed, 0.0};
  c.outer = {WallType::Roller, radius};
  return c;
}

// Host copies of the real particles' positions, velocities and stresses.
struct HostState {
  std::vector<double> r, z, vr, vz, srr, szz, stt, srz;
};

inline HostState host_state(const Simulation& sim) {
  ParticleSnapshot s = sim.snapshot();
  return {s.r, s.z, s.v_r, s.v_z, s.s_rr, s.s_zz, s.s_tt, s.s_rz};
}

}  // namespace tamp::testing
