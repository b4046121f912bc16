// Reductions for the energy account of a run (docs/drop-sequence.md, "Energy account").
//
// EnergyFluxes: the power of the forces that move energy across the particles' boundary
// or out of the mechanical system, summed over the real particles (W, > 0 when it feeds
// the particles):
//   [0] mass-proportional damping   sum m a_damp . u,  a_damp = -d v_c
//   [1] non-reflecting boundaries   sum m a_boundary . u   (dashpots, springs, held traction)
//   [2] fixed-wall friction         sum m a_friction . u
//   [3] rigid-body contact          sum F . (u - U)        (minus the rate of contact energy)
//   [4] artificial stress           sum m a_art . u        (a numerical force, no stored energy)
//   [5 + k] artificial-viscosity heating of material k, sum m du_visc (>= 0 but for the
//           pairs with tie particles: there the work of the unreciprocated viscous force)
// The velocity u is that of the middle of a half kick of the leapfrog, u = v + shift a
// (shift = +dt/4 before the first kick of a step, -dt/4 after the second; U likewise for
// the body): a half kick changes the kinetic energy by exactly the impulse times u, so the
// account is exact for each force however stiff. (Full-step velocities, a trapezoidal rule,
// missed a first-order part of the stick friction, whose force is ~ m v / dt.) v_c, the
// velocity the damping was computed from, is v - damp_back a.
// MaterialEnergies: per material k, [4k + 0] kinetic (of the inertia, for mass scaling), [4k + 1] internal (strain + heat),
// [4k + 2] gravitational (relative to z = 0), [4k + 3] elastic strain energy
//   W = m / rho (p^2 / (2K) + J2 / (2G)),  p = tr(sigma) / 3,  J2 = s:s / 2,
// the energy a linear-elastic unloading would give back; internal - elastic is what the
// material has dissipated (plastic work + viscous heat) plus the strain energy locked in
// by plastic flow.
// Array reductions (value_count set at run time) in the Kokkos 3.4 functor form.
#pragma once
#include "core/Material.hpp"
#include "core/Particles.hpp"

namespace tamp {

struct EnergyFluxes {
  using value_type = double[];
  using size_type = int;
  unsigned value_count;  // 5 + number of materials
  ViewN<double, 2> v, a, a_boundary, a_friction, contact_force, a_art;
  View1<double> mass, du_visc;
  View1<int> material;
  Kokkos::View<const MaterialParams*, MemSpace> materials;
  double damping, shift, damp_back;
  double body_ur, body_uz;  // the body's mid-kick velocity U
  int with_boundary, with_friction, with_contact, with_art;

  // Built by name from the particle fields; the parts of a written apart, the body's
  // velocity and the switches are set by the caller by name.
  EnergyFluxes(const Particles& P, const Kokkos::View<const MaterialParams*, MemSpace>& materials_in,
               unsigned n_materials)
      : value_count(5 + n_materials), materials(materials_in), damping(0), shift(0), damp_back(0), body_ur(0), body_uz(0),
        with_boundary(0), with_friction(0), with_contact(0), with_art(0) {
    v = P.v; a = P.a; mass = P.mass; du_visc = P.du_visc; material = P.material;
  }

  KOKKOS_INLINE_FUNCTION void operator()(const int i, value_type sum) const {
    // the velocity change per unit time is a / inertia for a mass-scaled material
    const double s = materials(material(i)).inertia;
    const double m = mass(i), ar = a(i, 0) / s, az = a(i, 1) / s;
    const double ur = v(i, 0) + shift * ar, uz = v(i, 1) + shift * az;
    if (damping != 0.0) {  // mass-proportional: on the inertia (Acceleration)
      const double cr = v(i, 0) - damp_back * ar, cz = v(i, 1) - damp_back * az;
      sum[0] -= s * m * damping * (cr * ur + cz * uz);
    }
    if (with_boundary) sum[1] += m * (a_boundary(i, 0) * ur + a_boundary(i, 1) * uz);
    if (with_friction) sum[2] += m * (a_friction(i, 0) * ur + a_friction(i, 1) * uz);
    if (with_contact) sum[3] += contact_force(i, 0) * (ur - body_ur) + contact_force(i, 1) * (uz - body_uz);
    if (with_art) sum[4] += m * (a_art(i, 0) * ur + a_art(i, 1) * uz);
    sum[5 + material(i)] += m * du_visc(i);
  }
  KOKKOS_INLINE_FUNCTION void join(volatile value_type dst, const volatile value_type src) const {
    for (unsigned k = 0; k < value_count; ++k) dst[k] += src[k];
  }
  KOKKOS_INLINE_FUNCTION void init(value_type sum) const {
    for (unsigned k = 0; k < value_count; ++k) sum[k] = 0.0;
  }
};

struct MaterialEnergies {
  using value_type = double[];
  using size_type = int;
  unsigned value_count;  // 4 * number of materials
  ViewN<double, 2> x, v;
  View1<double> mass, rho, internal_energy;
  ViewN<double, 4> sigma;
  View1<int> material;
  Kokkos::View<const MaterialParams*, MemSpace> materials;
  double gravity;

  MaterialEnergies(const Particles& P, unsigned n_materials, const Kokkos::View<const MaterialParams*, MemSpace>& materials_in,
                   double gravity_in)
      : value_count(4 * n_materials), materials(materials_in), gravity(gravity_in) {
    x = P.x; v = P.v; mass = P.mass; rho = P.rho; internal_energy = P.internal_energy; sigma = P.sigma;
    material = P.material;
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int i, value_type sum) const {
    const int k = 4 * material(i);
    const double m = mass(i);
    const MaterialParams& mp = materials(material(i));
    const double w = mp.elastic_energy_density(sigma(i, 0), sigma(i, 1), sigma(i, 2), sigma(i, 3));
    sum[k + 0] += 0.5 * mp.inertia * m * (v(i, 0) * v(i, 0) + v(i, 1) * v(i, 1));
    sum[k + 1] += m * internal_energy(i);
    sum[k + 2] += m * gravity * x(i, 1);
    sum[k + 3] += m / rho(i) * w;
  }
  KOKKOS_INLINE_FUNCTION void join(volatile value_type dst, const volatile value_type src) const {
    for (unsigned k = 0; k < value_count; ++k) dst[k] += src[k];
  }
  KOKKOS_INLINE_FUNCTION void init(value_type sum) const {
    for (unsigned k = 0; k < value_count; ++k) sum[k] = 0.0;
  }
};

}  // namespace tamp
