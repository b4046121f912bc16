// A constitutive model added from outside the engine: von Mises plasticity with linear
// isotropic hardening, whose hardening variable is a history slot it declares itself. This
// file is the whole of it (the checklist of docs/architecture.md "Add a constitutive model",
// walked): the model struct (device update, its history count, its host description), one
// list that registers it beside the engine's models, and its test. No other file of the
// engine knows it; it runs through the particles' stress pass and the elements' pass, which
// take the model list as a template argument, and its slot lives in the particles' and
// elements' history rows (core/Material.hpp kHistorySlots).
//
// Verification: under uniaxial straining (v_z = -c z, v_r = 0; no spin) the deviatoric strain
// path is proportional, and the radial return of linear hardening is then exact whatever the
// step (Simo & Hughes 1998, Computational Inelasticity, section 3.3.1): with the total axial
// strain eps (compression negative), q_trial = 2 G |eps|, and past yield
//   kappa = (2 G |eps| - sigma_y0) / (3 G + H),   q = sigma_y0 + H kappa,
//   sigma_zz = K eps - 2 q / 3,   sigma_rr = sigma_tt = K eps + q / 3.
// The particles' velocity gradient is exact for a linear field (kernel correction), the
// elements' strain increment is B v dt: both give the same increments every step, so the
// numbers must agree to round-off (tolerance 1e-9 of the yield stress, 100 steps).
#include <catch2/catch.hpp>
#include <cmath>
#include <vector>

#include "core/Particles.hpp"
#include "kernels/FemModel.hpp"
#include "kernels/NeighbourList.hpp"
#include "kernels/SphSolid.hpp"
#include "models/ModelList.hpp"
#include "models/StressUpdate.hpp"

using namespace tamp;

namespace {

// The model: its device update, its history slot, its deck description.
struct ToyVonMises {
  static constexpr int id = 7;             // a free MaterialParams::model number
  static constexpr int history_count = 1;  // slot 0: kappa
  enum Slot : int { YIELD = 0, HARDENING = 1 };  // MaterialParams::model_param slots

  KOKKOS_INLINE_FUNCTION static int plastic_correction(const MaterialParams& m, double s[4], const double[4],
                                                       MaterialState& state, double) {
    const double p = (s[0] + s[1] + s[2]) / 3.0;
    const double d0 = s[0] - p, d1 = s[1] - p, d2 = s[2] - p, d3 = s[3];
    const double q = math::sqrt(1.5 * (d0 * d0 + d1 * d1 + d2 * d2 + 2.0 * d3 * d3));
    const double H = m.model_param[HARDENING];
    double& kappa = state.history[0];
    const double f = q - (m.model_param[YIELD] + H * kappa);
    if (!(f > 0.0)) return 0;
    const double dkappa = f / (3.0 * m.shear_modulus + H);
    const double ratio = (q - 3.0 * m.shear_modulus * dkappa) / q;
    s[0] = p + ratio * d0;
    s[1] = p + ratio * d1;
    s[2] = p + ratio * d2;
    s[3] = ratio * d3;
    kappa += dkappa;
    return 1;
  }

