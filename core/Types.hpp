// Basic types shared by every part of Tamp: the execution/memory spaces, scalar type,
// and the index convention of the axisymmetric stress tensor.
#pragma once
#include <cmath>
#include <Kokkos_Core.hpp>

namespace tamp {

using ExecSpace = Kokkos::DefaultExecutionSpace;
using MemSpace = ExecSpace::memory_space;
using HostSpace = Kokkos::HostSpace;

constexpr double pi = 3.14159265358979323846;

// Axisymmetric stress / strain components, tension positive (SI: Pa).
// rr: radial, zz: vertical, tt: hoop (always a principal direction), rz: in-plane shear.
enum StressIndex : int { RR = 0, ZZ = 1, TT = 2, RZ = 3 };

// Coordinates: index 0 = r (m, >= 0), index 1 = z (m, up).
template <class T, class Space = MemSpace>
using View1 = Kokkos::View<T*, Space>;
template <class T, int N, class Space = MemSpace>
using ViewN = Kokkos::View<T* [N], Space>;

// Device-callable math. Kokkos 3.4 spells these Kokkos::Experimental::*, Kokkos 4 spells
// them Kokkos::*; the <cmath> overloads work on the host, OpenMP and CUDA in both.
namespace math {
KOKKOS_INLINE_FUNCTION double sqrt(double x) { return ::sqrt(x); }
KOKKOS_INLINE_FUNCTION double abs(double x) { return ::fabs(x); }
KOKKOS_INLINE_FUNCTION double floor(double x) { return ::floor(x); }
KOKKOS_INLINE_FUNCTION double sin(double x) { return ::sin(x); }
KOKKOS_INLINE_FUNCTION double cos(double x) { return ::cos(x); }
KOKKOS_INLINE_FUNCTION double atan2(double y, double x) { return ::atan2(y, x); }
KOKKOS_INLINE_FUNCTION double tan(double x) { return ::tan(x); }
KOKKOS_INLINE_FUNCTION double exp(double x) { return ::exp(x); }
KOKKOS_INLINE_FUNCTION double log(double x) { return ::log(x); }
KOKKOS_INLINE_FUNCTION double pow(double x, double y) { return ::pow(x, y); }
KOKKOS_INLINE_FUNCTION double min(double a, double b) { return a < b ? a : b; }
KOKKOS_INLINE_FUNCTION double max(double a, double b) { return a > b ? a : b; }
}  // namespace math

}  // namespace tamp
