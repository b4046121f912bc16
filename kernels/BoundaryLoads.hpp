// Loads and held states at the edges of the particle domain: the tractions a non-reflecting
// boundary holds (docs/sph.md, "Non-reflecting boundaries"), a prescribed velocity (a
// displacement-driven punch or plate) and a surface traction (a footing, an overburden). One
// particle per thread, no shared writes.
#pragma once
#include "core/Material.hpp"
#include "core/Particles.hpp"
#include "kernels/Mirror.hpp"

namespace tamp {

// The viscous-spring boundary per unit area of a face (the one law for particles and
// elements, docs/sph.md "Non-reflecting boundaries"): dashpots rho c_p (normal) and rho c_s
// (tangential) (Lysmer & Kuhlemeyer 1969), springs K_n = 4G / (3R) and K_t = K_n / 2 (Deeks &
// Randolph 1994, Liu et al. 2006) for the distance R to the soil's far side (R <= 0: none).
struct ViscousSpring {
  double dashpot_n, dashpot_t;  // Pa s/m
  double spring_n, spring_t;    // Pa/m
};
// A mass-scaled material (inertia s) is a medium of density s rho: its impedances are
// s rho c / sqrt(s) = sqrt(s) rho c.
KOKKOS_INLINE_FUNCTION ViscousSpring viscous_spring(const MaterialParams& m, double rho, double spring_distance) {
  const double G = m.shear_modulus, rho_i = m.inertia * rho;
  const double cp = math::sqrt(m.p_wave_modulus() / rho_i), cs = math::sqrt(G / rho_i);
  const double kn = spring_distance > 0 ? 4.0 * G / (3.0 * spring_distance) : 0.0;
  return {rho_i * cp, rho_i * cs, kn, 0.5 * kn};
}

// A box of the meridian plane, m: a particle is inside when r_min <= r < r_max and
// z_min <= z < z_max.
struct Box {
  double r_min, r_max, z_min, z_max;
  KOKKOS_INLINE_FUNCTION bool contains(double r, double z) const {
    return r >= r_min && r < r_max && z >= z_min && z < z_max;
  }
};

// The particles within one spacing inside a non-reflecting plane are flagged as held by it,
// with the traction t = sigma . n the soil beyond exerted on them (n the outward normal) and
// their position: the boundary holds that traction while its springs and dashpots act on
// the motion from there.
struct HoldBoundaryStress {
  ViewN<double, 2> x, traction0, x_hold;
  ViewN<double, 4> sigma;
  View1<int> flags;
  MirrorPlanes planes;
  double dp;
  HoldBoundaryStress(const Particles& P, const MirrorPlanes& planes_in, double dp_in) : planes(planes_in), dp(dp_in) {
    x = P.x; traction0 = P.traction0; x_hold = P.x_hold; sigma = P.sigma; flags = P.flags;
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int i) const {
    traction0(i, 0) = 0.0;
    traction0(i, 1) = 0.0;
    x_hold(i, 0) = x(i, 0);
    x_hold(i, 1) = x(i, 1);
    int f = flags(i);
    for (int k = 0; k < planes.count; ++k) {
      f &= ~(FLAG_HELD_BOUNDARY << k);
      const MirrorPlane& pl = planes.plane[k];
      const double d = (x(i, pl.axis) - pl.position) * pl.side;
      if (d < 0.0 || d >= dp) continue;
      f |= FLAG_HELD_BOUNDARY << k;
      // outward normal n = -side e_axis; traction on the soil t = sigma . n
      const double sn = pl.axis == 0 ? sigma(i, 0) : sigma(i, 1);
      traction0(i, pl.axis) += -pl.side * sn;
      traction0(i, 1 - pl.axis) += -pl.side * sigma(i, 3);
    }
    flags(i) = f;
  }
};

// The particles in the box are driven at (v_r, v_z), m/s, from now on.
struct PrescribeVelocity {
  ViewN<double, 2> x, v, v_prescribed;
  View1<int> flags;
  Box box;
  double v_r, v_z;
  PrescribeVelocity(const Particles& P, const Box& box_in, double v_r_in, double v_z_in)
      : box(box_in), v_r(v_r_in), v_z(v_z_in) {
    x = P.x; v = P.v; v_prescribed = P.v_prescribed; flags = P.flags;
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int i) const {
    if (!box.contains(x(i, 0), x(i, 1))) return;
    flags(i) |= FLAG_DRIVEN;
    v_prescribed(i, 0) = v_r; v_prescribed(i, 1) = v_z;
    v(i, 0) = v_r; v(i, 1) = v_z;
  }
};

// A traction (t_r, t_z), Pa, on the particles of the box, a layer `layer` m thick: the force on
// a ring over its ring mass rho 2 pi r layer dz, a_ext += t / (rho layer), scaled by
// face_r / r when the traction acts on a face at radius face_r (face_r <= 0: a face of
// constant z).
struct SurfaceTraction {
  ViewN<double, 2> x, a_ext;
  View1<double> rho;
  Box box;
  double t_r, t_z, layer, face_r;
  SurfaceTraction(const Particles& P, const Box& box_in, double t_r_in, double t_z_in, double layer_in, double face_r_in)
      : box(box_in), t_r(t_r_in), t_z(t_z_in), layer(layer_in), face_r(face_r_in) {
    x = P.x; a_ext = P.a_ext; rho = P.rho;
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int i) const {
    const double r = x(i, 0), z = x(i, 1);
    if (!box.contains(r, z)) return;
    const double ratio = face_r > 0 ? face_r / r : 1.0;
    a_ext(i, 0) += t_r * ratio / (rho(i) * layer);
    a_ext(i, 1) += t_z * ratio / (rho(i) * layer);
  }
};

}  // namespace tamp