  static std::vector<ModelDescription> describe() {
    using namespace ranges;
    ModelDescription d;
    d.name = "toy-von-mises";
    d.kernel = id;
    d.summary = "von Mises with linear isotropic hardening (a test's model)";
    d.keys = {{"yield_stress", "Pa", gt(0), std::nullopt, "initial yield stress in q"},
              {"hardening", "Pa", ge(0), 0.0, "H: yield stress gained per unit kappa"}};
    d.history = {{"kappa", "", "accumulated equivalent plastic strain of the toy"}};
    d.to_params = [](const MaterialSpec& s, MaterialParams& m) {
      m.model_param[YIELD] = model_param(s, "yield_stress");
      m.model_param[HARDENING] = model_param(s, "hardening");
    };
    return {d};
  }
};

// Its one registration line: the engine's models and the toy.
using ModelsWithToy = ModelSet<Elastic, MohrCoulomb, ModifiedCamClay, ToyVonMises>;

constexpr double G = 1.0e6, nu = 0.3, sigma_y0 = 5.0e3, H = 2.0e5;  // Pa, -, Pa, Pa
constexpr double rate = 1.0, dt = 1.0e-4;                            // 1/s, s: strain 1e-4 per step
constexpr int steps = 100;                                          // to eps = -0.01, yield at -0.0025

// The toy's material from its own description, as make_material builds a registered one.
MaterialParams toy_material() {
  const std::vector<ModelDescription> all = describe_models(ModelsWithToy{});  // checks ids and slot counts
  const ModelDescription* toy = nullptr;
  for (const auto& d : all)
    if (d.name == "toy-von-mises") toy = &d;
  REQUIRE(toy != nullptr);
  REQUIRE(toy->history.size() == 1);
  MaterialSpec spec;
  spec.name = "toy";
  spec.model = toy->name;
  spec.params["yield_stress"] = sigma_y0;
  spec.params["hardening"] = H;
  MaterialParams m;
  m.model = toy->kernel;
  m.density = 2000.0;
  m.shear_modulus = G;
  m.bulk_modulus = bulk_from_shear(G, nu);
  toy->to_params(spec, m);
  return m;
}

struct Expected {
  double s_rr, s_zz, kappa;
};

// The closed form above at total axial strain eps (< 0).
Expected uniaxial_strain(const MaterialParams& m, double eps) {
  const double q_trial = 2.0 * G * std::abs(eps);
  const double kappa = q_trial > sigma_y0 ? (q_trial - sigma_y0) / (3.0 * G + H) : 0.0;
  const double q = q_trial > sigma_y0 ? sigma_y0 + H * kappa : q_trial;
  const double p = m.bulk_modulus * eps;
  return {p + q / 3.0, p - 2.0 * q / 3.0, kappa};
}

// Two wrong declarations (namespace scope: a local class has no static members).
struct Miscounted : ToyVonMises {
  static constexpr int id = 8;
  static std::vector<ModelDescription> describe() {
    auto d = ToyVonMises::describe();
    d[0].name = "miscounted";
    d[0].kernel = id;
    d[0].history.clear();
    return d;
  }
};
struct SameId : ToyVonMises {
  static constexpr int id = MODEL_MOHR_COULOMB;
};

}  // namespace


