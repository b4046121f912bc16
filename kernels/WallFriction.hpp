// Coulomb friction of a fixed (rough) wall on the particles of its first layer.
//
// A fixed wall is a roller mirror (kernels/Mirror.hpp: the ghosts keep the tangential
// velocity and flip the shear stress, which conserves energy exactly) plus friction: the
// wall holds a particle in its first layer (0 <= d < dp from the plane) by a tangential
// acceleration bounded by the material's own shear strength on the wall face,
//   a_t <= tan(phi) a_n + c / (rho dp),
// where a_n is the wall's normal support of the particle (the summed pair accelerations of
// its fixed-wall ghosts, Acceleration::a_wall, taken along the wall's inward normal) and
// c / (rho dp) the cohesion c (Su for Tresca) on the particle's wall face (ring area
// 2 pi r dp over ring mass rho 2 pi r dp^2). As in the pounder's contact (RigidContact.hpp)
// the friction is at most the value that stops the sliding within one step against the
// other tangential forces (stick), a_t = -(v_t / dt + a_other,t) if that is within the cap.
// Its work is summed in the energy account (EnergyFluxes). Without it a cohesionless grain would slide along the base
// forever: the Monaghan viscosity acts on approaching pairs only.
#pragma once
#include "core/Material.hpp"
#include "core/Particles.hpp"
#include "kernels/Mirror.hpp"

namespace tamp {

struct WallFriction {
  ViewN<double, 2> x, v, a, a_wall;
  ViewN<double, 2> a_friction;  // out: the friction's part of a
  View1<double> rho;
  View1<int> material, flags;
  Kokkos::View<const MaterialParams*, MemSpace> materials;
  MirrorPlanes walls;  // the axis and walls; friction on the no_slip (fixed) ones
  double dp, dt;

  // Built by name; a_wall (in) and a_friction (out) are set by the caller.
  WallFriction(const Particles& P, const Kokkos::View<const MaterialParams*, MemSpace>& materials_in,
               const MirrorPlanes& walls_in, double dp_in, double dt_in)
      : materials(materials_in), walls(walls_in), dp(dp_in), dt(dt_in) {
    x = P.x; v = P.v; a = P.a; rho = P.rho; material = P.material; flags = P.flags;
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int i) const {
    a_friction(i, 0) = 0.0;
    a_friction(i, 1) = 0.0;
    if (flags(i) & FLAG_DRIVEN) return;
    for (int k = 0; k < walls.count; ++k) {
      const MirrorPlane& pl = walls.plane[k];
      if (!pl.no_slip) continue;
      const int n = pl.axis, t = 1 - pl.axis;
      const double d = (x(i, n) - pl.position) * pl.side;
      if (d < 0.0 || d >= dp) continue;
      const double an = a_wall(i, n) * pl.side;  // support into the domain
      const MaterialParams& m = materials(material(i));
      const double cap = (an > 0.0 ? an * math::tan(m.phi) : 0.0) + m.cohesion / (rho(i) * dp);
      if (!(cap > 0.0)) continue;
      // Stick: the friction that ends the step (v^{n+1/2} -> v^{n+3/2}, both kicks with
      // this acceleration) with no tangential speed, against the other forces too; if that
      // needs more than the cap, the particle slides with the full friction against v_t
      // (or, starting from rest, against the other forces).
      const double vt = v(i, t);
      const double stick = -(m.inertia * vt / dt + a(i, t));  // a per unit mass; inertia m.inertia times it
      double at;
      if (math::abs(stick) <= cap) at = stick;
      else if (vt != 0.0) at = vt > 0.0 ? -cap : cap;
      else at = stick > 0.0 ? cap : -cap;
      a(i, t) += at;
      a_friction(i, t) += at;
    }
  }
};

}  // namespace tamp
