// Non-reflecting (Lysmer-Kuhlemeyer) boundary: a compression pulse reaching it leaves
// little energy behind (issue: FEM/coupling, item 5, for SPH particles).
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>

#include "SphTestUtil.hpp"

using namespace tamp;
using namespace tamp::testing;

namespace {
// A 2 ms compression pulse is driven into the top of a laterally confined column of the
// lab clay (0.6 m, roller side); returns the wave energy left in the column once the pulse
// has met the base, relative to the energy of the incident pulse.
double reflected_fraction(WallType base) {
  const double R = 0.02, L = 0.6, dp = 0.0025, v0 = -0.01, pulse = 0.002;
  Config cfg = column_config(R, L, dp);
  cfg.bottom = {base, 0.0};
  cfg.sph.alpha = 0.2;
  Simulation sim(cfg);
  const double c = sim.materials()[0].wave_speed();
  const Box top{0, 1, L - dp, 1};
  sim.prescribe_velocity(top, 0.0, v0);
  sim.advance_to(pulse);
  sim.prescribe_velocity(top, 0.0, 0.0);  // the top is held from now on
  const double t_incident = (L - 0.15) / c;          // pulse inside, front 0.15 m above the base
  sim.advance_to(t_incident);
  const double e_incident = wave_energy(sim);
  const double t_reflected = L / c + pulse + 0.2 / c;  // a reflection would be 0.2 m up the column
  sim.advance_to(t_reflected);
  const double e_left = wave_energy(sim);
  std::printf("[boundary] %s base (%ld steps, last dt %.2e s): incident %.4e J, left after reflection %.4e J, ratio %.2f %%\n",
              base == WallType::NonReflecting ? "non-reflecting" : "roller", sim.steps(), sim.last_dt(), e_incident, e_left,
              100 * e_left / e_incident);
  return e_left / e_incident;
}
}  // namespace

TEST_CASE("Boundaries: a pulse reaching a non-reflecting base leaves < 5 % of its energy", "[boundaries][verification]") {
  // Tolerance 5 % (issue). The roller base is run beside it for reference: it reflects the
  // pulse, so nearly all the energy (less the artificial viscosity's share) stays.
  const double absorbed = reflected_fraction(WallType::NonReflecting);
  const double reflected = reflected_fraction(WallType::Roller);
  CHECK(absorbed < 0.05);
  CHECK(reflected > 0.5);
}

namespace {
// A laterally confined elastic column (roller side) on a non-reflecting base, loaded at the
// top by a step pressure q and left to come to rest (no damping other than the base's
// dashpots). Returns the top row's mean settlement (m) and its final velocity (m/s).
struct Settlement { double u, v, u_exact_column, k_n, rho_cp; };
Settlement step_load_settlement(double spring_distance, double end_time) {
  const double R = 0.02, L = 0.3, dp = 0.005, q = 1000.0;
  Config cfg = column_config(R, L, dp);
  cfg.bottom = {WallType::NonReflecting, 0.0, spring_distance};
  Simulation sim(cfg);
  const HostState s0 = host_state(sim);
  const Box top{0, 1, L - dp, 1};
  sim.apply_surface_traction(top, 0.0, -q, dp);
  sim.advance_to(end_time);
  const HostState s1 = host_state(sim);
  double u = 0, v = 0;
  int n = 0;
  for (size_t i = 0; i < s0.z.size(); ++i)
    if (s0.z[i] >= L - dp) { u += s0.z[i] - s1.z[i]; v += -s1.vz[i]; ++n; }
  const MaterialParams m = sim.materials()[0];
  const double M = m.p_wave_modulus();
  return {u / n, v / n, q * L / M, spring_distance > 0 ? 4.0 * m.shear_modulus / (3.0 * spring_distance) : 0.0,
          m.density * std::sqrt(M / m.density)};
}
}  // namespace

TEST_CASE("Boundaries: a non-reflecting base with springs carries a lasting load (static settlement)",
          "[boundaries][verification]") {
  // Statics of the viscous-spring boundary: the column shortens by q L / M and the base
  // spring gives q / K_n, K_n = 4 G / (3 R) (Liu et al. 2006). Tolerance 3 %: the loaded
  // top layer and the spring layer are one spacing thick and the SPH kernel is truncated at
  // both ends of the column (errors first order in dp / L = 1.7 %).
  const double q = 1000.0, L = 0.3;
  const Settlement s = step_load_settlement(L, 0.3);
  const double exact = s.u_exact_column + q / s.k_n;
  std::printf("[boundary] step load %.0f Pa on a spring base (R = %.2f m): settlement %.4e m, exact %.4e m "
              "(column %.4e + spring %.4e), error %+.2f %%, final velocity %.2e m/s\n",
              q, L, s.u, exact, s.u_exact_column, q / s.k_n, 100 * (s.u / exact - 1), s.v);
  CHECK(std::abs(s.u / exact - 1) < 0.03);
  CHECK(std::abs(s.v) < 1e-3 * q / s.rho_cp);  // at rest: < 0.1 % of the dashpot creep speed

  // Without springs (spring_distance = 0, pure Lysmer dashpots) the same load pushes the
  // column out through the base at the creep speed q / (rho c_p): why the springs exist.
  // Tolerance 5 %: the creep speed is reached once the column's waves are absorbed.
  const Settlement d = step_load_settlement(0.0, 0.3);
  std::printf("[boundary] same load on a dashpot-only base: settlement %.4e m after 0.3 s, velocity %.4e m/s, "
              "q/(rho c_p) = %.4e m/s (%+.2f %%)\n",
              d.u, d.v, q / d.rho_cp, 100 * (d.v * d.rho_cp / q - 1));
  CHECK(std::abs(d.v * d.rho_cp / q - 1) < 0.05);
}
