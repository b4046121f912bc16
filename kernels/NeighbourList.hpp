// Cell-linked-list neighbour search built on the device, and a compressed (CSR) list of
// neighbours for the first `n_query` particles. Steps (all parallel):
//   bounding box (reduce) -> cell of each particle, atomic count per cell -> exclusive
//   scan -> scatter into cell order -> sort each cell (so lists are deterministic) ->
//   count neighbours within the cut-off -> scan -> fill.
// No host loop over particles; the host only resizes buffers between kernels.
#pragma once
#include "core/Types.hpp"

namespace tamp {

// The binned particles: visits every particle within the cut-off of particle i, or within
// a radius up to the cut-off of any point (the stage-end measurements, the tie's search).
struct CellGrid {
  ViewN<double, 2> x;
  View1<int> cell_of, cell_start, sorted;
  int nr = 0, nz = 0;
  double rc2 = 0;
  double r_min = 0, z_min = 0, cell = 1;  // the grid: cells of side `cell` from (r_min, z_min)

  template <class F>
  KOKKOS_INLINE_FUNCTION void for_each_neighbour(int i, F&& on_pair) const {
    const int c = cell_of(i);
    const double xi = x(i, 0), zi = x(i, 1);
    visit(c % nr, c / nr, xi, zi, rc2, i, on_pair);
  }

  // Every particle j with |x_j - (r, z)|^2 < radius2 (radius at most the cut-off).
  template <class F>
  KOKKOS_INLINE_FUNCTION void for_each_near(double r, double z, double radius2, F&& on_particle) const {
    if (nr == 0) return;
    visit(cell_r(r), cell_z(z), r, z, radius2, -1, on_particle);
  }

  // The cell of a point, clamped into the grid (as the binning clamps).
  KOKKOS_INLINE_FUNCTION int cell_r(double r) const {
    const int ir = static_cast<int>((r - r_min) / cell);
    return ir < 0 ? 0 : (ir >= nr ? nr - 1 : ir);
  }
  KOKKOS_INLINE_FUNCTION int cell_z(double z) const {
    const int iz = static_cast<int>((z - z_min) / cell);
    return iz < 0 ? 0 : (iz >= nz ? nz - 1 : iz);
  }

 private:
  template <class F>
  KOKKOS_INLINE_FUNCTION void visit(int ir, int iz, double xi, double zi, double radius2, int skip, F& on_pair) const {
    for (int jz = iz - 1; jz <= iz + 1; ++jz) {
      if (jz < 0 || jz >= nz) continue;
      for (int jr = ir - 1; jr <= ir + 1; ++jr) {
        if (jr < 0 || jr >= nr) continue;
        const int cc = jz * nr + jr;
        for (int k = cell_start(cc); k < cell_start(cc + 1); ++k) {
          const int j = sorted(k);
          if (j == skip) continue;
          const double dr = xi - x(j, 0), dz = zi - x(j, 1);
          if (dr * dr + dz * dz < radius2) on_pair(j);
        }
      }
    }
  }
};

class NeighbourList {
 public:
  // Neighbours of particle i (i < n_query) are entries [offsets(i), offsets(i+1)) of
  // `neighbours`; i itself is excluded. Pairs are those with |x_i - x_j| < cutoff.
  View1<int> offsets;
  View1<int> neighbours;
  int n_query = 0;
  double cutoff = 0;

  // x: positions of n_total particles (r, z). Query particles are [0, n_query).
  void build(const ViewN<double, 2>& x, int n_total, int n_query, double cutoff_m);

  // Only the cell list of the first n_total particles (no pair list): for searches around
  // points (kernels/Measurements.hpp). The grid is valid until the particles move or the
  // next bin / build.
  CellGrid bin(const ViewN<double, 2>& x, int n_total, double cutoff_m);

  // Total number of stored pairs (i, j), each direction counted.
  int pair_count() const { return n_pairs_; }

