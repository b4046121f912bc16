// Mirror (ghost) particles: the ghosts of the axis, a base and an outer wall are exactly
// the points of the continued lattice within the band around the domain, corners included.
#include <catch2/catch.hpp>
#include <cmath>
#include <set>
#include <utility>

#include "SphTestUtil.hpp"

using namespace tamp;
using namespace tamp::testing;

TEST_CASE("Mirror: ghosts are the continued lattice within the band, corner images included", "[mirror][neighbours]") {
  // A 10 x 12 lattice (dp = 0.01 m, centres at (i + 1/2) dp) with the axis r = 0, a fixed
  // base z = 0 and a roller outer wall r = R. Every lattice point outside the block with
  // r in (-band, R + band) and z in (-band, H) must be a ghost exactly once, and nothing
  // else: the corners below the base at the axis and at the outer wall need images of
  // images (until 2026-11-22 the outer-wall corner ones went missing: docs/sph.md).
  const double dp = 0.01, R = 0.10, H = 0.12;
  Config cfg = column_config(R, H, dp);
  Simulation sim(cfg);
  const double band = 2.0 * sim.smoothing_length() + cfg.sph.neighbour_skin * sim.smoothing_length();
  Particles& P = sim.particles();
  auto x = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), P.x);
  std::multiset<std::pair<long, long>> ghosts;
  for (int g = P.n_real; g < P.n_total; ++g)
    ghosts.insert({std::lround(x(g, 0) / dp - 0.5), std::lround(x(g, 1) / dp - 0.5)});
  std::multiset<std::pair<long, long>> expected;
  const long lo = -static_cast<long>(std::ceil(band / dp)) - 1, hi_r = std::lround(R / dp) + 1 - lo,
             hi_z = std::lround(H / dp);
  for (long i = lo; i < hi_r; ++i)
    for (long j = lo; j < hi_z; ++j) {
      const double r = (i + 0.5) * dp, z = (j + 0.5) * dp;
      const bool inside = r > 0 && r < R && z > 0 && z < H;
      if (!inside && r > -band && r < R + band && z > -band && z < H) expected.insert({i, j});
    }
  int corner_base_outer = 0, corner_base_axis = 0;
  for (const auto& [i, j] : ghosts) {
    if (j < 0 && (i + 0.5) * dp > R) ++corner_base_outer;
    if (j < 0 && i < 0) ++corner_base_axis;
  }
  INFO("ghosts " << ghosts.size() << ", expected " << expected.size() << "; below the base: at the outer wall "
                 << corner_base_outer << ", at the axis " << corner_base_axis);
  CHECK(corner_base_outer > 0);
  CHECK(corner_base_axis > 0);
  CHECK(ghosts == expected);

  // After a forced rebuild (the list rebuilds during a run) the set is the same.
  sim.step();
  auto x2 = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), P.x);
  std::multiset<std::pair<long, long>> again;
  for (int g = P.n_real; g < P.n_total; ++g)
    again.insert({std::lround(x2(g, 0) / dp - 0.5), std::lround(x2(g, 1) / dp - 0.5)});
  CHECK(again == expected);
}
