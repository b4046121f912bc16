// Measurements of the particle state on the device: what a drop sequence reads at the end of a
// stage (the soil surface, the column of aggregate, the crater's free sites, the top of the
// material under the pounder) and the particle nearest a point. Definitions in
// docs/drop-sequence.md ("What blows.csv records", "The column").
//
// One cell list of the real particles (cells of 1.5 dp, kernels/NeighbourList.hpp) serves
// every search around a particle or a point: no host copy of the particles, no search over
// sites x particles. Maxima and minima are exact whatever the order; sums go through
// kernels/DeterministicSum.hpp, so a measurement is the same on any back end and thread count.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "core/Particles.hpp"
#include "core/Types.hpp"
#include "kernels/DeterministicSum.hpp"
#include "kernels/NeighbourList.hpp"

namespace tamp {

// The aggregate (one material) of the particles in bands of one spacing dp, from its top
// down. The band edges lie at whole spacings from a reference height z_ref = min(z_top +
// dp/2, z_cap): with z_cap the original ground, the bands below the ground are the same
// whatever grains lie heaped above it (issue 11: bands laid from the top grain down moved
// the head's 30 mm by up to half a band between runs that differ by round-off). Band 0 is
// the highest; bands 0 .. first_below - 1 lie above z_ref, band b spans
// (z_edge - (b + 1) dp, z_edge - b dp], z_edge = z_ref + first_below dp.
struct MaterialBands {
  bool any = false;
  double z_top = 0, z_bot = 0;  // highest and lowest particle centre, m
  double z_ref = 0, z_edge = 0;  // the reference height and the top edge of band 0, m
  int first_below = 0;           // index of the first band below z_ref
  double mass_kg = 0;
  std::vector<double> volume_m3;  // sum of m / rho per band (ring volumes)
  // per band: the smallest radius of a particle of any other material that has at least 3
  // such neighbours within 1.5 dp (the wall of the hole the material fills: the clay or
  // sand around the column; a lone entrained particle does not count), m; +inf if none
  std::vector<double> wall_r_m;
};

// A candidate crater site: the centre of cell (column k, any height z) of a regular grid of
// spacing dp, at r = (k + 1/2) dp.
struct CraterSite {
  int column;
  double z;
};

namespace detail {

// The band of height z among bands of one spacing dp below z_ref, `above` of them above it
// (MaterialBands): negative above the highest band.
KOKKOS_INLINE_FUNCTION int band_of(double z, double z_ref, double dp, int above) {
  return static_cast<int>(math::floor((z_ref - z) / dp)) + above;
}

// Particles of `material` (any, when -1) counted within the grid's cut-off of particle i.
struct CountNear {
  CellGrid grid;
  View1<int> material, count;
  int skip;
  KOKKOS_INLINE_FUNCTION void operator()(int i) const {
    if (material(i) == skip) return;
    int n = 0;
    grid.for_each_neighbour(i, [&](int j) { n += material(j) != skip ? 1 : 0; });
    count(i) = n;
  }
};

// top(k) = max over the qualifying particles of radial column k (width dp) of z + dp/2.
struct SurfaceTop {
  ViewN<double, 2> x;
  View1<int> material, count;
  View1<double> top;
  int skip, min_neighbours, columns;
  double dp;
  KOKKOS_INLINE_FUNCTION void operator()(int i) const {
    if (material(i) == skip || count(i) < min_neighbours) return;
    int k = static_cast<int>(x(i, 0) / dp);
    k = k < columns - 1 ? k : columns - 1;
    Kokkos::atomic_fetch_max(&top(k), x(i, 1) + 0.5 * dp);
  }
};

// column_top(k) = highest z among the particles with |r - (k + 1/2) dp| < dp / 2.
struct ColumnTop {
  ViewN<double, 2> x;
  View1<double> column_top;
  int columns;
  double dp;
  KOKKOS_INLINE_FUNCTION void operator()(int i) const {
    const int k0 = static_cast<int>(x(i, 0) / dp);
    for (int k = k0 - 1; k <= k0 + 1; ++k) {
      if (k < 0 || k >= columns) continue;
      if (math::abs(x(i, 0) - (k + 0.5) * dp) < 0.5 * dp) Kokkos::atomic_fetch_max(&column_top(k), x(i, 1));
    }
  }
};

// 1 where some particle lies within the radius of the point.
struct Occupied {
  CellGrid grid;
  ViewN<double, 2> point;
  View1<int> flag;
  double radius2;
  KOKKOS_INLINE_FUNCTION void operator()(int c) const {
    int near = 0;
    grid.for_each_near(point(c, 0), point(c, 1), radius2, [&](int) { near = 1; });
    flag(c) = near;
  }
};

// 1 where no particle lies within the clearance of the site and none above it in its column.
struct FreeSite {
  CellGrid grid;
  View1<int> column;
  View1<double> z, column_top;
  View1<int> free_flag;
  double clearance2, dp;
  KOKKOS_INLINE_FUNCTION void operator()(int c) const {
    int near = 0;
    grid.for_each_near((column(c) + 0.5) * dp, z(c), clearance2, [&](int) { near = 1; });
    free_flag(c) = !near && !(column_top(column(c)) > z(c)) ? 1 : 0;
  }
};

}  // namespace detail

// The real particles binned once; each measurement is a few kernels over them.
class ParticleSurvey {
 public:
  // The first P.n_real particles; the searches around particles or points bin them in cells
  // of 1.5 dp (their reach) once, at the first that needs it.
  ParticleSurvey(const Particles& P, double dp)
      : x_(P.x), mass_(P.mass), rho_(P.rho), material_(P.material), n_(P.n_real), dp_(dp) {}

