// The effect catalogue (models/Effects.hpp, issue: closing the loop): each effect against
// its closed-form law, alone and composed with Tresca in update_stress, on the host and in
// a kernel.
#include <catch2/catch.hpp>
#include <cmath>

#include "drivers/sequence/LabMaterials.hpp"
#include "kernels/solver/Simulation.hpp"
#include "models/StressUpdate.hpp"

using namespace tamp;

namespace {
MaterialParams tresca_clay() { return make_material(lab::clay("tresca")); }
double mean_pressure(const double s[4]) { return -(s[RR] + s[ZZ] + s[TT]) / 3.0; }
}  // namespace

TEST_CASE("Effects: rate and remoulding factors follow their laws", "[effects]") {
  // Exact closed forms (tolerance: round-off).
  MaterialParams m = tresca_clay();
  m.rate_coefficient = 0.3;
  m.reference_strain_rate = 2.0;
  CHECK(rate_factor(m, 1.0) == 1.0);  // below the reference rate: no gain
  CHECK(rate_factor(m, 20.0) == Approx(1.3).epsilon(1e-14));
  CHECK(rate_factor(m, 200.0) == Approx(1.6).epsilon(1e-14));
  m.rate_coefficient = 0;
  CHECK(rate_factor(m, 1e6) == 1.0);  // off
  m.remoulded_ratio = 0.4;
  m.remoulding_strain = 0.5;
  CHECK(remoulding_factor(m, 0.0) == 1.0);
  // 95 % of the loss at eps_95: 1 - 0.6 (1 - e^-3)
  CHECK(remoulding_factor(m, 0.5) == Approx(0.4 + 0.6 * std::exp(-3.0)).epsilon(1e-14));
  CHECK(remoulding_factor(m, 50.0) == Approx(0.4).epsilon(1e-12));
  // engineering shear strain rate of simple shear deps_rz = gdot dt / 2
  const double deps[4] = {0, 0, 0, 0.5 * 3.0 * 1e-4};
  CHECK(shear_strain_rate(deps, 1e-4) == Approx(3.0).epsilon(1e-12));
}

TEST_CASE("Effects: compaction follows the linear crush curve and stops at the air voids", "[effects]") {
  // Isotropic compression by volumetric strain increments: after crushing starts,
  // p = (p_c0 + H eps_vol) / (1 + H/K) (elastic K in series with the hardening H), exactly,
  // until eps_v^p reaches the air voids; then elastic again with K. Tolerance 1e-9 relative.
  MaterialParams m = tresca_clay();
  m.crush_pressure = 20e3;
  m.crush_hardening = 2e6;
  m.air_voids = 0.05;
  const double K = m.bulk_modulus, H = m.crush_hardening;
  double s[4] = {0, 0, 0, 0}, ep = 0, ev = 0, eps = 0;
  const double d = -1e-5;  // each axial component: volumetric increment 3d
  double worst = 0;
  bool saturated = false;
  for (int step = 0; step < 12000; ++step) {
    const double deps[4] = {d, d, d, 0};
    update_stress(m, s, deps, 0.0, ep, ev, 1e-4);
    eps += -3 * d;
    const double p = mean_pressure(s);
    double expected;
    if (eps <= m.crush_pressure / K) expected = K * eps;
    else if (ev < m.air_voids) expected = (m.crush_pressure + H * eps) / (1 + H / K);
    else {
      saturated = true;
      expected = K * (eps - m.air_voids);
    }
    worst = std::max(worst, std::fabs(p - expected) / expected);
    CHECK(ev <= m.air_voids);
  }
  INFO("worst relative error " << worst);
  CHECK(saturated);
  CHECK(worst < 1e-9);
  CHECK(ep == Approx(0.0).margin(1e-15));  // isotropic: no shear plasticity
}

TEST_CASE("Effects: rate and remoulding scale the Tresca strength in update_stress", "[effects]") {
  // Simple shear at a constant rate until the stress saturates: s1 - s3 = 2 Su factor.
  // Rate: exact. Remoulding: the factor uses the plastic strain at the start of the step,
  // a lag of one increment (1e-5 in eps_p): tolerance 1e-4 relative.
  MaterialParams m = tresca_clay();
  const double su = m.cohesion, dt = 1e-4, gdot = 50.0;  // 1/s
  auto shear_to = [&](MaterialParams mm, double& ep) {
    double s[4] = {0, 0, 0, 0}, ev = 0;
    ep = 0;
    for (int step = 0; step < 20000; ++step) {
      const double deps[4] = {0, 0, 0, 0.5 * gdot * dt};
      update_stress(mm, s, deps, 0.0, ep, ev, dt);
    }
    const double c = 0.5 * (s[RR] + s[ZZ]), r = std::sqrt(0.25 * (s[RR] - s[ZZ]) * (s[RR] - s[ZZ]) + s[RZ] * s[RZ]);
    (void)c;
    return r;  // (s1 - s3) / 2 in the r-z plane
  };
  double ep = 0;
  MaterialParams rate = m;
  rate.rate_coefficient = 0.2;
  rate.reference_strain_rate = 0.5;
  CHECK(shear_to(rate, ep) == Approx(su * (1 + 0.2 * 2.0)).epsilon(1e-12));  // 100x the reference: 2 decades
  MaterialParams soft = m;
  soft.remoulded_ratio = 0.5;
  soft.remoulding_strain = 20.0;
  const double tau = shear_to(soft, ep);
  CHECK(tau == Approx(su * remoulding_factor(soft, ep)).epsilon(1e-4));
  CHECK(tau < 0.9 * su);
}

TEST_CASE("Effects: the composed update gives the same bits in a kernel as on the host", "[effects]") {
  MaterialParams m = tresca_clay();
  m.crush_pressure = 15e3;
  m.air_voids = 0.1;
  m.rate_coefficient = 0.3;
  m.remoulded_ratio = 0.6;
  m.remoulding_strain = 0.3;
  const int n = 64;
  Kokkos::View<double* [4], MemSpace> out("out", n);
  Kokkos::parallel_for("test::effects", Kokkos::RangePolicy<ExecSpace>(0, n), KOKKOS_LAMBDA(int i) {
    double s[4] = {-1e3 * i, -2e3 * i, -1.5e3 * i, 300.0 * i}, ep = 0, ev = 0;
    for (int k = 0; k < 200; ++k) {
      const double deps[4] = {-2e-4, -1e-4 * (i % 5), -3e-5, 1e-4 * (i % 3)};
      update_stress(m, s, deps, 1e-5, ep, ev, 1e-4);
    }
    for (int c = 0; c < 4; ++c) out(i, c) = s[c];
  });
  auto h = Kokkos::create_mirror_view_and_copy(HostSpace(), out);
  for (int i = 0; i < n; ++i) {
    double s[4] = {-1e3 * i, -2e3 * i, -1.5e3 * i, 300.0 * i}, ep = 0, ev = 0;
    for (int k = 0; k < 200; ++k) {
      const double deps[4] = {-2e-4, -1e-4 * (i % 5), -3e-5, 1e-4 * (i % 3)};
      update_stress(m, s, deps, 1e-5, ep, ev, 1e-4);
    }
    for (int c = 0; c < 4; ++c) CHECK(h(i, c) == s[c]);
  }
}
