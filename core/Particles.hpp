// Particle storage: structure-of-arrays Kokkos views (Cabana-style), in the default
// memory space. Real particles occupy [0, n_real); mirror (ghost) particles that stand in
// for the axis and rigid walls occupy [n_real, n_total). Capacity grows on the host,
// never inside a kernel.
#pragma once
#include <string>
#include "core/Types.hpp"

namespace tamp {

enum ParticleFlag : int {
  FLAG_NONE = 0,
  FLAG_DRIVEN = 1,  // velocity prescribed (v_prescribed), not integrated from forces
  // Held by the k-th non-reflecting boundary (its boundary layer when the boundary stress
  // was recorded): bit FLAG_HELD_BOUNDARY << k, k = 0 .. 3.
  FLAG_HELD_BOUNDARY = 2,
  // A mirror particle of a fixed (rough) wall: the Acceleration loop sums its pair forces
  // apart, as the wall's normal support of the particle, for the wall's Coulomb friction
  // (kernels/WallFriction.hpp). Set on ghosts only.
  FLAG_FIXED_WALL_GHOST = 64,
};

struct Particles {
  int n_real = 0;
  int n_virtual = 0;  // tie particles [n_real, n_real + n_virtual): FEM material seen by the SPH
  int n_total = 0;
  int capacity = 0;

  ViewN<double, 2> x;             // position (r, z), m
  ViewN<double, 2> v;             // velocity (v_r, v_z), m/s
  ViewN<double, 2> a;             // acceleration, m/s2
  ViewN<double, 2> a_ext;         // external acceleration (surface tractions), m/s2
  ViewN<double, 2> v_prescribed;  // velocity of FLAG_DRIVEN particles, m/s
  ViewN<double, 2> x_ref;         // position at the last neighbour-list build
  ViewN<double, 2> traction0;     // static traction on non-reflecting boundary particles, Pa
  ViewN<double, 2> x_hold;        // their position when that traction was recorded, m
  View1<double> mass;             // ring mass (the whole ring of revolution), kg
  View1<double> planar_mass;      // mass / (2 pi r): mass per radian of revolution / r, kg/m
  View1<double> rho;              // density, kg/m3
  ViewN<double, 4> sigma;         // Cauchy stress rr, zz, tt, rz (tension positive), Pa
  ViewN<double, 4> sigma_tmp;     // scratch for stress regularisation
  ViewN<double, 3> art_stress;    // Gray-Monaghan-Swift R (rr, zz, rz), (Pa) / (kg/m3)^2
  ViewN<double, 3> pair_stress;   // mp sigma / rho^2 (rr, zz, rz): a particle's share of the
                                  // symmetric pair term, precomputed once per step
  View1<double> plastic_strain;   // accumulated equivalent plastic shear strain, -
  View1<double> compaction;       // plastic volumetric (compaction) strain, effect (a), -
  View1<double> internal_energy;  // specific internal energy (strain + dissipated), J/kg
  View1<double> du_visc;          // rate of viscous heating, W/kg
  View1<double> hoop_factor;      // chi: the hoop terms use chi / r (kernels/SphSolid.hpp)
  View1<int> material;            // index into the material table
  View1<int> flags;               // ParticleFlag bits
  View1<int> ghost_source;        // ghosts: the particle this one mirrors

  void reserve(int new_capacity);  // grows every view, keeping contents
};

inline void Particles::reserve(int new_capacity) {
  if (new_capacity <= capacity) return;
  auto grow = [&](auto& view, const char* label) {
    if (view.extent(0) == 0 && view.data() == nullptr)
      view = std::decay_t<decltype(view)>(std::string(label), static_cast<size_t>(new_capacity));
    else
      Kokkos::resize(view, new_capacity);
  };
  grow(x, "x"); grow(v, "v"); grow(a, "a"); grow(a_ext, "a_ext");
  grow(v_prescribed, "v_prescribed"); grow(x_ref, "x_ref"); grow(traction0, "traction0"); grow(x_hold, "x_hold");
  grow(mass, "mass"); grow(planar_mass, "planar_mass"); grow(rho, "rho");
  grow(sigma, "sigma"); grow(sigma_tmp, "sigma_tmp"); grow(art_stress, "art_stress");
  grow(pair_stress, "pair_stress");
  grow(plastic_strain, "plastic_strain"); grow(compaction, "compaction"); grow(internal_energy, "internal_energy");
  grow(du_visc, "du_visc"); grow(hoop_factor, "hoop_factor"); grow(material, "material"); grow(flags, "flags");
  grow(ghost_source, "ghost_source");
  capacity = new_capacity;
}

}  // namespace tamp