  int count() const { return n_; }

  // Top of the material other than skip_material (-1: none skipped) in radial columns of
  // width dp out to r_out (ceil(r_out / dp) + 2 columns, the last one collecting all beyond):
  // the highest particle centre + dp/2 among the particles with at least min_neighbours
  // such neighbours within 1.5 dp, so that particles splashed above the crater rim (single,
  // or with 3 in short chains) do not count as ground. -1e300 where a column has none.
  std::vector<double> soil_surface(int skip_material, double r_out, int min_neighbours) const {
    const int columns = static_cast<int>(std::ceil(r_out / dp_)) + 2;
    View1<double> top("tamp::survey::top", columns);
    Kokkos::deep_copy(top, -1e300);
    if (n_ > 0) {
      View1<int> count("tamp::survey::count", n_);
      Kokkos::parallel_for("tamp::survey::count_near", Kokkos::RangePolicy<ExecSpace>(0, n_),
                           detail::CountNear{grid(), material_, count, skip_material});
      Kokkos::parallel_for("tamp::survey::surface", Kokkos::RangePolicy<ExecSpace>(0, n_),
                           detail::SurfaceTop{x_, material_, count, top, skip_material, min_neighbours, columns, dp_});
    }
    return to_host(top);
  }

  // The particles of one material in bands of one spacing with edges at whole spacings from
  // min(z_top + dp/2, z_cap) (MaterialBands).
  MaterialBands bands(int material, double z_cap) const {
    MaterialBands out;
    if (material < 0 || n_ == 0) return out;
    const auto x = x_;
    const auto mat = material_;
    const auto m = mass_;
    const auto rho = rho_;
    using MinMax = Kokkos::MinMax<double>;
    MinMax::value_type zr;
    Kokkos::parallel_reduce(
        "tamp::survey::material_extent", Kokkos::RangePolicy<ExecSpace>(0, n_),
        KOKKOS_LAMBDA(int i, MinMax::value_type& v) {
          if (mat(i) != material) return;
          v.min_val = math::min(v.min_val, x(i, 1));
          v.max_val = math::max(v.max_val, x(i, 1));
        },
        MinMax(zr));
    if (!(zr.min_val <= zr.max_val)) return out;
    out.any = true;
    out.z_top = zr.max_val;
    out.z_bot = zr.min_val;
    const double dp = dp_;
    const double z_ref = std::min(out.z_top + 0.5 * dp, z_cap);
    // a particle's band below z_ref: floor((z_ref - z) / dp), negative above it
    const int above = std::max(0, -static_cast<int>(std::floor((z_ref - out.z_top) / dp)));
    const int nb = static_cast<int>(std::floor((z_ref - out.z_bot) / dp)) + above + 1;
    out.z_ref = z_ref;
    out.first_below = above;
    out.z_edge = z_ref + above * dp;
    // slot 0: the mass; slots 1..nb: the band volumes
    const std::vector<double> sums = fixed_order_sums(
        "tamp::survey::bands", n_, nb + 1, KOKKOS_LAMBDA(int i, double* s) {
          if (mat(i) != material) return;
          const int b0 = detail::band_of(x(i, 1), z_ref, dp, above);
          const int b = b0 < 0 ? 0 : (b0 < nb - 1 ? b0 : nb - 1);  // round-off at the ends
          s[0] += m(i);
          s[1 + b] += m(i) / rho(i);
        });
    out.mass_kg = sums[0];
    out.volume_m3.assign(sums.begin() + 1, sums.end());
    // the wall around it: a minimum, exact in any order
    View1<double> wall("tamp::survey::wall_r", nb);
    Kokkos::deep_copy(wall, std::numeric_limits<double>::infinity());
    View1<int> count("tamp::survey::count", n_);
    Kokkos::parallel_for("tamp::survey::count_near", Kokkos::RangePolicy<ExecSpace>(0, n_),
                         detail::CountNear{grid(), material_, count, material});
    Kokkos::parallel_for(
        "tamp::survey::band_wall", Kokkos::RangePolicy<ExecSpace>(0, n_), KOKKOS_LAMBDA(int i) {
          if (mat(i) == material || count(i) < 3) return;
          const int b = detail::band_of(x(i, 1), z_ref, dp, above);
          if (b >= 0 && b < nb) Kokkos::atomic_fetch_min(&wall(b), x(i, 0));
        });
    out.wall_r_m = to_host(wall);
    return out;
  }

