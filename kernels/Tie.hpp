// SPH-FEM tie: tie particles (docs/coupling.md).
//
// The FEM elements next to the interface are sampled at the SPH spacing by tie particles,
// fixed in the element's parent coordinates (xi, eta). Every step they take the element's
// motion (bilinear interpolation of the nodes; the first row next to the interface takes the
// motion of its projection on the interface edge, whose nodes receive its traction), density
// and stress, and stand in the SPH
// sums as neighbours of the real particles: the particles next to the interface see a full
// kernel of material on the FEM side, as they would inside one body. In return the FEM
// boundary receives the interface traction t = sigma(p) . n at the interface points p
// below the first row of tie particles, sigma(p) interpolated by linear moving least
// squares over the particles around p on both sides (real particles, tie particles and
// their images), handed to the edge nodes with consistent ring weights. (The reactions of
// the SPH pair forces on the tie particles were tried first: they conserve momentum in z,
// but in the ring-mass form they also carry the hoop-balance part of the radial pair sums,
// a spurious radial load on the FEM that bent the stress field next to the axis by 15 %.)
// Particle arrays: [n_real, n_real + n_tie).
#pragma once
#include "core/Particles.hpp"
#include "kernels/FemQuad.hpp"
#include "kernels/NeighbourList.hpp"
#include "kernels/Wendland.hpp"

