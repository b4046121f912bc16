// The soils of the reference laboratory test for tests and benchmarks, as the lab deck
// declares them: examples/lab-test.toml is the one place their values are written, each with
// its source (data/lab-test.toml holds the paper's facts they come from). Read once, at the
// first call, from the source tree (TAMP_SOURCE_DIR, defined for the tests and benchmarks).
#pragma once
#include <stdexcept>
#include <string>

#include "core/Config.hpp"
#include "core/Deck.hpp"

namespace tamp::lab {

// g of the lab deck, m/s2 (converts the paper's unit weights to densities)
constexpr double g = 9.81;

inline const Config& deck() {
  static const Config c = load_deck(std::string(TAMP_SOURCE_DIR) + "/examples/lab-test.toml");
  return c;
}

inline MaterialSpec material(const std::string& name) {
  for (const MaterialSpec& m : deck().materials)
    if (m.name == name) return m;
  throw std::logic_error("examples/lab-test.toml has no material '" + name + "'");
}

// Soft silty clay, undrained (Tresca, Su 10.2 kPa; G 1.39 MPa, nu 0.31, 18.7 kN/m3).
// model: "tresca" (the deck's) or "elastic" (the same without its strength).
inline MaterialSpec clay(const std::string& model = "tresca") {
  MaterialSpec m = material("clay");
  if (model == "elastic") {
    m.model = "elastic";
    m.cohesion = 0.0;
  } else if (model != "tresca") {
    throw std::logic_error("lab::clay: model '" + model + "'; allowed: tresca, elastic");
  }
  return m;
}

// Crushed basalt 5-25 mm, the backfill: cohesionless Mohr-Coulomb (phi 47 deg, psi 0), its
// grains separate below 1526 kg/m3 and compact from there, its viscosity a fifth of the others'.
inline MaterialSpec aggregate() { return material("aggregate"); }

}  // namespace tamp::lab
