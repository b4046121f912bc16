// Rigid bodies of revolution and their penalty contact with SPH particles.
//
// A body is a closed polygon in its own (r, z) half-plane (the meridian section), placed
// at an offset (r0, z0) and moving with a velocity (v_r, v_z). Edges on the axis (r = 0 at
// both ends) close the polygon but are not surfaces. For every particle the exact signed
// distance d to the polygon's surface edges and the outward normal n are computed; a
// particle of spacing dp touches the body when d < dp/2 (its half spacing: the particle
// stands for a cell dp wide). The penetration g = dp/2 - d gives, per unit ring mass,
//   normal:   a_n = max(0, kappa g - 2 xi sqrt(kappa) v_n),  kappa = s c^2 / dp^2
//   friction: a_t = min(mu a_n, min(sqrt(kappa), 1/dt) |v_t|) against the sliding direction,
//             mu = FD + (FS - FD) exp(-DC |v_t|)  (LS-DYNA's friction law)
// with c the particle material's P-wave speed: the contact is as stiff as one particle
// spacing of the soil itself (s = 1), so it keeps the SPH time step stable (omega dt = s^0.5
// c dt / dp < 1) while the penetration under the pounder's weight stays ~1e-3 dp. Below
// the Coulomb bound (stick) the friction is a tangential dashpot at the rate sqrt(kappa).
// The reaction on the body is minus the sum of the particle forces (docs/contact.md).
#pragma once
#include "core/Material.hpp"
#include "core/Particles.hpp"
#include "kernels/DeterministicSum.hpp"

namespace tamp {

constexpr int max_profile_vertices = 48;

struct RigidProfile {
  double r[max_profile_vertices];  // m, body frame, counter-clockwise in (r, z)
  double z[max_profile_vertices];
  int count = 0;
  double r_min = 0, r_max = 0, z_min = 0, z_max = 0;  // bounding box, m

  // Call after filling r, z: the bounding box.
  void finish() {
    r_min = 1e300; r_max = 0; z_min = 1e300; z_max = -1e300;
    for (int k = 0; k < count; ++k) {
      r_min = r[k] < r_min ? r[k] : r_min;
      r_max = r[k] > r_max ? r[k] : r_max;
      z_min = z[k] < z_min ? z[k] : z_min;
      z_max = z[k] > z_max ? z[k] : z_max;
    }
  }
  // False when (pr, pz) is farther than `margin` from the bounding box (no contact).
  KOKKOS_INLINE_FUNCTION bool near_box(double pr, double pz, double margin) const {
    return pr >= r_min - margin && pr <= r_max + margin && pz >= z_min - margin && pz <= z_max + margin;
  }

  // Signed distance (> 0 outside) from (pr, pz) to the surface edges; n = outward normal.
  KOKKOS_INLINE_FUNCTION double signed_distance(double pr, double pz, double& nr, double& nz) const {
    double best = 1e300, bnr = 0, bnz = 1;
    bool inside = false, on_edge = false;
    for (int k = 0; k < count; ++k) {
      const int k2 = (k + 1) % count;
      const double ar = r[k], az = z[k], br = r[k2], bz = z[k2];
      // crossing test (ray in +r) over every edge, the axis edges included
      if ((az > pz) != (bz > pz)) {
        const double rc = ar + (pz - az) * (br - ar) / (bz - az);
        if (pr < rc) inside = !inside;
      }
      if (ar == 0.0 && br == 0.0) continue;  // the axis: not a surface
      const double er = br - ar, ez = bz - az;
      const double len2 = er * er + ez * ez;
      double t = len2 > 0 ? ((pr - ar) * er + (pz - az) * ez) / len2 : 0.0;
      t = t < 0 ? 0 : (t > 1 ? 1 : t);
      const double cr = ar + t * er, cz = az + t * ez;
      const double dr = pr - cr, dz = pz - cz;
      const double d2 = dr * dr + dz * dz;
      if (d2 < best) {
        best = d2;
        const double d = math::sqrt(d2);
        on_edge = !(d > 1e-12);
        if (!on_edge) {
          bnr = dr / d;
          bnz = dz / d;
        } else {  // on the edge: its outward normal (counter-clockwise polygon)
          const double l = math::sqrt(len2);
          bnr = ez / l;
          bnz = -er / l;
        }
      }
    }
    const double d = math::sqrt(best);
    // Inside, the vector from the closest point points inwards: flip it to the outward normal.
    const bool flip = inside && !on_edge;
    nr = flip ? -bnr : bnr;
    nz = flip ? -bnz : bnz;
    return inside ? -d : d;
  }
};

// The kinematic state of one rigid body as the kernels see it.
struct RigidBodyState {
  RigidProfile profile;
  double r0 = 0, z0 = 0;  // m, offset of the body frame
  double v_r = 0, v_z = 0;  // m/s
};

struct ContactLaw {
  double contact_distance = 0;  // m, dp / 2
  double penalty_scale = 1.0;   // s: kappa = s c^2 / dp^2
  double damping_ratio = 0.2;   // xi of the normal contact
  double static_friction = 0.5; // FS
  double dynamic_friction = 0.4;// FD
  double decay = 0.0;           // DC, s/m
};

// Adds the contact acceleration to a and writes the force on each particle ring (N) to
// `force` (zero when not in contact). One particle per thread, no shared writes.
struct PenaltyContact {
  ViewN<double, 2> x, v, a, force;
  View1<double> mass, rho;
  View1<int> material, flags;
  Kokkos::View<const MaterialParams*, MemSpace> materials;
  RigidBodyState body;
  ContactLaw law;
  double dt;

