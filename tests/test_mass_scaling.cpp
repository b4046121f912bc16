// Mass scaling of a material (`mass_scaling`, docs/models.md "Mass scaling"): the inertia of
// its particles times s, its weight, stiffness and strength as they are. A scaled medium is
// a medium of density s rho: waves travel at c / sqrt(s), its impedance is sqrt(s) rho c, the
// stable step grows by sqrt(s) where it sets the step, statics do not change, and the energy
// account books the kinetic energy of the inertia.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>

#include "SphTestUtil.hpp"

using namespace tamp;
using namespace tamp::testing;

namespace {
// The lab sand (examples/lab-test.toml), elastic: c_p 246 m/s, 4.8 times the clay's.
MaterialSpec elastic_sand(double mass_scaling) {
  MaterialSpec m;
  m.name = "sand";
  m.model = "elastic";
  m.density = 18.0e3 / lab::g;
  m.shear_modulus = 41.7e6;
  m.poisson_ratio = 0.2;
  m.mass_scaling = mass_scaling;
  return m;
}

// Kinetic (of the inertia) + elastic strain energy of one material's particles, J.
double wave_energy_of(const Simulation& sim, int material) {
  const auto e = sim.material_energies();
  return e[material].kinetic + e[material].elastic;
}

struct PulseResult {
  double reflected, transmitted, reflected_exact, dt;
  long steps;
};

// Laterally confined column, radius 20 mm, 5 mm particles: the elastic lab clay for z in
// [0.5, 0.8] m on the elastic lab sand (inertia times s) for z in [0, 0.5] m; roller side,
// fixed base. A 2 ms velocity pulse driven into the top meets the interface. 1D strain: a
// wave from impedance Z1 onto Z2 reflects ((Z2 - Z1) / (Z2 + Z1))^2 of its energy and
// transmits the rest (Graff, Wave Motion in Elastic Solids, 1975, sec. 1.2); for the
// scaled sand Z2 = s rho c / sqrt(s). Measured when the reflected pulse has left the
// interface and the transmitted one has not reached the base.
PulseResult pulse_into_sand(double s) {
  const double R = 0.02, zi = 0.5, L = 0.8, dp = 0.005, v0 = -0.01, pulse = 0.002;
  Config cfg = column_config(R, L, dp);
  cfg.materials = {lab_clay_elastic(), elastic_sand(s)};
  BlockSpec sand;
  sand.material = "sand";
  sand.r_min = 0; sand.r_max = R; sand.z_min = 0; sand.z_max = zi;
  cfg.blocks[0].z_min = zi;
  cfg.blocks.push_back(sand);
  cfg.sph.alpha = 0.2;
  Simulation sim(cfg);
  const MaterialParams clay = sim.materials()[0], sandp = sim.materials()[1];
  const double z1 = clay.density * clay.wave_speed();
  const double z2 = s * sandp.density * sandp.wave_speed();  // wave_speed() is c / sqrt(s)
  const Box top{0, 1, L - dp, 1};
  const double t_cross = (L - zi) / clay.wave_speed();
  const double t_incident = t_cross - 0.05 / clay.wave_speed();
  const double t_end = t_cross + pulse + 0.6e-3;
  const double e_incident = drive_pulse(sim, top, v0, pulse, t_incident, t_end, [](const Simulation& sm) {
    return wave_energy_of(sm, 0) + wave_energy_of(sm, 1);
  });
  return {wave_energy_of(sim, 0) / e_incident, wave_energy_of(sim, 1) / e_incident,
          std::pow((z2 - z1) / (z2 + z1), 2), sim.last_dt(), sim.steps()};
}
}  // namespace

TEST_CASE("Mass scaling: a pulse into a mass-scaled sand reflects and transmits by the impedance sqrt(s) rho c, "
          "with a step sqrt(s) longer",
          "[mass-scaling][verification]") {
  // Tolerance 5 % of each fraction (as the tie's impedance test, docs/coupling.md): the
  // viscosity (alpha 0.2) takes about 1.5 % of a crossing pulse. s = 6.08 brings the sand's
  // c_p (246 m/s) down to the aggregate's (99.8 m/s), the lab deck's case; unscaled, the
  // same column reflects 41 % of the energy instead of 70 %.
  const PulseResult one = pulse_into_sand(1.0);
  const PulseResult scaled = pulse_into_sand(6.08);
  for (const auto& [name, r] : {std::make_pair("unscaled", one), std::make_pair("s = 6.08", scaled)}) {
    std::printf("[mass scaling] %s: %ld steps, last step %.3e s; reflected %.4f (exact %.4f, %+.2f %%), transmitted "
                "%.4f (exact %.4f, %+.2f %%)\n",
                name, r.steps, r.dt, r.reflected, r.reflected_exact, 100 * (r.reflected / r.reflected_exact - 1),
                r.transmitted, 1 - r.reflected_exact, 100 * (r.transmitted / (1 - r.reflected_exact) - 1));
    CHECK(std::fabs(r.reflected / r.reflected_exact - 1) < 0.05);
    CHECK(std::fabs(r.transmitted / (1 - r.reflected_exact) - 1) < 0.05);
  }
  // The sand sets the step unscaled (c_p 246 m/s against the clay's 51.5); scaled by 6.08
  // its c_p is 99.8 m/s: the step grows by sqrt(6.08) = 2.47 (within 2 %: the speed term
  // |v| of the stable step differs a little between the runs).
  CHECK(std::fabs(scaled.dt / one.dt / std::sqrt(6.08) - 1) < 0.02);
}

