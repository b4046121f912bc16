// Tests of models/ModifiedCamClay.hpp: the return mapping on random states, isotropic and
// drained triaxial compression against the closed-form critical-state responses, the
// model through the deck, and a geostatic column of it in particles tied to elements.
// Units: Pa. Tolerances are stated (with the reason) next to each check.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "SphTestUtil.hpp"
#include "core/Deck.hpp"
#include "models/ModelList.hpp"
#include "models/StressUpdate.hpp"

using namespace tamp;
using tamp::testing::column_config;

namespace {

using MCC = ModifiedCamClay;

MaterialParams mcc(double G, double nu, double lambda, double kappa, double M, double pc0, double v0) {
  MaterialParams m;
  m.model = MCC::id;
  m.density = 1900.0;
  m.shear_modulus = G;
  m.bulk_modulus = bulk_from_shear(G, nu);
  m.model_param[MCC::LAMBDA] = lambda;
  m.model_param[MCC::KAPPA] = kappa;
  m.model_param[MCC::M_CS] = M;
  m.model_param[MCC::PC0] = pc0;
  m.model_param[MCC::V0] = v0;
  return m;
}

double theta(const MaterialParams& m) {
  return m.model_param[MCC::V0] / (m.model_param[MCC::LAMBDA] - m.model_param[MCC::KAPPA]);
}
double pc_of(const MaterialParams& m, double eps_vp) { return m.model_param[MCC::PC0] * std::exp(theta(m) * eps_vp); }

struct PQ {
  double p, q;
};
PQ invariants(const double s[4]) {
  const double p = -(s[RR] + s[ZZ] + s[TT]) / 3.0;
  const double a = s[RR] + p, b = s[ZZ] + p, c = s[TT] + p;
  return {p, std::sqrt(1.5 * (a * a + b * b + c * c + 2 * s[RZ] * s[RZ]))};
}

// The lab clay's elastic constants (G 1.39 MPa, nu 0.31) with critical-state parameters of a
// soft silty clay: lambda 0.2, kappa 0.04, M 0.9, v0 2.2.
MaterialParams soft_clay(double pc0) { return mcc(1.39e6, 0.31, 0.2, 0.04, 0.9, pc0, 2.2); }

}  // namespace

