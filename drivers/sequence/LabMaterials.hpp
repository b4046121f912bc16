// The soils of the reference laboratory test (data/lab-test.toml, copied from the paper's
// figures with provenance), as deck material entries for scenarios, tests and benchmarks.
#pragma once
#include "core/Config.hpp"

namespace tamp::lab {

constexpr double g = 9.81;  // m/s2, converts the paper's unit weights to densities

// Soft silty clay, undrained: G = 1.39 MPa, nu = 0.31, unit weight 18.7 kN/m3, Su = 10.2 kPa.
// model: "elastic" or "tresca".
inline MaterialSpec clay(const std::string& model = "tresca") {
  MaterialSpec m;
  m.name = "clay";
  m.model = model;
  m.density = 18.7e3 / g;
  m.shear_modulus = 1.39e6;
  m.poisson_ratio = 0.31;
  if (model == "tresca") m.cohesion = 10.2e3;
  return m;
}

// Crushed basalt 5-25 mm, the backfill: cohesionless Mohr-Coulomb, phi = 47 deg, psi = 0,
// G = 6.86 MPa, nu = 0.2, unit weight 18 kN/m3, grains separate below 1526 kg/m3 and
// compact plastically from there (effect (a): 4.9 kPa at the loosest packing, 20 kPa at the
// poured density, air voids 0.05; examples/lab-test.toml), its artificial viscosity a fifth
// of the others'.
inline MaterialSpec aggregate() {
  MaterialSpec m;
  m.name = "aggregate";
  m.model = "mohr-coulomb";
  m.density = 18.0e3 / g;
  m.shear_modulus = 6.86e6;
  m.poisson_ratio = 0.2;
  m.phi_deg = 47.0;
  m.separation_density = 1526.0;
  m.crush_pressure = 20.0e3;   // Pa
  m.crush_hardening = 82.0e3;  // Pa
  m.air_voids = 0.05;
  m.viscosity = 0.2;  // alpha 0.1 of [sph] 0.5 (examples/lab-test.toml)
  m.viscosity_head_on = 1.0;  // grains sliding past each other are not pushed apart (as the deck)
  return m;
}

}  // namespace tamp::lab
