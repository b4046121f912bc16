// Mirror (ghost) particles for the symmetry axis and rigid walls.
//
// A plane x[axis] = position bounds the domain on the side `side` (+1: the domain lies at
// x[axis] > position). Every particle within `band` of the plane gets a mirror image:
//   position   x[axis] -> 2 position - x[axis]
//   velocity   the normal component flips (free slip), at the axis, a roller and a fixed
//              wall alike. A fixed wall grips the soil by Coulomb friction instead
//              (kernels/WallFriction.hpp): its ghosts are flagged FLAG_FIXED_WALL_GHOST so
//              that their pair forces, the wall's normal support, are summed apart. (Flipping
//              the tangential velocity too, the former no-slip image, is not a symmetry of
//              the pair equations: that wall did work, +187 % of the blow in the
//              elastic-layer drop; docs/sph.md.)
//   stress     the shear component rz flips; normal components are kept, except that
//              behind a wall z = const the vertical stress continues the gravity
//              gradient (sigma_zz,g = sigma_zz,s - rho g (z_s - z_g)), so the wall carries
//              the weight of the soil above it instead of a stress-free-gradient image
// Planes are processed in order and each sees the ghosts of the previous ones, so a
// corner (axis + bottom) gets its doubly mirrored particles.
#pragma once
#include <vector>
#include "core/Particles.hpp"

namespace tamp {

struct MirrorPlane {
  int axis = 0;          // 0: plane r = position; 1: plane z = position
  double position = 0;   // m
  int side = 1;          // +1: domain at x[axis] > position, -1: at x[axis] < position
  int no_slip = 0;       // 1: fixed (rough) wall, 0: roller / symmetry
  double spring_distance = 0;  // non-reflecting planes only: R of the static springs, m (0: none)
};

constexpr int max_mirror_planes = 4;

struct MirrorPlanes {
  MirrorPlane plane[max_mirror_planes];
  int count = 0;
};

class MirrorGhosts {
 public:
  MirrorPlanes planes;

  // Creates the ghosts of all planes for the current positions, then syncs all fields.
  void generate(Particles& p, double band, double gravity);
  // Ghost x, v, rho, planar mass, material, flags from their sources.
  void sync_kinematics(Particles& p) const;
  // Ghost sigma, artificial stress and rho from their sources.
  void sync_stress(Particles& p, double gravity) const;
  int ghost_count() const { return ghost_count_; }

  // The ghosts [begin, end) of plane `plane`. Public only because nvcc does not allow device
  // lambdas in private member functions.
  struct Range { int begin, end, plane; };
  void sync_range_kinematics(Particles& p, const Range& rg) const;