TEST_CASE("ModifiedCamClay: random trial states return onto the yield surface", "[models][cam-clay]") {
  // Random materials and trial stresses (compression and tension, any shear); every state
  // that yields must end on the updated surface, |f| / S^2 < 1e-9 with S the largest stress
  // of the step, max(p_c, p_c before, |p_tr|, q_tr) (the solvers stop at 1e-14 of p_c^2;
  // 1e-9 leaves room for the round-off of rebuilding sigma from p and q). S and not p_c:
  // a tension trial state (p_tr = -222 kPa) returns to the apex with p_c collapsing from
  // 299 kPa to 1e-7 Pa, and p = p_tr - K x then carries a round-off of 1e-11 Pa, 1e-3 of
  // p itself (|f| / p_c^2 = 4e-3, |f| / S^2 = 1e-28). With dgamma >= 0
  // (the plastic volumetric and shear increments have the signs of the flow rule), the
  // deviatoric direction kept, and the same results inside a Kokkos kernel.
  std::mt19937_64 rng(20261201);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const int n = 4000;
  std::vector<MaterialParams> mats(n);
  std::vector<double> sig(4 * n), eps_p(n), eps_v(n);
  for (int i = 0; i < n; ++i) {
    const double lambda = 0.05 + 0.25 * u(rng);
    mats[i] = mcc(std::pow(10.0, 5 + 3 * u(rng)), 0.1 + 0.35 * u(rng), lambda, lambda * (0.05 + 0.5 * u(rng)),
                  0.6 + 1.0 * u(rng), std::pow(10.0, 4 + 2 * u(rng)), 1.5 + 1.5 * u(rng));
    const double pc = mats[i].model_param[MCC::PC0];
    for (int k = 0; k < 3; ++k) sig[4 * i + k] = -pc * (3.0 * u(rng) - 0.5);  // -0.5 pc .. 2.5 pc
    sig[4 * i + 3] = pc * (u(rng) - 0.5);
    eps_p[i] = 0.0;
    eps_v[i] = 0.05 * (u(rng) - 0.5);
  }
  int yielded = 0;
  double worst_f = 0, worst_dir = 0;
  std::vector<double> host(4 * n), host_ev(n), host_ep(n);
  for (int i = 0; i < n; ++i) {
    double s[4] = {sig[4 * i], sig[4 * i + 1], sig[4 * i + 2], sig[4 * i + 3]};
    const PQ tr = invariants(s);
    MaterialState st;
    st.plastic_strain = eps_p[i];
    st.compaction = eps_v[i];
    const double deps[4] = {0, 0, 0, 0};
    const int region = MCC::plastic_correction(mats[i], s, deps, st, 0.0);
    const double ep = st.plastic_strain, ev = st.compaction;
    for (int k = 0; k < 4; ++k) host[4 * i + k] = s[k];
    host_ev[i] = ev;
    host_ep[i] = ep;
    const double pc = pc_of(mats[i], ev);
    const PQ pq = invariants(s);
    const double f = MCC::yield(pq.p, pq.q, pc, mats[i].model_param[MCC::M_CS]);
    if (region == 0) {
      CHECK(MCC::yield(tr.p, tr.q, pc_of(mats[i], eps_v[i]), mats[i].model_param[MCC::M_CS]) <= 0.0);
      continue;
    }
    ++yielded;
    const double S = std::max({pc, pc_of(mats[i], eps_v[i]), std::fabs(tr.p), tr.q});
    worst_f = std::max(worst_f, std::fabs(f) / (S * S));
    CHECK(ep >= eps_p[i]);
    // Deviatoric direction: s = s_tr q / q_tr, so s_rz / q is unchanged.
    if (tr.q > 1e-6 * pc && pq.q > 1e-6 * pc)
      worst_dir = std::max(worst_dir, std::fabs(s[RZ] / pq.q - sig[4 * i + 3] / tr.q));
  }
  std::printf("[cam-clay] random returns: %d of %d yielded, worst |f|/S^2 = %.2e, direction %.2e\n", yielded, n,
              worst_f, worst_dir);
  CHECK(yielded > n / 4);
  CHECK(worst_f < 1e-9);
  CHECK(worst_dir < 1e-9);

  // The same returns in a kernel.
  Kokkos::View<MaterialParams*, MemSpace> dm("mats", n);
  Kokkos::View<double*, MemSpace> ds("sig", 4 * n), dev("ev", n), dep("ep", n);
  auto hm = Kokkos::create_mirror_view(dm);
  auto hs = Kokkos::create_mirror_view(ds);
  auto hv = Kokkos::create_mirror_view(dev);
  auto hp = Kokkos::create_mirror_view(dep);
  for (int i = 0; i < n; ++i) {
    hm(i) = mats[i];
    hv(i) = eps_v[i];
    hp(i) = eps_p[i];
    for (int k = 0; k < 4; ++k) hs(4 * i + k) = sig[4 * i + k];
  }
  Kokkos::deep_copy(dm, hm);
  Kokkos::deep_copy(ds, hs);
  Kokkos::deep_copy(dev, hv);
  Kokkos::deep_copy(dep, hp);
  Kokkos::parallel_for(
      "test::cam_clay", Kokkos::RangePolicy<ExecSpace>(0, n), KOKKOS_LAMBDA(int i) {
        double s[4] = {ds(4 * i), ds(4 * i + 1), ds(4 * i + 2), ds(4 * i + 3)};
        const double deps[4] = {0, 0, 0, 0};
        MaterialState st;
        st.plastic_strain = dep(i);
        st.compaction = dev(i);
        ModifiedCamClay::plastic_correction(dm(i), s, deps, st, 0.0);
        dep(i) = st.plastic_strain;
        dev(i) = st.compaction;
        for (int k = 0; k < 4; ++k) ds(4 * i + k) = s[k];
      });
  Kokkos::deep_copy(hs, ds);
  Kokkos::deep_copy(hv, dev);
  double worst_kernel = 0;
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < 4; ++k)
      worst_kernel = std::max(worst_kernel, std::fabs(hs(4 * i + k) - host[4 * i + k]) / mats[i].model_param[MCC::PC0]);
    worst_kernel = std::max(worst_kernel, std::fabs(hv(i) - host_ev[i]));
  }
  CHECK(worst_kernel < 1e-12);  // the same arithmetic (0 on host back ends; FMA contraction on a GPU)
}