  // Built by name; force (out) is set by the caller.
  PenaltyContact(const Particles& P, const Kokkos::View<const MaterialParams*, MemSpace>& materials_in,
                 const RigidBodyState& body_in, const ContactLaw& law_in, double dt_in)
      : materials(materials_in), body(body_in), law(law_in), dt(dt_in) {
    x = P.x; v = P.v; a = P.a; mass = P.mass; rho = P.rho; material = P.material; flags = P.flags;
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int i) const {
    force(i, 0) = 0.0;
    force(i, 1) = 0.0;
    if (flags(i) & FLAG_DRIVEN) return;
    const double pr = x(i, 0) - body.r0, pz = x(i, 1) - body.z0;
    if (!body.profile.near_box(pr, pz, law.contact_distance)) return;
    double nr, nz;
    const double d = body.profile.signed_distance(pr, pz, nr, nz);
    const double g = law.contact_distance - d;
    if (g <= 0.0) return;
    const double dp = 2.0 * law.contact_distance;
    // A mass-scaled particle (inertia s) keeps the spring (a force per unit mass, from its
    // stiffness M) and responds with s times the inertia; its dashpot rates are those of the
    // spring on that inertia, sqrt(kappa s), and stopping within a step takes s v / dt.
    const MaterialParams& mp = materials(material(i));
    const double s_in = mp.inertia;
    const double c2 = mp.p_wave_modulus() / rho(i);
    const double kappa = law.penalty_scale * c2 / (dp * dp);
    const double rate = math::sqrt(kappa * s_in);
    const double vr = v(i, 0) - body.v_r, vz = v(i, 1) - body.v_z;
    const double vn = vr * nr + vz * nz;
    double an = kappa * g - 2.0 * law.damping_ratio * rate * vn;
    if (an < 0.0) an = 0.0;  // no adhesion
    const double tr = vr - vn * nr, tz = vz - vn * nz;
    const double vt = math::sqrt(tr * tr + tz * tz);
    double ar = an * nr, az = an * nz;
    if (vt > 1e-14) {
      const double mu = law.dynamic_friction +
                        (law.static_friction - law.dynamic_friction) * math::exp(-law.decay * vt);
      // Stick, regularised: below the Coulomb bound the friction is a tangential dashpot
      // at the normal spring's own rate sqrt(kappa), not "stop within this step" (vt/dt):
      // that cap grew without bound as dt fell, made the particles at the pounder chatter
      // step by step, and the pair forces then did work their stress power did not book
      // (lab blow 8: 1.1 J of the 1.7 J energy residual went with the friction).
      // (1/dt bounds the rate for stiff penalty scales: never more than stopping.)
      const double at = math::min(mu * an, math::min(rate, s_in / dt) * vt);
      ar -= at * tr / vt;
      az -= at * tz / vt;
    }
    a(i, 0) += ar;
    a(i, 1) += az;
    force(i, 0) = mass(i) * ar;
    force(i, 1) = mass(i) * az;
  }
};

// Sums over the real particles: the total contact force on the particles (N; the body
// feels minus this), and the power of the contact forces relative to the body,
// sum F_i . (v_i - V) (W; minus the rate of energy stored in or dissipated by the contact).
struct ContactSums {
  double force_r = 0, force_z = 0, power = 0;
  int touching = 0;
};

// The force on the particles feeds the pounder's dynamics: summed in a fixed order, so that
// a run gives the same answer on any number of threads.
inline ContactSums contact_sums(const ViewN<double, 2>& force, const ViewN<double, 2>& v, int n,
                                double body_vr, double body_vz) {
  const auto t = fixed_order_sum<4>("tamp::contact::sums", n, KOKKOS_LAMBDA(int i, double* s) {
    s[0] += force(i, 0);
    s[1] += force(i, 1);
    s[2] += force(i, 0) * (v(i, 0) - body_vr) + force(i, 1) * (v(i, 1) - body_vz);
    s[3] += (force(i, 0) != 0.0 || force(i, 1) != 0.0) ? 1.0 : 0.0;
  });
  ContactSums s;
  s.force_r = t[0];
  s.force_z = t[1];
  s.power = t[2];
  s.touching = static_cast<int>(t[3]);
  return s;
}

// One rigid body of revolution (the pounder, a punch, a sliding block) in penalty contact
// with the particles, and its motion: the same leapfrog as the particles (half kick, drift,
// half kick) on the degrees of freedom it is free in. Its profile and mass are set once;
// place() puts it in the model. Host state: one body, a few scalars.
struct RigidBody {
  RigidProfile profile;           // meridian section in the body frame, m
  double mass = 0;                // kg (the whole body of revolution)
  bool free_r = false, free_z = true;  // degrees of freedom integrated from the forces
  bool kinematic = false;         // true: the velocity is prescribed (a displacement-driven punch)
  bool active = false;            // in the model (false: lifted out)
  double r0 = 0, z0 = 0;          // m, position of the body frame
  double v_r = 0, v_z = 0;        // m/s
  double a_r = 0, a_z = 0;        // m/s2, of the last step
  ContactSums contact;            // forces on the particles in the last step (body: minus)

