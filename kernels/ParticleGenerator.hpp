// The particle generator: a block of the deck filled with particles on a regular grid of
// spacing dp (centres at half spacings), ring mass m = rho0 2 pi r dp^2, at rest or with
// the block's initial velocity. How many particles each block gets is counted on the host
// first (core/ParticleGrid.hpp); one launch per block fills them.
#pragma once
#include "core/Config.hpp"
#include "core/Material.hpp"
#include "core/Particles.hpp"

namespace tamp {

struct FillBlock {
  ViewN<double, 2> x, v;
  View1<double> mass, planar_mass, rho;
  View1<int> material;
  int first, nr, nz, mat;  // slots [first, first + nr nz); grid size; material index
  double r_min, z_min, velocity_r, velocity_z, rho0, dp, r_floor;

  FillBlock(const Particles& P, int first_in, int nr_in, int nz_in, int mat_in, const BlockSpec& b, double rho0_in,
            const SphSpec& sph)
      : first(first_in), nr(nr_in), nz(nz_in), mat(mat_in), r_min(b.r_min), z_min(b.z_min),
        velocity_r(b.velocity_r), velocity_z(b.velocity_z), rho0(rho0_in), dp(sph.spacing), r_floor(planar_mass_floor(sph)) {
    x = P.x; v = P.v; mass = P.mass; planar_mass = P.planar_mass; rho = P.rho; material = P.material;
  }
  int count() const { return nr * nz; }

  KOKKOS_INLINE_FUNCTION void operator()(const int k) const {
    const int i = first + k;
    // Strip order: vertical strips of `strip` columns, each filled row by row, so that the
    // neighbours of a particle are at most ~3 strip widths away in memory (the row-major
    // order put them a whole row apart: 30-40 % slower at 160k particles).
    constexpr int strip = 32;
    const int s = k / (strip * nz);
    const int width = (s + 1) * strip <= nr ? strip : nr - s * strip;
    const int kk = k - s * strip * nz;
    const int ir = s * strip + kk % width, iz = kk / width;
    const double r = r_min + (ir + 0.5) * dp;
    const double z = z_min + (iz + 0.5) * dp;
    x(i, 0) = r;
    x(i, 1) = z;
    v(i, 0) = velocity_r;
    v(i, 1) = velocity_z;
    rho(i) = rho0;
    mass(i) = rho0 * 2.0 * pi * r * dp * dp;
    planar_mass(i) = planar_mass_of(mass(i), r, r_floor);
    material(i) = mat;
  }
};

// Particles added to the model (backfill): slot first + k takes the k-th new particle at
// (r, z) at rest with its material's density and the ring mass rho0 2 pi r dp^2 of a grid
// cell; the other fields are at a new particle's value already (Particles::fill_new). A
// reduction: it returns the mass added, kg.
struct PlaceNewParticles {
  ViewN<double, 2> x, x_ref;
  View1<double> mass, planar_mass, rho;
  View1<int> material;
  View1<double> new_r, new_z;
  View1<int> new_material;
  Kokkos::View<const MaterialParams*, MemSpace> materials;
  int first;
  double dp, r_floor;
  PlaceNewParticles(const Particles& P, int first_in, const View1<double>& r, const View1<double>& z,
                    const View1<int>& mat, const Kokkos::View<const MaterialParams*, MemSpace>& materials_in,
                    const SphSpec& sph)
      : new_r(r), new_z(z), new_material(mat), materials(materials_in), first(first_in), dp(sph.spacing),
        r_floor(planar_mass_floor(sph)) {
    x = P.x; x_ref = P.x_ref; mass = P.mass; planar_mass = P.planar_mass; rho = P.rho; material = P.material;
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int k, double& added) const {
    const int i = first + k;
    const double r = new_r(k);
    const double rho0 = materials(new_material(k)).density;
    x(i, 0) = r; x(i, 1) = new_z(k);
    x_ref(i, 0) = r; x_ref(i, 1) = new_z(k);
    rho(i) = rho0;
    mass(i) = rho0 * 2.0 * pi * r * dp * dp;
    planar_mass(i) = planar_mass_of(mass(i), r, r_floor);
    material(i) = new_material(k);
    added += mass(i);
  }
};

// The planar mass m / (2 pi r) from the current radius (after a restore or a move).
struct PlanarMass {
  ViewN<double, 2> x;
  View1<double> mass, planar_mass;
  double r_floor;
  PlanarMass(const Particles& P, const SphSpec& sph) : r_floor(planar_mass_floor(sph)) {
    x = P.x; mass = P.mass; planar_mass = P.planar_mass;
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int i) const { planar_mass(i) = planar_mass_of(mass(i), x(i, 0), r_floor); }
};

}  // namespace tamp