TEST_CASE("Mass scaling: the statics of a scaled column do not change, its dashpot base creeps at q / (sqrt(s) rho c_p)",
          "[mass-scaling][boundaries][verification]") {
  // A laterally confined elastic column (lab clay, inertia times s = 4) on a non-reflecting
  // base, loaded at the top by a step pressure q: with the base's springs (R = L) it settles
  // by q L / M + q / K_n as unscaled (weight and stiffness are not scaled; tolerance 3 %, as
  // the unscaled test in test_boundaries.cpp); on dashpots only it creeps through the base
  // at q / Z with Z = sqrt(s) rho c_p, the scaled medium's impedance (tolerance 5 %, idem).
  const double R = 0.02, L = 0.3, dp = 0.005, q = 1000.0, s = 4.0;
  auto settle = [&](double spring_distance, double& u, double& v) {
    Config cfg = column_config(R, L, dp);
    cfg.materials[0].mass_scaling = s;
    cfg.bottom = {WallType::NonReflecting, 0.0, spring_distance};
    Simulation sim(cfg);
    const HostState s0 = host_state(sim);
    const Box top{0, 1, L - dp, 1};
    sim.apply_surface_traction(top, 0.0, -q, dp);
    sim.advance_to(0.4);
    const HostState s1 = host_state(sim);
    u = v = 0;
    int n = 0;
    for (size_t i = 0; i < s0.z.size(); ++i)
      if (s0.z[i] >= L - dp) { u += s0.z[i] - s1.z[i]; v += -s1.vz[i]; ++n; }
    u /= n;
    v /= n;
    return sim.materials()[0];
  };
  double u_spring, v_spring, u_dash, v_dash;
  const MaterialParams m = settle(L, u_spring, v_spring);
  settle(0.0, u_dash, v_dash);
  const double M = m.p_wave_modulus(), Kn = 4.0 * m.shear_modulus / (3.0 * L);
  const double exact = q * L / M + q / Kn, Z = std::sqrt(s) * m.density * std::sqrt(M / m.density);
  std::printf("[mass scaling] s = %.0f, step load %.0f Pa: spring base settlement %.4e m (exact %.4e, %+.2f %%); "
              "dashpot base creep %.4e m/s (q / (sqrt(s) rho c_p) = %.4e, %+.2f %%)\n",
              s, q, u_spring, exact, 100 * (u_spring / exact - 1), v_dash, q / Z, 100 * (v_dash * Z / q - 1));
  CHECK(std::fabs(u_spring / exact - 1) < 0.03);
  CHECK(std::fabs(v_dash * Z / q - 1) < 0.05);
}

TEST_CASE("Mass scaling: a pounder dropped onto a mass-scaled elastic layer, energy balance closes within 2 %",
          "[mass-scaling][contact][verification]") {
  // As the unscaled drop in test_contact.cpp (roller side and base, no energy leaves): the
  // particles' kinetic energy of their inertia, their strain energy and heat, the pounder and
  // the contact must stay constant; tolerance 2 % of the blow's kinetic energy (issue). The
  // layer's inertia is scaled by 4: the contact acts on it with its spring unchanged and its
  // dashpots at the rate of that inertia (kernels/RigidContact.hpp).
  Config cfg = elastic_clay_layer(WallType::Roller);
  cfg.materials[0].mass_scaling = 4.0;
  Simulation sim(cfg);
  const double worst = drop_pounder_worst_imbalance(sim), blow = 0.5 * 10.55 * 2.0 * 2.0;
  std::printf("[mass scaling] drop on a layer of inertia 4x: %ld steps, worst imbalance %.4f J = %.3f %% of the blow\n",
              sim.steps(), worst, 100 * worst / blow);
  CHECK(worst / blow < 0.02);
}
