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

// The linear moving-least-squares fit around a point p: moments
//   A = sum_j w_j q_j q_j^T,  q_j = (1, r_j - r_p, z_j - z_p)  (w_j = V_j W(x_j - p)),
// and beta = A^-1 e1, so that sum_j w_j (beta . q_j) f_j reproduces constant and linear
// fields f exactly; beta = (1 / A00, 0, 0) (Shepard) where A is singular. Used by the stress
// regularisation (kernels/SphSolid.hpp) and the tie's interface stress (kernels/Tie.hpp).
struct LinearMlsFit {
  double A00 = 0, A01 = 0, A02 = 0, A11 = 0, A12 = 0, A22 = 0;
  double b0 = 0, b1 = 0, b2 = 0;
  KOKKOS_INLINE_FUNCTION void add(double w, double dr, double dz) {
    A00 += w; A01 += w * dr; A02 += w * dz;
    A11 += w * dr * dr; A12 += w * dr * dz; A22 += w * dz * dz;
  }
  // beta = A^-1 e1 (the first column of the inverse, by cofactors)
  KOKKOS_INLINE_FUNCTION void solve() {
    const double c00 = A11 * A22 - A12 * A12;
    const double c01 = -(A01 * A22 - A12 * A02);
    const double c02 = A01 * A12 - A11 * A02;
    const double det = A00 * c00 + A01 * c01 + A02 * c02;
    b0 = 1.0 / A00; b1 = 0.0; b2 = 0.0;
    if (math::abs(det) > 1e-12 * math::abs(A00 * c00)) { b0 = c00 / det; b1 = c01 / det; b2 = c02 / det; }
  }
  // The fit's weight factor beta . q of a point at (dr, dz) from p.
  KOKKOS_INLINE_FUNCTION double factor(double dr, double dz) const { return b0 + b1 * dr + b2 * dz; }
};

}  // namespace tamp