TEST_CASE("Toy model: a linear-hardening von Mises added in a test runs on particles and elements",
          "[models][toy]") {
  const MaterialParams toy = toy_material();
  Kokkos::View<MaterialParams*, MemSpace> materials("toy::materials", 1);
  Kokkos::deep_copy(materials, Kokkos::View<MaterialParams*, HostSpace, Kokkos::MemoryTraits<Kokkos::Unmanaged>>(
                                   const_cast<MaterialParams*>(&toy), 1));
  const double eps_total = -rate * dt * steps;
  const Expected want = uniaxial_strain(toy, eps_total);
  REQUIRE(want.kappa > 0.0);  // the test reaches the plastic range (2 G |eps| = 20 kPa > 5 kPa)
  const double tol = 1e-9 * sigma_y0;

  SECTION("particles: the SPH stress pass") {
    // A 16 x 16 lattice away from the axis; the particles 3 spacings inside see a full kernel.
    const double dp = 0.01, r0 = 0.1;
    const int nr = 16, nz = 16, n = nr * nz;
    Particles P;
    P.reserve(n);
    P.fill_new(0, n);
    P.n_real = P.n_total = n;
    auto x = Kokkos::create_mirror_view(P.x);
    auto v = Kokkos::create_mirror_view(P.v);
    auto mass = Kokkos::create_mirror_view(P.mass);
    auto rho = Kokkos::create_mirror_view(P.rho);
    for (int i = 0; i < nr; ++i)
      for (int j = 0; j < nz; ++j) {
        const int a = i * nz + j;
        x(a, 0) = r0 + (i + 0.5) * dp;
        x(a, 1) = (j + 0.5) * dp;
        v(a, 0) = 0.0;
        v(a, 1) = -rate * x(a, 1);
        rho(a) = toy.density;
        mass(a) = toy.density * 2.0 * M_PI * x(a, 0) * dp * dp;
      }
    Kokkos::deep_copy(P.x, x);
    Kokkos::deep_copy(P.v, v);
    Kokkos::deep_copy(P.mass, mass);
    Kokkos::deep_copy(P.rho, rho);
    SphParams p;
    p.h = 1.3 * dp;
    p.r_min = 0.0;
    NeighbourList list;
    list.build(P.x, n, n, 2.0 * p.h);
    View1<double> pair_factor("toy::pair_factor", list.neighbours.extent(0));
    const Kokkos::View<const MaterialParams*, MemSpace> mats = materials;
    for (int s = 0; s < steps; ++s)
      Kokkos::parallel_for("toy::particles", Kokkos::RangePolicy<ExecSpace>(0, n),
                           StrainRateAndStressT<ModelsWithToy>(P, list, pair_factor, mats, p, dt));
    auto sigma = Kokkos::create_mirror_view_and_copy(HostSpace(), P.sigma);
    auto history = Kokkos::create_mirror_view_and_copy(HostSpace(), P.history);
    auto eps_p = Kokkos::create_mirror_view_and_copy(HostSpace(), P.plastic_strain);
    int checked = 0;
    for (int i = 3; i < nr - 3; ++i)
      for (int j = 3; j < nz - 3; ++j) {
        const int a = i * nz + j;
        CHECK(std::abs(sigma(a, 0) - want.s_rr) < tol);
        CHECK(std::abs(sigma(a, 1) - want.s_zz) < tol);
        CHECK(std::abs(sigma(a, 2) - want.s_rr) < tol);
        CHECK(std::abs(sigma(a, 3)) < tol);
        CHECK(std::abs(history(a, 0) - want.kappa) < 1e-12);
        CHECK(history(a, 1) == 0.0);  // the slot it does not declare is left alone
        CHECK(eps_p(a) == 0.0);       // nor does it touch the standard variables
        ++checked;
      }
    CHECK(checked == 100);
  }

  SECTION("elements: the quad element pass") {
    fem::FemBlock block;
    block.r0 = 0.1; block.r1 = 0.2; block.z0 = 0.0; block.z1 = 0.1;
    block.nr = 4; block.nz = 4;
    fem::FemModel fem(toy, block);
    fem::FemMesh& mesh = fem.mesh();
    auto x = Kokkos::create_mirror_view_and_copy(HostSpace(), mesh.x);
    auto v = Kokkos::create_mirror_view(mesh.v);
    for (int k = 0; k < mesh.n_nodes; ++k) {
      v(k, 0) = 0.0;
      v(k, 1) = -rate * x(k, 1);
    }
    Kokkos::deep_copy(mesh.v, v);
    // Nodes stay where they are: each pass takes the same increment B(x - v dt / 2) v dt,
    // which the element reports as its rate of deformation.
    fem.element_pass_with<ModelsWithToy>(dt, 0.0);
    auto rate_h = Kokkos::create_mirror_view_and_copy(HostSpace(), mesh.strain_rate);
    const double deps_zz = rate_h(0, 1) * dt;
    for (int s = 1; s < steps; ++s) fem.element_pass_with<ModelsWithToy>(dt, 0.0);
    const Expected want_e = uniaxial_strain(toy, deps_zz * steps);
    REQUIRE(std::abs(deps_zz * steps - eps_total) < 1e-3 * std::abs(eps_total));  // the same path, near
    auto stress = Kokkos::create_mirror_view_and_copy(HostSpace(), mesh.stress);
    auto history = Kokkos::create_mirror_view_and_copy(HostSpace(), mesh.history);
    rate_h = Kokkos::create_mirror_view_and_copy(HostSpace(), mesh.strain_rate);
    for (int e = 0; e < mesh.n_elements; ++e) {
      CHECK(std::abs(rate_h(e, 1) * dt - deps_zz) < 1e-15);  // every element the same increment
      CHECK(std::abs(stress(e, 0) - want_e.s_rr) < tol);
      CHECK(std::abs(stress(e, 1) - want_e.s_zz) < tol);
      CHECK(std::abs(stress(e, 2) - want_e.s_rr) < tol);
      CHECK(std::abs(stress(e, 3)) < tol);
      CHECK(std::abs(history(e, 0) - want_e.kappa) < 1e-12);
      CHECK(history(e, 1) == 0.0);
    }
  }
}

TEST_CASE("Toy model: a model that names fewer history variables than it keeps is refused", "[models][toy]") {
  CHECK_THROWS_WITH(describe_models(ModelSet<Elastic, Miscounted>{}),
                    Catch::Contains("names 0 history variables, keeps 1"));
  CHECK_THROWS_WITH(describe_models(ModelSet<MohrCoulomb, SameId>{}), Catch::Contains("two models have id"));
}
