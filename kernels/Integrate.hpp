// Leapfrog (kick-drift-kick, velocity Verlet) time integration of the real particles,
// the CFL time step, and energy sums. All parallel over particles.
#pragma once
#include "core/Material.hpp"
#include "core/Particles.hpp"
#include "kernels/DeterministicSum.hpp"
#include "kernels/Mirror.hpp"

namespace tamp {

// v += dt_half * a / inertia (driven particles take their prescribed velocity);
// the viscous heating rate is integrated with the same half step. `a` is the force per unit
// (true) mass; a mass-scaled material (MaterialParams::inertia > 1) responds to it with its
// larger inertia. The work of the mirror images' pair force over the half kick, F . u dt/2
// with u the mean of the velocities before and after (exactly the kinetic energy it gave),
// is added to image_work (kernels/SphSolid.hpp).
struct Kick {
  ViewN<double, 2> v, a, v_prescribed, image_work;
  ViewN<double, 4> image_force;
  View1<double> internal_energy, du_visc;
  View1<int> flags, material;
  Kokkos::View<const MaterialParams*, MemSpace> materials;
  double dt_half;
  // Built by name from the particle fields (core/Particles.hpp).
  Kick(const Particles& P, const Kokkos::View<const MaterialParams*, MemSpace>& materials_in, double dt_half_in)
      : materials(materials_in), dt_half(dt_half_in) {
    v = P.v; a = P.a; v_prescribed = P.v_prescribed;
    internal_energy = P.internal_energy; du_visc = P.du_visc; flags = P.flags; material = P.material;
    image_force = P.image_force; image_work = P.image_work;
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int i) const {
    if (flags(i) & FLAG_DRIVEN) {
      v(i, 0) = v_prescribed(i, 0);
      v(i, 1) = v_prescribed(i, 1);
    } else {
      const double k = dt_half / materials(material(i)).inertia;
      const double ur = v(i, 0) + 0.5 * k * a(i, 0), uz = v(i, 1) + 0.5 * k * a(i, 1);
      image_work(i, 0) += dt_half * (image_force(i, 0) * ur + image_force(i, 1) * uz);
      image_work(i, 1) += dt_half * (image_force(i, 2) * ur + image_force(i, 3) * uz);
      v(i, 0) += k * a(i, 0);
      v(i, 1) += k * a(i, 1);
    }
    internal_energy(i) += dt_half * du_visc(i);
  }
};

// x += dt v; a particle that crosses the axis or a wall is reflected back (its normal
// velocity flips); the planar mass m / (2 pi r) follows the new radius. A non-reflecting
// boundary stands for more soil, so the particles it holds may cross its plane (their
// springs pull them back); any other particle that crosses it is reflected like at a wall,
// so that soil cannot leak out between the held particles.
struct Drift {
  ViewN<double, 2> x, v;
  View1<double> mass, planar_mass;
  View1<int> flags;
  MirrorPlanes walls;
  MirrorPlanes open_planes;  // the non-reflecting boundaries, in their flag-bit order
  double dt;
  double r_floor;  // smallest radius used for the planar mass, m
  Drift(const Particles& P, const MirrorPlanes& walls_in, const MirrorPlanes& open_planes_in, double dt_in,
        double r_floor_in)
      : walls(walls_in), open_planes(open_planes_in), dt(dt_in), r_floor(r_floor_in) {
    x = P.x; v = P.v; mass = P.mass; planar_mass = P.planar_mass; flags = P.flags;
  }
  KOKKOS_INLINE_FUNCTION void reflect(const int i, const MirrorPlane& pl) const {
    const double d = (x(i, pl.axis) - pl.position) * pl.side;
    if (d < 0) {
      x(i, pl.axis) = 2.0 * pl.position - x(i, pl.axis);
      v(i, pl.axis) = -v(i, pl.axis);
    }
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int i) const {
    x(i, 0) += dt * v(i, 0);
    x(i, 1) += dt * v(i, 1);
    for (int k = 0; k < walls.count; ++k) reflect(i, walls.plane[k]);
    for (int k = 0; k < open_planes.count; ++k)
      if (!(flags(i) & (FLAG_HELD_BOUNDARY << k))) reflect(i, open_planes.plane[k]);
    planar_mass(i) = planar_mass_of(mass(i), x(i, 0), r_floor);
  }
};

// Stable step: dt = cfl * min_a h / (c_a + |v_a|), also bounded by cfl * sqrt(h / |a_a|),
// with c_a = sqrt(M / (inertia rho)) and a_a / inertia for a mass-scaled material.
struct StableStep {
  ViewN<double, 2> v, a;
  View1<double> rho;
  View1<int> material;
  Kokkos::View<const MaterialParams*, MemSpace> materials;
  double h;
  StableStep(const Particles& P, const Kokkos::View<const MaterialParams*, MemSpace>& materials_in, double h_in)
      : materials(materials_in), h(h_in) {
    v = P.v; a = P.a; rho = P.rho; material = P.material;
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int i, double& dt_min) const {
    const MaterialParams& m = materials(material(i));
    const double c = math::sqrt(m.p_wave_modulus() / (m.inertia * rho(i)));
    const double speed = math::sqrt(v(i, 0) * v(i, 0) + v(i, 1) * v(i, 1));
    double dt = h / (c + speed);
    const double acc = math::sqrt(a(i, 0) * a(i, 0) + a(i, 1) * a(i, 1)) / m.inertia;
    if (acc > 0) dt = math::min(dt, math::sqrt(h / acc));
    if (!(dt == dt)) dt = 0;  // NaN -> zero step, caught by the driver
    dt_min = math::min(dt_min, dt);
  }
};

struct Energies {
  double kinetic = 0;    // J
  double internal = 0;   // J (strain energy + dissipated heat)
  double potential = 0;  // J, gravity, relative to z = 0
  double total() const { return kinetic + internal + potential; }
};

// Kinetic, internal and gravitational energy of the real particles (ring masses), summed
// in a fixed order (kernels/DeterministicSum.hpp): the same on any number of threads. The
// kinetic energy of a mass-scaled material is that of its inertia.
inline Energies energy_sums(const Particles& p, const Kokkos::View<const MaterialParams*, MemSpace>& materials,
                            double gravity) {
  auto x = p.x; auto v = p.v; auto m = p.mass; auto u = p.internal_energy; auto mat = p.material;
  const auto s = fixed_order_sum<3>("tamp::energy::sums", p.n_real, KOKKOS_LAMBDA(int i, double* e) {
    e[0] += 0.5 * materials(mat(i)).inertia * m(i) * (v(i, 0) * v(i, 0) + v(i, 1) * v(i, 1));
    e[1] += m(i) * u(i);
    e[2] += m(i) * gravity * x(i, 1);
  });
  Energies e;
  e.kinetic = s[0];
  e.internal = s[1];
  e.potential = s[2];
  return e;
}

}  // namespace tamp
