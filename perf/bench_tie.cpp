// Time per step of a tied model and its split between the particles (SPH), the elements
// (FEM), the tie and the neighbour search (issue 3, performance). The model: a column of the
// elastic lab clay, R = 0.2 m, particles for z in [0.4, 0.8] m on elements for z in [0, 0.4] m
// (element size = particle spacing, the tested configuration), roller side, fixed FEM base,
// gravity. Default spacings: 10 mm (the lab default) and 2.5 mm (the paper's SPH spacing).
//   bench_tie [--spacings 0.01,0.0025] [--steps 200] [--repeats 3]
// With --deck, the coupled lab domain of a deck with [fem] (examples/lab-geostatic.toml) at
// the resolutions "particle spacing:element size" (m) listed; element size 0 = the same deck
// all in particles, for comparison:
//   bench_tie --deck examples/lab-geostatic.toml --resolutions 0.01:0.01,0.01:0,0.0025:0.01
#include <Kokkos_Core.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "core/Deck.hpp"
#include "kernels/FemModel.hpp"
#include "drivers/sequence/LabMaterials.hpp"
#include "kernels/solver/Simulation.hpp"

using namespace tamp;

int main(int argc, char** argv) {
  Kokkos::initialize(argc, argv);
  {
    std::vector<double> spacings = {0.01, 0.0025};
    std::vector<std::pair<double, double>> resolutions = {{0.01, 0.01}, {0.01, 0.0}, {0.0025, 0.01}, {0.0025, 0.0025}, {0.0025, 0.0}};
    std::string deck;
    int steps = 200, repeats = 3;
    for (int i = 1; i + 1 < argc; i += 2) {
      if (!std::strcmp(argv[i], "--spacings")) {
        spacings.clear();
        std::stringstream ss(argv[i + 1]);
        std::string item;
        while (std::getline(ss, item, ',')) spacings.push_back(std::stod(item));
      } else if (!std::strcmp(argv[i], "--steps")) {
        steps = std::stoi(argv[i + 1]);
      } else if (!std::strcmp(argv[i], "--repeats")) {
        repeats = std::stoi(argv[i + 1]);
      } else if (!std::strcmp(argv[i], "--deck")) {
        deck = argv[i + 1];
      } else if (!std::strcmp(argv[i], "--resolutions")) {
        resolutions.clear();
        std::stringstream ss(argv[i + 1]);
        std::string item;
        while (std::getline(ss, item, ',')) {
          const auto colon = item.find(':');
          resolutions.push_back({std::stod(item.substr(0, colon)), std::stod(item.substr(colon + 1))});
        }
      }
    }
    if (!deck.empty()) {  // the coupled lab domain
      std::printf("# %s; exec space %s, concurrency %d; %d steps from the geostatic state, median of %d\n", deck.c_str(),
                  ExecSpace::name(), ExecSpace().concurrency(), steps, repeats);
      std::printf("# spacing_m element_m particles elements tie_particles  ms_per_step  dt_s  sph%%  fem%%  tie%%  search%%  other%%\n");
      for (auto [dp, he] : resolutions) {
        std::vector<double> total;
        StepProfile best;
        int np = 0, ne = 0, nt = 0;
        double dt = 0;
        for (int r = 0; r < repeats; ++r) {
          Config cfg = load_deck(deck);
          cfg.sph.spacing = dp;
          cfg.fem.enabled = he > 0;
          cfg.fem.element_size = he;
          Simulation sim(cfg);
          for (int k = 0; k < 5; ++k) sim.step();  // warm-up
          sim.set_profiling(true);
          for (int k = 0; k < steps; ++k) sim.step();
          const StepProfile& p = sim.profile();
          const double t = p.sph() + p.fem + p.tie + p.search + p.other;
          total.push_back(t);
          if (total.size() == 1 || t <= *std::min_element(total.begin(), total.end())) best = p;
          np = sim.particle_count(); ne = sim.fem() ? sim.fem()->mesh().n_elements : 0; nt = sim.tie_particle_count();
          dt = sim.last_dt();
        }
        std::sort(total.begin(), total.end());
        const double med = total[total.size() / 2];
        const double t = best.sph() + best.fem + best.tie + best.search + best.other;
        std::printf("%10.4f %9.4f %9d %8d %13d %12.3f %9.3g %5.1f %5.1f %5.1f %8.1f %7.1f\n", dp, he, np, ne, nt,
                    1e3 * med / steps, dt, 100 * best.sph() / t, 100 * best.fem / t, 100 * best.tie / t,
                    100 * best.search / t, 100 * best.other / t);
        std::fflush(stdout);
      }
      spacings.clear();
    }
    if (!spacings.empty())
      std::printf("# exec space %s, concurrency %d; %d steps, median of %d\n# spacing_m particles elements tie_particles  ms_per_step  sph%%  fem%%  tie%%  search%%  other%%\n",
                  ExecSpace::name(), ExecSpace().concurrency(), steps, repeats);
    const double R = 0.2, L = 0.8, zi = 0.4;
    for (double dp : spacings) {
      std::vector<double> total;
      StepProfile best;
      int np = 0, ne = 0, nt = 0;
      for (int r = 0; r < repeats; ++r) {
        Config cfg;
        cfg.run.name = "bench_tie";
        cfg.sph.spacing = dp;
        cfg.gravity = 9.81;
        cfg.materials = {lab::clay("elastic")};
        BlockSpec b;
        b.material = cfg.materials[0].name;
        b.r_min = 0; b.r_max = R; b.z_min = zi; b.z_max = L;
        cfg.blocks = {b};
        cfg.outer = {WallType::Roller, R};
        Simulation sim(cfg);
        fem::FemBlock fb;
        fb.r0 = 0; fb.r1 = R; fb.z0 = 0; fb.z1 = zi;
        fb.nr = static_cast<int>(std::lround(R / dp));
        fb.nz = static_cast<int>(std::lround(zi / dp));
        fem::FemOptions fo;
        fo.gravity = cfg.gravity;
        fem::FemModel model(make_material(cfg.materials[0]), fb, fo);
        model.set_side(fem::FemSide::Outer, fem::FemBc::Roller);
        model.set_side(fem::FemSide::Bottom, fem::FemBc::Fixed);
        sim.tie_fem(model, {cfg.materials[0].name});
        for (int k = 0; k < 5; ++k) sim.step();  // warm-up
        sim.set_profiling(true);
        for (int k = 0; k < steps; ++k) sim.step();
        const StepProfile& p = sim.profile();
        const double t = p.sph() + p.fem + p.tie + p.search + p.other;
        total.push_back(t);
        if (total.size() == 1 || t <= *std::min_element(total.begin(), total.end())) best = p;
        np = sim.particle_count(); ne = fb.nr * fb.nz; nt = sim.tie_particle_count();
      }
      std::sort(total.begin(), total.end());
      const double med = total[total.size() / 2];
      const double t = best.sph() + best.fem + best.tie + best.search + best.other;
      std::printf("%10.4f %9d %8d %13d %12.3f %5.1f %5.1f %5.1f %8.1f %7.1f\n", dp, np, ne, nt, 1e3 * med / steps,
                  100 * best.sph() / t, 100 * best.fem / t, 100 * best.tie / t, 100 * best.search / t, 100 * best.other / t);
    }
  }
  Kokkos::finalize();
}