  RigidBodyState state() const { return {profile, r0, z0, v_r, v_z}; }
  void half_kick(double dt_half) {
    if (!active || kinematic) return;
    v_r += dt_half * a_r;
    v_z += dt_half * a_z;
  }
  void drift(double dt) {
    if (!active) return;
    r0 += dt * v_r;
    z0 += dt * v_z;
  }
  // The acceleration from the contact forces on the particles (the body takes minus their
  // sum) and gravity, m/s2.
  void take_contact(const ContactSums& sums, double gravity) {
    contact = sums;
    if (!kinematic) {
      a_r = free_r ? -contact.force_r / mass : 0.0;
      a_z = free_z ? -contact.force_z / mass - gravity : 0.0;
    } else {
      a_r = a_z = 0.0;
    }
  }
  // Kinetic + potential energy (z0 the height of the body frame), J; 0 when lifted out.
  double energy(double gravity) const {
    if (!active) return 0.0;
    return 0.5 * mass * (v_r * v_r + v_z * v_z) + mass * gravity * z0;
  }
};

}  // namespace tamp

namespace tamp {

// A barrel (the lab pounder): radius base_d/2 at the base and the top, max_d/2 at
// mid-height, parabolic in between; base at z = 0 of the body frame.
inline RigidProfile barrel_profile(double base_d, double max_d, double height, int segments) {
  RigidProfile p;
  const double rb = 0.5 * base_d, rm = 0.5 * max_d;
  p.r[p.count] = 0.0; p.z[p.count++] = 0.0;
  for (int k = 0; k <= segments && p.count < max_profile_vertices - 1; ++k) {
    const double s = static_cast<double>(k) / segments;  // 0 at the base, 1 at the top
    const double u = 2.0 * s - 1.0;
    p.r[p.count] = rb + (rm - rb) * (1.0 - u * u);
    p.z[p.count++] = s * height;
  }
  p.r[p.count] = 0.0; p.z[p.count++] = height;
  p.finish();
  return p;
}

// A rectangle r_min..r_max, z_min..z_max (a flat punch when r_min = 0; a ring otherwise).
inline RigidProfile rectangle_profile(double r_min, double r_max, double z_min, double z_max) {
  RigidProfile p;
  const double rr[4] = {r_min, r_max, r_max, r_min}, zz[4] = {z_min, z_min, z_max, z_max};
  for (int k = 0; k < 4; ++k) {
    p.r[k] = rr[k];
    p.z[k] = zz[k];
  }
  p.count = 4;
  p.finish();
  return p;
}

}  // namespace tamp