TEST_CASE("ModifiedCamClay: isotropic compression follows the normal compression line", "[models][cam-clay][verification]") {
  // Drained isotropic compression from p0 (elastic while p < p_c0, then on the yield
  // surface's tip q = 0, p = p_c). With linear elasticity and exponential hardening the
  // closed form is eps_v = (p - p0)/K + max(0, ln(p / p_c0)) / theta, theta = v0/(lambda -
  // kappa): the plastic part is v0 d eps_v^p = (lambda - kappa) d ln p, the normal
  // compression line's slope lambda less the elastic kappa. The backward-Euler return
  // integrates it exactly (the hardening is multiplicative), so the tolerance is round-off:
  // 1e-9 of eps_v, for 20 and for 2000 steps. Unloading is elastic (dp = K d eps_v).
  for (const double p0 : {100e3, 50e3}) {  // normally and over-consolidated (OCR 2)
    const MaterialParams m = soft_clay(100e3);
    const double K = m.bulk_modulus;
    for (const int steps : {20, 2000}) {
      double s[4] = {-p0, -p0, -p0, 0.0};
      double ep = 0, ev = 0;
      const double total = 0.08;  // volumetric strain, compression
      double worst = 0;
      for (int k = 1; k <= steps; ++k) {
        const double d = -total / steps / 3.0;
        const double deps[4] = {d, d, d, 0.0};
        update_stress(m, s, deps, 0.0, ep, ev, 0.0);
        const double eps = total * k / steps;
        const double p = invariants(s).p;
        const double exact = (p - p0) / K + std::max(0.0, std::log(p / 100e3)) / theta(m);
        worst = std::max(worst, std::fabs(exact - eps) / eps);
        CHECK(invariants(s).q < 1e-9 * p);
      }
      std::printf("[cam-clay] isotropic p0 %.0f kPa, %d steps: p %.1f kPa at eps_v %.2f, worst %.1e\n", p0 / 1e3,
                  steps, invariants(s).p / 1e3, total, worst);
      CHECK(worst < 1e-9);
      // unload elastically by a tenth of the strain
      const double p_top = invariants(s).p, ev_top = ev;
      const double d = 0.008 / 3.0;
      const double deps[4] = {d, d, d, 0.0};
      update_stress(m, s, deps, 0.0, ep, ev, 0.0);
      CHECK(invariants(s).p == Approx(p_top - K * 0.008).epsilon(1e-12));
      CHECK(ev == ev_top);
    }
  }
}