namespace tamp {

struct TieParticles {
  int count = 0;
  View1<int> element;            // FEM element holding the tie particle
  ViewN<double, 2> parent;       // (xi, eta) in [-1, 1]^2
  ViewN<double, 2> follow;       // (xi, eta) whose motion it takes: its own, or (first row)
                                 // its projection on the interface edge
  View1<double> planar_mass;     // rho0 times its share of the element's (r, z) area, kg/m
  ViewN<double, 2> normal;       // first row: outward normal of the FEM at its interface edge
  View1<double> depth;           // first row: reference distance to the interface edge, m
  View1<double> face_area;       // first row: ring area of its interface segment, m2; else 0
  ViewN<double, 2> force;        // interface force handed to the FEM, N (per ring)
  View1<int> material;           // index in the SPH material table (its element's material)
  // Where the force goes, seen from the nodes of the interface edges, for a sum in a fixed
  // order (tie index, then the edge's node a before b): node_id(q) receives node_share(e)
  // force(node_tie(e)) for e in [node_start(q), node_start(q+1)). Atomic adds per tie
  // particle made a node's sum depend on the threads' order once it had more than two terms
  // (5 mm particles on 10 mm elements).
  int node_count = 0;
  View1<int> node_id, node_start, node_tie;
  View1<double> node_share;
};


// Position, velocity, density and masses of the tie particles from the FEM nodes.
struct SyncTieKinematics {
  ViewN<double, 2> x, v;
  View1<double> mass, planar_mass, rho;
  View1<int> material, flags;
  // tie layout
  View1<int> element;
  ViewN<double, 2> parent, follow;
  View1<double> tie_planar_mass;
  View1<int> tie_material;
  int n_real;
  // FEM
  ViewN<double, 2> node_x, node_x0, node_v;
  Kokkos::View<int* [4], MemSpace> conn;
  View1<double> elem_mass, elem_volume;
  double r_floor;
  // Built by name from the particles, the tie and the element mesh.
  SyncTieKinematics(const Particles& P, const TieParticles& tie, const fem::FemMesh& mesh, double r_floor_in)
      : r_floor(r_floor_in) {
    x = P.x; v = P.v; mass = P.mass; planar_mass = P.planar_mass; rho = P.rho; material = P.material; flags = P.flags;
    element = tie.element; parent = tie.parent; follow = tie.follow; tie_planar_mass = tie.planar_mass;
    tie_material = tie.material; n_real = P.n_real;
    node_x = mesh.x; node_x0 = mesh.x0; node_v = mesh.v; conn = mesh.conn; elem_mass = mesh.elem_mass;
    elem_volume = mesh.volume;
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int k) const {
    const int i = n_real + k, e = element(k);
    double N[4], F[4];
    fem::bilinear(parent(k, 0), parent(k, 1), N);  // kernels/FemQuad.hpp
    fem::bilinear(follow(k, 0), follow(k, 1), F);
    double xr = 0, xz = 0, vr = 0, vz = 0;
    for (int q = 0; q < 4; ++q) {
      const int n = conn(e, q);
      // position at its own parent point, moved with the point it follows
      xr += N[q] * node_x0(n, 0) + F[q] * (node_x(n, 0) - node_x0(n, 0));
      xz += N[q] * node_x0(n, 1) + F[q] * (node_x(n, 1) - node_x0(n, 1));
      vr += F[q] * node_v(n, 0); vz += F[q] * node_v(n, 1);
    }
    x(i, 0) = xr; x(i, 1) = xz;
    v(i, 0) = vr; v(i, 1) = vz;
    rho(i) = elem_mass(e) / elem_volume(e);
    planar_mass(i) = tie_planar_mass(k);
    mass(i) = 2.0 * pi * (xr > r_floor ? xr : r_floor) * tie_planar_mass(k);
    material(i) = tie_material(k);
    flags(i) = 0;
  }
};

// Stress of the tie particles from their elements, and their share of the pair term.
struct SyncTieStress {
  ViewN<double, 4> sigma;
  ViewN<double, 3> art_stress, pair_stress;
  View1<double> planar_mass, rho;
  View1<int> element;
  ViewN<double, 4> elem_stress;
  int n_real;
  SyncTieStress(const Particles& P, const TieParticles& tie, const fem::FemMesh& mesh) {
    sigma = P.sigma; art_stress = P.art_stress; pair_stress = P.pair_stress; planar_mass = P.planar_mass; rho = P.rho;
    element = tie.element; elem_stress = mesh.stress; n_real = P.n_real;
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int k) const {
    const int i = n_real + k, e = element(k);
    for (int c = 0; c < 4; ++c) sigma(i, c) = elem_stress(e, c);
    for (int c = 0; c < 3; ++c) art_stress(i, c) = 0.0;
    set_pair_stress(i, planar_mass, rho, sigma, pair_stress);  // core/Particles.hpp
  }
};

// Interface force of a first-row tie particle: F = A sigma(p) . n at the interface point
// p = x + depth n, with sigma(p) from a linear moving-least-squares fit over the listed
// neighbours of the tie particle (both sides of the interface; W centred at p):
//   A_p = sum_j V_j W(x_j - p) q_j q_j^T,  q_j = (1, r_j - r_p, z_j - z_p),  A_p beta = e1,
//   sigma(p) = sum_j V_j W(x_j - p) (beta . q_j) sigma_j        (exact for linear fields)
struct TieTraction {
  ViewN<double, 2> x;
  View1<double> planar_mass, rho;
  ViewN<double, 4> sigma;
  View1<int> offsets, neighbours;
  ViewN<double, 2> normal;  // outward normal of the FEM at the interface
  View1<double> depth, face_area;
  ViewN<double, 2> force;
  double h;
  int n_real;
  TieTraction(const Particles& P, const NeighbourList& list, const TieParticles& tie, double h_in) : h(h_in) {
    x = P.x; planar_mass = P.planar_mass; rho = P.rho; sigma = P.sigma;
    offsets = list.offsets; neighbours = list.neighbours;
    normal = tie.normal; depth = tie.depth; face_area = tie.face_area; force = tie.force; n_real = P.n_real;
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int k) const {
    if (face_area(k) == 0.0) {
      force(k, 0) = 0.0;
      force(k, 1) = 0.0;
      return;
    }
    const int b = n_real + k;
    const double nr = normal(k, 0), nz = normal(k, 1);
    const double pr = x(b, 0) + depth(k) * nr, pz = x(b, 1) + depth(k) * nz;
    const Wendland2D W(h);
    LinearMlsFit fit;  // kernels/Wendland.hpp
    auto accumulate = [&](int j) {
      const double dr = x(j, 0) - pr, dz = x(j, 1) - pz;
      fit.add(W.value(math::sqrt(dr * dr + dz * dz)) * planar_mass(j) / rho(j), dr, dz);
    };
    accumulate(b);
    for (int q = offsets(b); q < offsets(b + 1); ++q) accumulate(neighbours(q));
    fit.solve();
    double s[4] = {0, 0, 0, 0};
    auto add = [&](int j) {
      const double dr = x(j, 0) - pr, dz = x(j, 1) - pz;
      const double w = W.value(math::sqrt(dr * dr + dz * dz)) * planar_mass(j) / rho(j) * fit.factor(dr, dz);
      for (int c = 0; c < 4; ++c) s[c] += w * sigma(j, c);
    };
    add(b);
    for (int q = offsets(b); q < offsets(b + 1); ++q) add(neighbours(q));
    // t = sigma . n with sigma = [[rr, rz], [rz, zz]] in the meridian plane
    force(k, 0) = face_area(k) * (s[0] * nr + s[3] * nz);
    force(k, 1) = face_area(k) * (s[3] * nr + s[1] * nz);
  }
};

// Hands each tie particle's force to its interface edge nodes (f_tie must be zeroed first):
// one thread per receiving node, its terms summed in the fixed order of TieParticles, so the
// result is the same bits whatever the threads.
struct TieForceToNodes {
  ViewN<double, 2> force, f_tie;
  View1<int> node_id, node_start, node_tie;
  View1<double> node_share;
  TieForceToNodes(const TieParticles& tie, const fem::FemMesh& mesh) {
    force = tie.force; f_tie = mesh.f_tie; node_id = tie.node_id; node_start = tie.node_start;
    node_tie = tie.node_tie; node_share = tie.node_share;
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int q) const {
    double f0 = 0.0, f1 = 0.0;
    for (int e = node_start(q); e < node_start(q + 1); ++e) {
      const int k = node_tie(e);
      f0 += node_share(e) * force(k, 0);
      f1 += node_share(e) * force(k, 1);
    }
    f_tie(node_id(q), 0) += f0;
    f_tie(node_id(q), 1) += f1;
  }
};

}  // namespace tamp
