// Helpers shared by the SPH verification tests: decks built in code, host probes.
#pragma once
#include <fstream>
#include <sstream>
#include <string>
#include <vector>
#include <catch2/catch.hpp>
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

}  // namespace tamp::testing
