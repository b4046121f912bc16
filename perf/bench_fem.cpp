// FEM nodal force assembly: ScatterView (duplicated per thread on the host) against atomic
// additions, on a structured block of the elastic lab clay (issue 3: "measure which is
// faster here"). Prints element-steps per second, median of the repeats.
//   bench_fem [--elements 10000,40000,160000] [--steps 200] [--repeats 5]
#include <Kokkos_Core.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "kernels/FemModel.hpp"
#include "drivers/sequence/LabMaterials.hpp"
#include "kernels/solver/Simulation.hpp"

using namespace tamp;
using namespace tamp::fem;

int main(int argc, char** argv) {
  Kokkos::initialize(argc, argv);
  {
    std::vector<int> sizes = {10000, 40000, 160000};
    int steps = 200, repeats = 5;
    for (int i = 1; i + 1 < argc; i += 2) {
      if (!std::strcmp(argv[i], "--elements")) {
        sizes.clear();
        std::stringstream ss(argv[i + 1]);
        std::string item;
        while (std::getline(ss, item, ',')) sizes.push_back(std::stoi(item));
      } else if (!std::strcmp(argv[i], "--steps")) {
        steps = std::stoi(argv[i + 1]);
      } else if (!std::strcmp(argv[i], "--repeats")) {
        repeats = std::stoi(argv[i + 1]);
      }
    }
    const MaterialParams m = make_material(lab::clay("elastic"));
    std::printf("# exec space %s, concurrency %d\n", ExecSpace::name(), ExecSpace().concurrency());
    std::printf("# elements  steps  scatter_median_s  atomic_median_s  scatter_elem_steps_per_s  atomic_elem_steps_per_s  atomic/scatter_time\n");
    for (int n : sizes) {
      const int nr = std::max(1, static_cast<int>(std::lround(std::sqrt(double(n)))));
      FemBlock b;
      b.r0 = 0; b.r1 = 0.5; b.z0 = 0; b.z1 = 0.5;
      b.nr = nr; b.nz = nr;
      double med[2];
      for (int mode = 0; mode < 2; ++mode) {
        std::vector<double> t;
        for (int r = 0; r < repeats; ++r) {
          FemOptions o;
          o.gravity = 9.81;
          o.assembly = mode == 0 ? ASSEMBLY_SCATTER : ASSEMBLY_ATOMIC;
          FemModel model(m, b, o);
          model.set_side(FemSide::Bottom, FemBc::Fixed);
          model.set_side(FemSide::Outer, FemBc::Roller);
          model.step();  // warm-up (first forces)
          Kokkos::fence();
          const auto t0 = std::chrono::steady_clock::now();
          for (int k = 0; k < steps; ++k) model.step();
          Kokkos::fence();
          t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
        }
        std::sort(t.begin(), t.end());
        med[mode] = t[t.size() / 2];
      }
      const double work = double(nr) * nr * steps;
      std::printf("%10d %6d %17.4f %16.4f %25.4e %24.4e %20.3f\n", nr * nr, steps, med[0], med[1], work / med[0],
                  work / med[1], med[1] / med[0]);
    }
  }
  Kokkos::finalize();
}