 private:
  std::vector<Range> ranges_;
  int ghost_count_ = 0;
  double gravity_ = 0;
};

inline void MirrorGhosts::generate(Particles& p, double band, double gravity) {
  gravity_ = gravity;
  using policy = Kokkos::RangePolicy<ExecSpace>;
  ranges_.clear();
  int n = p.n_real + p.n_tie;  // real and tie particles are the sources
  for (int ip = 0; ip < planes.count; ++ip) {
    const MirrorPlane pl = planes.plane[ip];
    auto x = p.x;
    auto near = KOKKOS_LAMBDA(int i) {
      const double d = (x(i, pl.axis) - pl.position) * pl.side;
      return d >= -band && d < band;
    };
    int count = 0;
    Kokkos::parallel_reduce(
        "tamp::mirror::count", policy(0, n),
        KOKKOS_LAMBDA(int i, int& c) { c += near(i) ? 1 : 0; }, count);
    p.reserve(n + count);
    auto src = p.ghost_source;
    const int base = n;
    auto x2 = p.x;
    Kokkos::parallel_scan(
        "tamp::mirror::fill", policy(0, n), KOKKOS_LAMBDA(int i, int& k, bool final) {
          const double d = (x2(i, pl.axis) - pl.position) * pl.side;
          if (d >= -band && d < band) {
            if (final) src(base + k) = i;
            ++k;
          }
        });
    ranges_.push_back({n, n + count, ip});
    // Place this plane's ghosts now: the next plane selects its sources, these ghosts
    // included (corner images), by position. (Placing all ghosts only at the end left the
    // next plane reading stale positions: corner ghosts went missing, and the particles
    // at the corner of the base and the outer wall fell through, issue 2's base defect.)
    p.n_total = n + count;
    sync_range_kinematics(p, ranges_.back());
    n += count;
  }
  p.n_total = n;
  ghost_count_ = n - p.n_real - p.n_tie;
  sync_kinematics(p);
  sync_stress(p, gravity_);
}

inline void MirrorGhosts::sync_kinematics(Particles& p) const {
  for (const Range& rg : ranges_) sync_range_kinematics(p, rg);
}

inline void MirrorGhosts::sync_range_kinematics(Particles& p, const Range& rg) const {
  auto x = p.x; auto v = p.v; auto rho = p.rho; auto mp = p.planar_mass; auto mass = p.mass;
  auto mat = p.material; auto flags = p.flags; auto src = p.ghost_source;
  {
    const MirrorPlane pl = planes.plane[rg.plane];
    const bool across_axis = pl.axis == 0 && pl.position == 0.0;
    Kokkos::parallel_for(
        "tamp::mirror::kinematics", Kokkos::RangePolicy<ExecSpace>(rg.begin, rg.end),
        KOKKOS_LAMBDA(int g) {
          const int s = src(g);
          const int t = 1 - pl.axis;  // tangential axis
          x(g, pl.axis) = 2.0 * pl.position - x(s, pl.axis);
          x(g, t) = x(s, t);
          v(g, pl.axis) = -v(s, pl.axis);
          v(g, t) = v(s, t);
          rho(g) = rho(s);
          mp(g) = mp(s);
          // Ring mass. Across the axis, the source's, negated: the areal density
          // eta = 2 pi r rho is odd in r, and the ring-mass sums need its odd extension to
          // stay consistent at the axis; across a plane z = const, the source's; across a
          // plane r = R, the planar mass at the ghost's own radius. (Not 2 pi r mp for the
          // first two: within the regularised radius of the axis mp = m / (2 pi r~), r~ > r,
          // and the pair terms would no longer be the conjugates of the strain rates.)
          mass(g) = across_axis ? -mass(s) : (pl.axis == 1 ? mass(s) : 2.0 * pi * x(g, 0) * mp(s));
          mat(g) = mat(s);
          flags(g) = pl.no_slip ? (flags(s) | FLAG_FIXED_WALL_GHOST) : flags(s);
        });
  }
}

inline void MirrorGhosts::sync_stress(Particles& p, double gravity) const {
  auto sigma = p.sigma; auto R = p.art_stress; auto rho = p.rho; auto src = p.ghost_source;
  auto x = p.x; auto mp = p.planar_mass; auto ps = p.pair_stress;
  for (const Range& rg : ranges_) {
    const double grav = planes.plane[rg.plane].axis == 1 ? gravity : 0.0;
    Kokkos::parallel_for(
        "tamp::mirror::stress", Kokkos::RangePolicy<ExecSpace>(rg.begin, rg.end),
        KOKKOS_LAMBDA(int g) {
          const int s = src(g);
          sigma(g, 0) = sigma(s, 0);
          sigma(g, 1) = sigma(s, 1) - rho(s) * grav * (x(s, 1) - x(g, 1));
          sigma(g, 2) = sigma(s, 2);
          sigma(g, 3) = -sigma(s, 3);
          R(g, 0) = R(s, 0);
          R(g, 1) = R(s, 1);
          R(g, 2) = -R(s, 2);
          rho(g) = rho(s);
          set_pair_stress(g, mp, rho, sigma, ps);  // core/Particles.hpp
        });
  }
}

}  // namespace tamp