  // Sum of m / rho of the particles of one material with z < z_below, m^3.
  double volume_below(int material, double z_below) const {
    if (material < 0) return 0.0;
    const auto x = x_;
    const auto mat = material_;
    const auto m = mass_;
    const auto rho = rho_;
    return fixed_order_sum<1>("tamp::survey::volume_below", n_, KOKKOS_LAMBDA(int i, double* s) {
      if (mat(i) == material && x(i, 1) < z_below) s[0] += m(i) / rho(i);
    })[0];
  }

  // Particles of each material (indices 0 .. materials - 1).
  std::vector<long> count_by_material(int materials) const {
    const auto mat = material_;
    const std::vector<double> c = fixed_order_sums(
        "tamp::survey::count_by_material", n_, materials, KOKKOS_LAMBDA(int i, double* s) {
          if (mat(i) >= 0 && mat(i) < materials) s[mat(i)] += 1.0;  // exact below 2^53
        });
    return std::vector<long>(c.begin(), c.end());
  }

  // Highest particle centre with r < reach, m (-1e300 when none).
  double highest_within(double reach) const {
    const auto x = x_;
    double top = -1e300;
    Kokkos::parallel_reduce(
        "tamp::survey::highest_within", Kokkos::RangePolicy<ExecSpace>(0, n_),
        KOKKOS_LAMBDA(int i, double& v) {
          if (x(i, 0) < reach) v = math::max(v, x(i, 1));
        },
        Kokkos::Max<double>(top));
    return top;
  }

