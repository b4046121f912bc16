// Helpers shared by the SPH verification tests: decks built in code, host probes.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>
#include <catch2/catch.hpp>
#include "core/Config.hpp"
#include "drivers/sequence/LabMaterials.hpp"
#include "kernels/solver/Simulation.hpp"

namespace tamp::testing {

// The lab clay of the reference paper, elastic (drivers/sequence/LabMaterials.hpp).
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

// A number from the environment (the knobs of the studies in docs/), or the fallback when
// the variable is not set.
inline double env_or(const char* name, double fallback) {
  const char* v = std::getenv(name);
  return v ? std::atof(v) : fallback;
}

// The on-step callback (Simulation::advance_to) of a base of glued grains: every real particle
// whose centre lies below `height` (m) is held at rest. None (an empty callback) for height 0.
inline std::function<bool()> glued_base(Simulation& sim, double height) {
  if (!(height > 0)) return {};
  return [&sim, height]() {
    sim.prescribe_velocity({0.0, 1e3, -1.0, height}, 0.0, 0.0);
    return true;
  };
}

// Host copies of the real particles' positions, velocities and stresses.
struct HostState {
  std::vector<double> r, z, vr, vz, srr, szz, stt, srz;
};

inline HostState host_state(const Simulation& sim) {
  ParticleSnapshot s = sim.snapshot();
  return {s.r, s.z, s.v_r, s.v_z, s.s_rr, s.s_zz, s.s_tt, s.s_rz};
}

// Kinetic + elastic strain energy of the real particles (J): the wave energy of an
// elastic column. Strain energy density p^2/(2K) + s:s/(4G), volume m / rho.
inline double wave_energy(const Simulation& sim) {
  const ParticleSnapshot s = sim.snapshot();
  const MaterialParams m = sim.materials()[0];
  double e = 0;
  for (size_t i = 0; i < s.r.size(); ++i) {
    const double p = (s.s_rr[i] + s.s_zz[i] + s.s_tt[i]) / 3;
    const double drr = s.s_rr[i] - p, dzz = s.s_zz[i] - p, dtt = s.s_tt[i] - p;
    const double ss = drr * drr + dzz * dzz + dtt * dtt + 2 * s.s_rz[i] * s.s_rz[i];
    const double w = p * p / (2 * m.bulk_modulus) + ss / (4 * m.shear_modulus);
    e += 0.5 * s.mass[i] * (s.v_r[i] * s.v_r[i] + s.v_z[i] * s.v_z[i]) + w * s.mass[i] / s.density[i];
  }
  return e;
}

// The rows of a CSV file written by Tamp (numbers only), after its header line; the header
// cells go to `header` if given.
inline std::vector<std::vector<double>> read_csv(const std::string& path, std::vector<std::string>* header = nullptr) {
  std::ifstream in(path);
  REQUIRE(in.good());
  std::string line;
  std::getline(in, line);
  if (header) {
    std::stringstream hs(line);
    std::string h;
    while (std::getline(hs, h, ',')) header->push_back(h);
  }
  std::vector<std::vector<double>> rows;
  while (std::getline(in, line)) {
    std::stringstream ls(line);
    std::string cell;
    std::vector<double> row;
    while (std::getline(ls, cell, ',')) row.push_back(std::stod(cell));
    rows.push_back(row);
  }
  return rows;
}

// Drives the particles in `top` down at v0 (m/s) for `pulse` s, then holds them, stepping to
// t_end (s); returns energy(sim) at the first step at or after t_incident (the incident pulse
// before it meets anything). For the wave tests through an interface.
template <class Energy>
double drive_pulse(Simulation& sim, const Box& top, double v0, double pulse, double t_incident, double t_end,
                   Energy energy) {
  sim.prescribe_velocity(top, 0.0, v0);
  double e_incident = -1;
  bool pulse_on = true;
  while (sim.time() < t_end) {
    sim.step();
    if (pulse_on && sim.time() >= pulse) {
      sim.prescribe_velocity(top, 0.0, 0.0);
      pulse_on = false;
    }
    if (e_incident < 0 && sim.time() >= t_incident) e_incident = energy(sim);
  }
  return e_incident;
}

// The layer of the pounder-drop energy tests: the elastic lab clay, 0.2 m thick, radius 0.3 m,
// 10 mm particles, geostatic, on `bottom`.
inline Config elastic_clay_layer(WallType bottom) {
  Config cfg = column_config(0.3, 0.2, 0.01);
  cfg.bottom = {bottom, 0.0};
  cfg.materials = {lab::clay("elastic")};
  cfg.gravity = 9.81;
  cfg.initial_stress = "geostatic";
  return cfg;
}

// Drops the lab's 10.55 kg barrel pounder at 2 m/s onto the top of elastic_clay_layer (1 mm
// above the particle cells) and steps 0.06 s; returns the worst |accounted energy - start| (J).
// The blow's kinetic energy is 0.5 * 10.55 * 2^2 = 21.1 J.
inline double drop_pounder_worst_imbalance(Simulation& sim) {
  sim.set_rigid_body(barrel_profile(0.09, 0.1, 0.2, 16), 10.55);
  sim.place_body(0.0, 0.2 + 0.001, 0.0, -2.0);
  const double e0 = sim.accounted_energy();
  double worst = 0;
  while (sim.time() < 0.06) {
    sim.step();
    worst = std::max(worst, std::fabs(sim.accounted_energy() - e0));
  }
  return worst;
}

}  // namespace tamp::testing
