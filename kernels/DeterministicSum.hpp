// Sums over particles in a fixed order, whatever the back end or the number of threads.
//
// A Kokkos reduction adds in an order that depends on the thread count, so a sum that
// feeds the dynamics (the contact force on the pounder) would make a run on 1 thread differ
// in the last bits from one on 2 threads, and the difference grows over thousands of steps.
// Forward runs of the loop (drivers/loop/ForwardRuns.hpp) run with whatever threads a worker has
// and must give the same answer. Here [0, n) is cut into blocks of kBlock entries, each
// block summed in index order by one thread, and the block sums added in block order on the
// host: the same additions in the same order on every back end.
#pragma once
#include <array>
#include <string>
#include <vector>
#include <Kokkos_Core.hpp>

#include "core/Types.hpp"

namespace tamp {

// sum_i f(i, out) for i in [0, n): f adds its `count` contributions to out[0..count-1]
// (the signature of a Kokkos array reducer's operator(), so such functors fit unchanged).
template <class F>
std::vector<double> fixed_order_sums(const char* label, int n, int count, const F& f) {
  constexpr int kBlock = 64;
  const int blocks = (n + kBlock - 1) / kBlock;
  std::vector<double> total(count, 0.0);
  if (blocks == 0 || count == 0) return total;
  Kokkos::View<double**, Kokkos::LayoutRight, MemSpace> partial(std::string(label), blocks, count);  // zeroed
  Kokkos::parallel_for(
      label, Kokkos::RangePolicy<ExecSpace>(0, blocks), KOKKOS_LAMBDA(int b) {
        double* row = &partial(b, 0);  // LayoutRight: the block's sums are contiguous
        const int end = (b + 1) * kBlock < n ? (b + 1) * kBlock : n;
        for (int i = b * kBlock; i < end; ++i) f(i, row);
      });
  const auto host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), partial);
  for (int b = 0; b < blocks; ++b)
    for (int k = 0; k < count; ++k) total[k] += host(b, k);
  return total;
}

// The same with N sums known at compile time.
template <int N, class F>
std::array<double, N> fixed_order_sum(const char* label, int n, const F& f) {
  const std::vector<double> v = fixed_order_sums(label, n, N, f);
  std::array<double, N> out{};
  for (int k = 0; k < N; ++k) out[k] = v[k];
  return out;
}

}  // namespace tamp
