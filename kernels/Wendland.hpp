// Wendland C2 kernel in two dimensions (the (r, z) plane), support radius 2h.
//   W(q) = 7 / (4 pi h^2) (1 - q/2)^4 (2q + 1),  q = |x| / h in [0, 2]
//   dW/dr = 7 / (4 pi h^3) (-5 q) (1 - q/2)^3
// Source: Wendland (1995), Adv. Comput. Math. 4, 389; normalisation as in Dehnen & Aly
// (2012), MNRAS 425, 1068 (with their H = 2h).
#pragma once
#include "core/Types.hpp"

namespace tamp {

struct Wendland2D {
  double h;
  double norm;  // 7 / (4 pi h^2)

  KOKKOS_INLINE_FUNCTION explicit Wendland2D(double h_ = 1.0) : h(h_), norm(7.0 / (4.0 * pi * h_ * h_)) {}

  KOKKOS_INLINE_FUNCTION double support() const { return 2.0 * h; }

  KOKKOS_INLINE_FUNCTION double value(double r) const {
    const double q = r / h;
    if (q >= 2.0) return 0.0;
    const double t = 1.0 - 0.5 * q;
    const double t2 = t * t;
    return norm * t2 * t2 * (2.0 * q + 1.0);
  }
  // (dW/dr) / r from the squared distance, so that grad_a W_ab = factor * (x_a - x_b);
  // 0 outside the support and for coincident points. The one definition used by every
  // pair loop (the strain-rate loop and its stand-alone twin must agree bit for bit).
  KOKKOS_INLINE_FUNCTION double gradient_factor(double r2) const {
    if (r2 >= 4.0 * h * h || r2 <= 0.0) return 0.0;
    const double r = ::sqrt(r2);
    return derivative(r) / r;
  }
  // dW/dr (negative for 0 < r < 2h).
  KOKKOS_INLINE_FUNCTION double derivative(double r) const {
    const double q = r / h;
    if (q >= 2.0) return 0.0;
    const double t = 1.0 - 0.5 * q;
    return norm / h * (-5.0 * q) * t * t * t;
  }
};

}  // namespace tamp
