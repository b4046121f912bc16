// Throughput of the full SPH step (neighbour search with Verlet skin, strain rate and
// stress update with Mohr-Coulomb/Tresca, accelerations, integration) on an axisymmetric
// block of the lab clay (0.5 m radius and height) under gravity, fixed base and roller
// side, starting from the K0 geostatic stress (a soil at rest: the work per particle and
// step does not depend on the spacing); the particle count sets the spacing.
//   bench_sph [--sizes 10000,40000,160000] [--steps 200] [--repeats 5]
// Prints one line per size: particles, steps, median wall s, particle-steps/s.
// Threads: from OMP_NUM_THREADS (perf/run-bench runs 1 and 2).
#include <Kokkos_Core.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "drivers/sequence/LabMaterials.hpp"
#include "kernels/solver/Simulation.hpp"

using namespace tamp;

// The same physical block (0.5 m x 0.5 m) at every size, so that the stress state, and
// with it the work per particle (plastic returns, artificial stress), is the same.
static Config block_config(int n_target) {
  const double L = 0.5;
  const int side = static_cast<int>(std::lround(std::sqrt(double(n_target))));
  const double dp = L / side;
  Config c;
  c.sph.spacing = dp;
  c.gravity = 9.81;
  c.damping = 0.0;
  const MaterialSpec clay = lab::clay("tresca");
  c.materials = {clay};
  BlockSpec b;
  b.material = "clay";
  b.r_min = 0; b.r_max = L; b.z_min = 0; b.z_max = L;
  c.blocks = {b};
  c.bottom = {WallType::Fixed, 0.0};
  c.outer = {WallType::Roller, L};
  c.sph.regularise_every = 25;
  return c;
}

int main(int argc, char** argv) {
  std::vector<int> sizes = {10000, 40000, 160000};
  int steps = 200, repeats = 5;
  for (int k = 1; k < argc; ++k) {
    if (!std::strcmp(argv[k], "--sizes") && k + 1 < argc) {
      sizes.clear();
      std::stringstream ss(argv[++k]);
      std::string item;
      while (std::getline(ss, item, ',')) sizes.push_back(std::stoi(item));
    } else if (!std::strcmp(argv[k], "--steps") && k + 1 < argc) {
      steps = std::stoi(argv[++k]);
    } else if (!std::strcmp(argv[k], "--repeats") && k + 1 < argc) {
      repeats = std::stoi(argv[++k]);
    }
  }
  Kokkos::initialize(argc, argv);
  {
    std::printf("# exec space %s, concurrency %d\n", ExecSpace::name(), ExecSpace().concurrency());
    std::printf("# particles  steps  median_wall_s  particle_steps_per_s  list_builds  neighbours_per_particle\n");
    for (int n : sizes) {
      std::vector<double> walls;
      long builds = 0;
      int np = 0;
      double npp = 0;
      for (int r = 0; r < repeats; ++r) {
        Simulation sim(block_config(n));
        sim.set_geostatic_stress();  // start at rest: the same steady work at every size
        for (int k = 0; k < 10; ++k) sim.step();  // warm-up (first touch, list growth)
        Kokkos::fence();
        const long b0 = sim.neighbour_list_builds();
        const auto t0 = std::chrono::steady_clock::now();
        for (int k = 0; k < steps; ++k) sim.step();
        Kokkos::fence();
        walls.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
        builds = sim.neighbour_list_builds() - b0;
        np = sim.particle_count();
        npp = sim.mean_neighbours();
      }
      std::sort(walls.begin(), walls.end());
      const double med = walls[walls.size() / 2];
      std::printf("%10d  %5d  %13.4f  %20.4e  %11ld  %6.1f\n", np, steps, med, double(np) * steps / med, builds, npp);
      std::fflush(stdout);
    }
  }
  Kokkos::finalize();
  return 0;
}