TEST_CASE("ModifiedCamClay: drained triaxial compression reaches the critical state", "[models][cam-clay][verification]") {
  // Conventional drained triaxial compression of a normally consolidated sample: radial
  // stress held at -p0, axial strain increased. Closed forms (Wood 1990, Soil Behaviour and
  // Critical State Soil Mechanics, ch. 4 and 6; Roscoe & Burland 1968):
  //  - stress path q = 3 (p - p0) (checked to 1e-9 p0: the radial stress is solved for);
  //  - on the yield surface p_c = p + q^2 / (M^2 p), so the volumetric strain is
  //    eps_v = (p - p0)/K + ln(p_c / p_c0)/theta at every state (exact for this return,
  //    as in isotropic compression: 1e-8 of eps_v);
  //  - flow rule d eps_v^p / d eps_q^p = (M^2 - eta^2) / (2 eta), eta = q/p (backward Euler
  //    evaluates it at the end of the step: 1e-8);
  //  - the critical state: q -> M p_cs, p_cs = 3 p0 / (3 - M), reached asymptotically and
  //    slowly (soft clay, lambda = 0.2: q is 7 % short of q_cs at 30 % axial strain); the
  //    strain driver is small-strain, so it is run on to 200 % to test the limit itself:
  //    q within 0.5 % of q_cs there, and never above it.
  const double p0 = 100e3;
  const MaterialParams m = soft_clay(p0);
  const double M = m.model_param[MCC::M_CS], K = m.bulk_modulus;
  double s[4] = {-p0, -p0, -p0, 0.0};
  double ep = 0, ev = 0, eps_v = 0;
  double worst_path = 0, worst_vol = 0, worst_flow = 0, q_max = 0;
  const double da = -1e-4;  // axial strain increment (compression)
  const int steps = 20000;  // 200 %
  double q_30 = 0;
  for (int k = 0; k < steps; ++k) {
    // radial strain increment so that sigma_rr stays -p0 (secant iterations)
    auto trial = [&](double dr, double out[4], double& ep_o, double& ev_o) {
      for (int c = 0; c < 4; ++c) out[c] = s[c];
      ep_o = ep;
      ev_o = ev;
      const double deps[4] = {dr, da, dr, 0.0};
      update_stress(m, out, deps, 0.0, ep_o, ev_o, 0.0);
      return out[RR] + p0;
    };
    double t[4], e1, e2;
    double x0 = 0.0, x1 = -da * 0.5;
    double f0 = trial(x0, t, e1, e2), f1 = trial(x1, t, e1, e2);
    for (int it = 0; it < 100 && std::fabs(f1) > 1e-10 * p0; ++it) {
      const double x2 = x1 - f1 * (x1 - x0) / (f1 - f0);
      x0 = x1; f0 = f1;
      x1 = x2; f1 = trial(x1, t, e1, e2);
    }
    const double ep_old = ep, ev_old = ev;
    trial(x1, s, ep, ev);
    eps_v -= da + 2 * x1;  // compression positive
    const PQ pq = invariants(s);
    q_max = std::max(q_max, pq.q);
    if (k == 2999) q_30 = pq.q;
    worst_path = std::max(worst_path, std::fabs(pq.q - 3 * (pq.p - p0)) / p0);
    const double pc = pq.p + pq.q * pq.q / (M * M * pq.p);
    const double exact = (pq.p - p0) / K + std::log(pc / p0) / theta(m);
    worst_vol = std::max(worst_vol, std::fabs(exact - eps_v) / std::max(eps_v, 1e-12));
    if (ep - ep_old > 1e-12) {
      const double eta = pq.q / pq.p;
      const double ratio = (ev - ev_old) / (ep - ep_old);
      worst_flow = std::max(worst_flow, std::fabs(ratio - (M * M - eta * eta) / (2 * eta)));
    }
  }
  const double p_cs = 3 * p0 / (3 - M), q_cs = M * p_cs;
  const PQ pq = invariants(s);
  std::printf("[cam-clay] triaxial: q %.2f kPa at 30 %%, %.2f kPa at 200 %% (q_cs %.2f, %+.3f %%), eps_v %.4f "
              "(critical state %.4f); path %.1e, volume %.1e, flow rule %.1e\n",
              q_30 / 1e3, pq.q / 1e3, q_cs / 1e3, 100 * (pq.q / q_cs - 1), eps_v,
              (p_cs - p0) / K + std::log(2 * p_cs / p0) / theta(m), worst_path, worst_vol, worst_flow);
  CHECK(worst_path < 1e-9);
  CHECK(worst_vol < 1e-8);
  CHECK(worst_flow < 1e-8);
  CHECK(std::fabs(pq.q / q_cs - 1) < 0.005);
  CHECK(q_max <= q_cs * (1 + 1e-9));
}