 private:
  View1<int> cell_of_, cell_count_, cell_start_, cell_cursor_, sorted_, count_;
  int n_pairs_ = 0;
};

inline CellGrid NeighbourList::bin(const ViewN<double, 2>& x, int n_total, double cutoff_m) {
  using policy = Kokkos::RangePolicy<ExecSpace>;
  if (n_total <= 0) return CellGrid{};

  // 1. bounding box
  using MinMax = Kokkos::MinMax<double>;
  MinMax::value_type rb, zb;
  Kokkos::parallel_reduce(
      "tamp::nl::bbox_r", policy(0, n_total),
      KOKKOS_LAMBDA(int i, MinMax::value_type& m) {
        m.min_val = math::min(m.min_val, x(i, 0));
        m.max_val = math::max(m.max_val, x(i, 0));
      },
      MinMax(rb));
  Kokkos::parallel_reduce(
      "tamp::nl::bbox_z", policy(0, n_total),
      KOKKOS_LAMBDA(int i, MinMax::value_type& m) {
        m.min_val = math::min(m.min_val, x(i, 1));
        m.max_val = math::max(m.max_val, x(i, 1));
      },
      MinMax(zb));
  const double rmin = rb.min_val, rmax = rb.max_val, zmin = zb.min_val, zmax = zb.max_val;
  const double cell = cutoff_m;
  const int nr = static_cast<int>((rmax - rmin) / cell) + 1;
  const int nz = static_cast<int>((zmax - zmin) / cell) + 1;
  const int ncell = nr * nz;

  if (static_cast<int>(cell_of_.extent(0)) < n_total) {
    cell_of_ = View1<int>("tamp::nl::cell_of", n_total);
    sorted_ = View1<int>("tamp::nl::sorted", n_total);
  }
  if (static_cast<int>(cell_count_.extent(0)) < ncell + 1) {
    cell_count_ = View1<int>("tamp::nl::cell_count", ncell + 1);
    cell_start_ = View1<int>("tamp::nl::cell_start", ncell + 1);
    cell_cursor_ = View1<int>("tamp::nl::cell_cursor", ncell + 1);
  }

  auto cell_of = cell_of_;
  auto cell_count = cell_count_;
  auto cell_start = cell_start_;
  auto cell_cursor = cell_cursor_;
  auto sorted = sorted_;
  Kokkos::deep_copy(cell_count, 0);
  Kokkos::deep_copy(cell_cursor, 0);

  // 2. cell of each particle, counted
  Kokkos::parallel_for(
      "tamp::nl::bin", policy(0, n_total), KOKKOS_LAMBDA(int i) {
        int ir = static_cast<int>((x(i, 0) - rmin) / cell);
        int iz = static_cast<int>((x(i, 1) - zmin) / cell);
        ir = ir < 0 ? 0 : (ir >= nr ? nr - 1 : ir);
        iz = iz < 0 ? 0 : (iz >= nz ? nz - 1 : iz);
        const int c = iz * nr + ir;
        cell_of(i) = c;
        Kokkos::atomic_add(&cell_count(c), 1);  // atomic_increment is deprecated in Kokkos 4
      });
  // 3. exclusive scan of counts -> first slot of each cell (cell_start(ncell) = n_total)
  Kokkos::parallel_scan(
      "tamp::nl::cell_scan", policy(0, ncell + 1),
      KOKKOS_LAMBDA(int c, int& partial, bool final) {
        const int cnt = (c < ncell) ? cell_count(c) : 0;
        if (final) cell_start(c) = partial;
        partial += cnt;
      });
  // 4. scatter into cell order
  Kokkos::parallel_for(
      "tamp::nl::scatter", policy(0, n_total), KOKKOS_LAMBDA(int i) {
        const int c = cell_of(i);
        const int slot = Kokkos::atomic_fetch_add(&cell_cursor(c), 1);
        sorted(cell_start(c) + slot) = i;
      });
  // 5. sort each cell by index (cells hold a handful of particles): deterministic lists
  Kokkos::parallel_for(
      "tamp::nl::cell_sort", policy(0, ncell), KOKKOS_LAMBDA(int c) {
        const int b = cell_start(c), e = cell_start(c + 1);
        for (int k = b + 1; k < e; ++k) {
          const int key = sorted(k);
          int m = k - 1;
          while (m >= b && sorted(m) > key) {
            sorted(m + 1) = sorted(m);
            --m;
          }
          sorted(m + 1) = key;
        }
      });
  CellGrid grid;
  grid.x = x; grid.cell_of = cell_of; grid.cell_start = cell_start; grid.sorted = sorted;
  grid.nr = nr; grid.nz = nz; grid.rc2 = cutoff_m * cutoff_m;
  grid.r_min = rmin; grid.z_min = zmin; grid.cell = cell;
  return grid;
}

inline void NeighbourList::build(const ViewN<double, 2>& x, int n_total, int n_query_in,
                                 double cutoff_m) {
  n_query = n_query_in;
  cutoff = cutoff_m;
  using policy = Kokkos::RangePolicy<ExecSpace>;
  const CellGrid grid = bin(x, n_total, cutoff_m);
  if (static_cast<int>(count_.extent(0)) < n_query + 1) count_ = View1<int>("tamp::nl::count", n_query + 1);
  if (static_cast<int>(offsets.extent(0)) < n_query + 1) offsets = View1<int>("tamp::nl::offsets", n_query + 1);

  // 6. count, scan, fill: one functor body used twice
  auto count = count_;
  auto offs = offsets;
  const int nq = n_query_in;  // not the member: a device lambda must not capture `this`
  Kokkos::parallel_for(
      "tamp::nl::count", policy(0, n_query), KOKKOS_LAMBDA(int i) {
        int n = 0;
        grid.for_each_neighbour(i, [&](int) { ++n; });
        count(i) = n;
      });
  Kokkos::parallel_scan(
      "tamp::nl::offsets", policy(0, n_query + 1),
      KOKKOS_LAMBDA(int i, int& partial, bool final) {
        const int cnt = (i < nq) ? count(i) : 0;
        if (final) offs(i) = partial;
        partial += cnt;
      });
  int total = 0;
  Kokkos::deep_copy(total, Kokkos::subview(offs, n_query));
  n_pairs_ = total;
  if (static_cast<int>(neighbours.extent(0)) < total)
    neighbours = View1<int>("tamp::nl::neighbours", total + total / 8 + 16);
  auto nbr = neighbours;
  Kokkos::parallel_for(
      "tamp::nl::fill", policy(0, n_query), KOKKOS_LAMBDA(int i) {
        int k = offs(i);
        grid.for_each_neighbour(i, [&](int j) { nbr(k++) = j; });
      });
  Kokkos::fence();
}

// max_i |x_i - x_ref_i|^2 over the first n particles: the lists stay valid while no particle
// has moved half the skin since they were built.
inline double max_displacement_sq(const ViewN<double, 2>& x, const ViewN<double, 2>& x_ref, int n) {
  double dmax = 0;
  Kokkos::parallel_reduce(
      "tamp::nl::max_displacement", Kokkos::RangePolicy<ExecSpace>(0, n),
      KOKKOS_LAMBDA(int i, double& m) {
        const double dr = x(i, 0) - x_ref(i, 0), dz = x(i, 1) - x_ref(i, 1);
        m = math::max(m, dr * dr + dz * dz);
      },
      Kokkos::Max<double>(dmax));
  return dmax;
}

}  // namespace tamp
