// Verification 1: the cell-list neighbour search returns exactly the brute-force pairs.
#include <catch2/catch.hpp>
#include <algorithm>
#include <random>
#include <set>
#include <vector>

#include "kernels/NeighbourList.hpp"

using namespace tamp;

namespace {

// Compares the device list with an O(n^2) host search. Exact: both use the same
// floating-point test |x_i - x_j|^2 < rc^2, so no tolerance is needed.
void check_against_brute_force(const std::vector<double>& r, const std::vector<double>& z, int n_query,
                               double rc) {
  const int n = static_cast<int>(r.size());
  ViewN<double, 2> x("x", n);
  auto hx = Kokkos::create_mirror_view(x);
  for (int i = 0; i < n; ++i) { hx(i, 0) = r[i]; hx(i, 1) = z[i]; }
  Kokkos::deep_copy(x, hx);
  NeighbourList nl;
  nl.build(x, n, n_query, rc);
  auto off = Kokkos::create_mirror_view_and_copy(HostSpace(), nl.offsets);
  auto nb = Kokkos::create_mirror_view_and_copy(HostSpace(), nl.neighbours);
  long pairs = 0;
  for (int i = 0; i < n_query; ++i) {
    std::vector<int> expect;
    for (int j = 0; j < n; ++j) {
      if (j == i) continue;
      const double dr = r[i] - r[j], dz = z[i] - z[j];
      if (dr * dr + dz * dz < rc * rc) expect.push_back(j);
    }
    std::vector<int> got(nb.data() + off(i), nb.data() + off(i + 1));
    std::vector<int> sorted_got = got;
    std::sort(sorted_got.begin(), sorted_got.end());
    REQUIRE(std::adjacent_find(sorted_got.begin(), sorted_got.end()) == sorted_got.end());  // no duplicates
    REQUIRE(sorted_got == expect);
    pairs += static_cast<long>(expect.size());
  }
  CHECK(nl.pair_count() == pairs);
}

}  // namespace

TEST_CASE("Neighbours: random particles match brute force", "[neighbours]") {
  std::mt19937 gen(42);
  std::uniform_real_distribution<double> ur(0.0, 0.3), uz(-0.1, 0.2);
  std::vector<double> r, z;
  for (int i = 0; i < 3000; ++i) { r.push_back(ur(gen)); z.push_back(uz(gen)); }
  check_against_brute_force(r, z, 3000, 0.013);
  check_against_brute_force(r, z, 1200, 0.031);  // only the first 1200 are queried
}

TEST_CASE("Neighbours: particles on cell edges, on the axis and mirrored across it", "[neighbours]") {
  // A lattice whose spacing equals the cut-off puts particles exactly on cell faces and at
  // exactly the cut-off distance (which must be excluded: the test is strict).
  const double rc = 0.02;
  std::vector<double> r, z;
  for (int i = 0; i < 20; ++i)
    for (int j = 0; j < 20; ++j) { r.push_back(i * rc); z.push_back(j * rc); }
  // particles on the axis and their mirror images at negative r
  std::mt19937 gen(7);
  std::uniform_real_distribution<double> u(0.0, 0.4);
  for (int k = 0; k < 200; ++k) {
    const double zz = u(gen), rr = 0.1 * rc * (k % 5);
    r.push_back(rr); z.push_back(zz);
    r.push_back(-rr); z.push_back(zz);
  }
  // half-spacing lattice: distances of exactly rc/2 and rc
  for (int i = 0; i < 10; ++i) { r.push_back(0.5 * rc * i); z.push_back(0.5 * rc); }
  check_against_brute_force(r, z, static_cast<int>(r.size()), rc);
}