TEST_CASE("ModifiedCamClay: declared through the deck", "[models][cam-clay][deck]") {
  const std::string deck = R"(
[sph]
spacing = 0.01
[[materials]]
name = "clay"
model = "modified-cam-clay"
unit_weight = 18.7e3
G = 1.39e6
nu = 0.31
lambda = 0.2
kappa = 0.04
M = 0.9
p_c0 = 8e3
v0 = 2.2
[[blocks]]
material = "clay"
r = [0, 0.05]
z = [0, 0.1]
)";
  const Config c = parse_deck(deck, "mcc.toml");
  const MaterialParams m = make_material(c.materials[0]);
  CHECK(m.model == MCC::id);
  CHECK(m.model_param[MCC::PC0] == 8e3);
  CHECK(m.model_param[MCC::V0] == 2.2);
  // round trip
  const Config d = parse_deck(to_toml(c), "again.toml");
  CHECK(d.materials[0].params == c.materials[0].params);
  // its own rules and ranges, one line naming the key
  auto error = [&](const std::string& from, const std::string& to) {
    std::string text = deck;
    text.replace(text.find(from), from.size(), to);
    try {
      parse_deck(text, "mcc.toml");
    } catch (const DeckError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  CHECK_THAT(error("kappa = 0.04", "kappa = 0.3"), Catch::Contains("materials[0].kappa = 0.3 is out of range") &&
                                                       Catch::Contains("kappa < lambda"));
  CHECK_THAT(error("M = 0.9", "M = 3.5"), Catch::Contains("materials[0].M = 3.5 is out of range"));
  CHECK_THAT(error("v0 = 2.2\n", ""), Catch::Contains("materials[0].v0 is missing"));
  CHECK_THAT(error("lambda = 0.2", "lambda = 0.2\nSu = 1e4"), Catch::Contains("is not used by model \"modified-cam-clay\""));
}

TEST_CASE("ModifiedCamClay: geostatic column in particles tied to elements", "[models][cam-clay][tie][fem][verification]") {
  // The geostatic column of the tie tests (R = 0.05 m, 0.4 m deep, 10 mm; particles above
  // z = 0.2 m, quads below), of Modified Cam-Clay with p_c0 = 8 kPa, so that the lower part
  // yields under its own weight (at the base p ~ 4.7 kPa, q ~ 4.1 kPa with K0 = nu/(1-nu)).
  // Equilibrium does not depend on the model: sigma_v = -gamma d within 2 % near the
  // interface (the elastic column's tolerance), and every particle and element ends inside
  // or on its yield surface (f <= 1e-9 p_c^2).
  const double R = 0.05, L = 0.4, zi = 0.2, dp = 0.01;
  Config cfg = column_config(R, L, dp);
  cfg.materials[0].model = "modified-cam-clay";
  cfg.materials[0].params = {{"lambda", 0.2}, {"kappa", 0.04}, {"M", 0.9}, {"p_c0", 8e3}, {"v0", 2.2}};
  cfg.blocks[0].z_min = zi;
  cfg.bottom = {WallType::None, 0.0};
  cfg.gravity = 9.81;
  const MaterialParams m = make_material(cfg.materials[0]);
  const double c = m.wave_speed();
  cfg.damping = 2 * pi / (4 * L / c);
  Simulation sim(cfg);
  fem::FemBlock b;
  b.r0 = 0; b.r1 = R; b.z0 = 0; b.z1 = zi;
  b.nr = 5; b.nz = 20;
  fem::FemOptions fo;
  fo.gravity = cfg.gravity;
  fo.damping = cfg.damping;
  fem::FemModel model(m, b, fo);
  model.set_side(fem::FemSide::Outer, fem::FemBc::Roller);
  model.set_side(fem::FemSide::Bottom, fem::FemBc::Fixed);
  sim.tie_fem(model, {cfg.materials[0].name});
  sim.advance_to(25 * 4 * L / c);

  const double gamma = m.density * cfg.gravity, M = m.model_param[MCC::M_CS];
  double worst_v_sph = 0, worst_v_fem = 0, worst_f = 0;
  int plastic_elements = 0;
  const ParticleSnapshot s = sim.snapshot();
  auto ev = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), sim.particles().compaction);
  for (size_t i = 0; i < s.r.size(); ++i) {
    const double st[4] = {s.s_rr[i], s.s_zz[i], s.s_tt[i], s.s_rz[i]};
    const PQ pq = invariants(st);
    const double pc = pc_of(m, ev(i));
    worst_f = std::max(worst_f, MCC::yield(pq.p, pq.q, pc, M) / (pc * pc));
    if (s.z[i] >= zi + 0.05) continue;
    worst_v_sph = std::max(worst_v_sph, std::fabs(s.s_zz[i] / (-gamma * (L - s.z[i])) - 1));
  }
  auto st = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), model.mesh().stress);
  auto eve = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), model.mesh().compaction);
  auto x = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), model.mesh().x);
  auto conn = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), model.mesh().conn);
  for (int e = 0; e < model.mesh().n_elements; ++e) {
    const double se[4] = {st(e, 0), st(e, 1), st(e, 2), st(e, 3)};
    const PQ pq = invariants(se);
    const double pc = pc_of(m, eve(e));
    worst_f = std::max(worst_f, MCC::yield(pq.p, pq.q, pc, M) / (pc * pc));
    if (eve(e) > 0) ++plastic_elements;
    double zc = 0;
    for (int q = 0; q < 4; ++q) zc += 0.25 * x(conn(e, q), 1);
    if (zc < zi - 0.05) continue;
    worst_v_fem = std::max(worst_v_fem, std::fabs(st(e, 1) / (-gamma * (L - zc)) - 1));
  }
  std::printf("[cam-clay] geostatic column: sigma_v particles %.2f %%, elements %.2f %%; %d of %d elements "
              "hardened; worst f/pc^2 %.1e\n",
              100 * worst_v_sph, 100 * worst_v_fem, plastic_elements, model.mesh().n_elements, worst_f);
  CHECK(worst_v_sph < 0.02);
  CHECK(worst_v_fem < 0.02);
  CHECK(worst_f < 1e-9);
  CHECK(plastic_elements > 0);  // the model acted, not only its elastic part
}