  // The particle nearest (r, z); of equally near ones the lowest index. -1 when none.
  int nearest(double r, double z) const {
    if (n_ == 0) return -1;
    const auto x = x_;
    double d2min = 1e300;
    Kokkos::parallel_reduce(
        "tamp::survey::nearest_distance", Kokkos::RangePolicy<ExecSpace>(0, n_),
        KOKKOS_LAMBDA(int i, double& v) {
          const double d = (x(i, 0) - r) * (x(i, 0) - r) + (x(i, 1) - z) * (x(i, 1) - z);
          v = math::min(v, d);
        },
        Kokkos::Min<double>(d2min));
    int best = n_;
    Kokkos::parallel_reduce(
        "tamp::survey::nearest_index", Kokkos::RangePolicy<ExecSpace>(0, n_),
        KOKKOS_LAMBDA(int i, int& v) {
          const double d = (x(i, 0) - r) * (x(i, 0) - r) + (x(i, 1) - z) * (x(i, 1) - z);
          if (d == d2min) v = i < v ? i : v;
        },
        Kokkos::Min<int>(best));
    return best < n_ ? best : -1;
  }

  // For each point (r, z), whether a particle lies within `radius` of it (radius at most
  // 1.5 dp, the cells' reach).
  std::vector<int> occupied(const std::vector<std::array<double, 2>>& points, double radius) const {
    const int np = static_cast<int>(points.size());
    if (np == 0) return {};
    ViewN<double, 2> point("tamp::survey::points", np);
    View1<int> flag("tamp::survey::occupied", np);
    auto h = Kokkos::create_mirror_view(point);
    for (int c = 0; c < np; ++c) { h(c, 0) = points[c][0]; h(c, 1) = points[c][1]; }
    Kokkos::deep_copy(point, h);
    Kokkos::parallel_for("tamp::survey::occupied", Kokkos::RangePolicy<ExecSpace>(0, np),
                         detail::Occupied{grid(), point, flag, radius * radius});
    const auto hf = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), flag);
    return std::vector<int>(hf.data(), hf.data() + np);
  }

  // For each site, whether it is free: no particle within `clearance` of it and none above it
  // in its column (|r - r_site| < dp/2, z > z_site): a hole open to the sky, not a void in the
  // soil. clearance at most 1.5 dp (the cells' reach).
  std::vector<int> free_sites(const std::vector<CraterSite>& sites, double clearance) const {
    const int nc = static_cast<int>(sites.size());
    if (nc == 0) return {};
    int columns = 1;
    for (const CraterSite& s : sites) columns = std::max(columns, s.column + 1);
    View1<int> column("tamp::survey::site_column", nc), flag("tamp::survey::site_free", nc);
    View1<double> z("tamp::survey::site_z", nc), column_top("tamp::survey::column_top", columns);
    {
      auto hc = Kokkos::create_mirror_view(column);
      auto hz = Kokkos::create_mirror_view(z);
      for (int c = 0; c < nc; ++c) { hc(c) = sites[c].column; hz(c) = sites[c].z; }
      Kokkos::deep_copy(column, hc);
      Kokkos::deep_copy(z, hz);
    }
    Kokkos::deep_copy(column_top, -1e300);
    if (n_ > 0)
      Kokkos::parallel_for("tamp::survey::column_top", Kokkos::RangePolicy<ExecSpace>(0, n_),
                           detail::ColumnTop{x_, column_top, columns, dp_});
    Kokkos::parallel_for("tamp::survey::free_sites", Kokkos::RangePolicy<ExecSpace>(0, nc),
                         detail::FreeSite{grid(), column, z, column_top, flag, clearance * clearance, dp_});
    const auto h = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), flag);
    return std::vector<int>(h.data(), h.data() + nc);
  }

 private:
  const CellGrid& grid() const {
    if (!binned_) {
      grid_ = cells_.bin(x_, n_, 1.5 * dp_);
      binned_ = true;
    }
    return grid_;
  }
  static std::vector<double> to_host(const View1<double>& v) {
    const auto h = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), v);
    return std::vector<double>(h.data(), h.data() + h.extent(0));
  }

  ViewN<double, 2> x_;
  View1<double> mass_, rho_;
  View1<int> material_;
  int n_;
  double dp_;
  mutable NeighbourList cells_;
  mutable CellGrid grid_;
  mutable bool binned_ = false;
};

}  // namespace tamp
