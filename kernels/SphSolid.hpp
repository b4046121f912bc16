// Axisymmetric SPH for solids: the two pair loops of a step.
//
// Formulation: ring-mass form (after Garcia-Senz et al. 2009, MNRAS 392, 346; equations
// in docs/sph.md). Particle a is a ring of mass m_a; 2D kernel sums over the (r, z) plane
// use ring masses and the areal density eta = 2 pi r rho. Writing rho a = div(sigma) +
// hoop terms as (1/eta) div(2 pi r sigma) - sigma_tt/(rho r) e_r gives a pair term that is
// symmetric in ring masses, so the discrete equations conserve momentum in z and total
// energy exactly (semi-discretely) when the strain rate uses the conjugate weights m_b/eta_a:
//   grad v_a   = sum_b (m_b / eta_a) (v_b - v_a) (x) grad_a W_ab
//   d_tt       = chi_a v_r / r,   drho/dt = -rho (dv_r/dr + dv_z/dz + d_tt)
//   dv_a/dt    = sum_b m_b (S_a + S_b - Pi_ab I) . grad_a W_ab - chi_a sigma_tt,a / (rho_a r_a) e_r
// with chi_a the discrete radial moment (~1; see StrainRateAndStress)
//   S_a        = sigma_a / (2 pi r_a rho_a^2)
// with 1/r regularised as 1/max(r, c h) near the axis. The axis and rigid walls are
// represented by mirror particles (kernels/Mirror.hpp).
#pragma once
#include "core/Material.hpp"
#include "core/Particles.hpp"
#include "kernels/BoundaryLoads.hpp"
#include "kernels/NeighbourList.hpp"
#include "kernels/Wendland.hpp"
#include "models/StressUpdate.hpp"

namespace tamp {

// first_image of the pair loops when the image pairs are not summed apart (no images known)
constexpr int kNoImages = 2147483647;

struct SphParams {
  double h = 0;               // smoothing length, m
  double alpha = 0.5;         // Monaghan viscosity, linear
  double beta = 0.0;          // Monaghan viscosity, quadratic
  double artificial_stress_epsilon = 0.0;       // Gray-Monaghan-Swift epsilon
  double art_n = 2.55;        // exponent n
  double inv_w_dp = 0;        // 1 / W(dp)
  double r_min = 0;           // regularised radius c h, m
  double gravity = 0;         // m/s2 in -z
  double damping = 0;         // 1/s
  int kernel_correction = 1;  // first-order gradient correction in the velocity gradient
};

// Loop A: velocity gradient (with the hoop rate), continuity, stress update through the
// material model (a model of the list Models, models/ModelList.hpp), internal energy,
// artificial stress R. Writes only particle a.
template <class Models = RegisteredModels>
struct StrainRateAndStressT {
  ViewN<double, 2> x, v;
  ViewN<double, 2> image_work;  // in/out: += the stress power booked for pairs with mirror images (see below)
  View1<double> hoop_factor;  // out: chi, the hoop term is chi / r (see below)
  View1<double> pair_gradient_factor;  // out: (dW/dr)/r of every listed pair, 0 beyond the support
  View1<double> mass, rho, plastic_strain, compaction, internal_energy;
  ViewN<double, kHistorySlots> history;
  ViewN<double, 4> sigma;
  ViewN<double, 3> art_stress;
  View1<int> material;
  View1<int> offsets, neighbours;
  Kokkos::View<const MaterialParams*, MemSpace> materials;
  SphParams p;
  double dt;
  int first_image = kNoImages;  // index of the first mirror image (n_real + n_tie); none by default

  // Built by name: the particle fields, the neighbour list, the pair factors it writes.
  StrainRateAndStressT(const Particles& P, const NeighbourList& list, const View1<double>& pair_gradient_factor_out,
                      const Kokkos::View<const MaterialParams*, MemSpace>& materials_in, const SphParams& p_in,
                      double dt_in)
      : pair_gradient_factor(pair_gradient_factor_out), materials(materials_in), p(p_in), dt(dt_in) {
    x = P.x; v = P.v; hoop_factor = P.hoop_factor; mass = P.mass; rho = P.rho;
    plastic_strain = P.plastic_strain; compaction = P.compaction; history = P.history;
    internal_energy = P.internal_energy;
    sigma = P.sigma; art_stress = P.art_stress; material = P.material; image_work = P.image_work;
    offsets = list.offsets; neighbours = list.neighbours;
  }
  // Mirror images are not integrated: a pair of a real particle and an image is one-sided,
  // and its stress terms are not the conjugates of the strain rates (docs/sph.md, "Energy
  // of the image pairs"). What such pairs give the particles is summed per particle in
  // image_work: here the part of a's stress power that its image pairs contribute (the
  // image terms of the velocity gradient, with the same trapezoidal stress), and in the
  // kicks the work of the image pairs' force (Acceleration's image_force). For real pairs
  // the two parts cancel pair by pair; for image pairs the sum is a numerical energy source.
  KOKKOS_INLINE_FUNCTION void operator()(const int a) const {
    const Wendland2D W(p.h);
    const double xa = x(a, 0), za = x(a, 1);
    const double vra = v(a, 0), vza = v(a, 1);
    const double r_reg = math::max(xa, p.r_min);
    const double inv_eta_a = 1.0 / (2.0 * pi * r_reg * rho(a));
    double G00 = 0, G01 = 0, G10 = 0, G11 = 0;  // sum V_b (v_b - v_a)_i dW/dx_j
    double B00 = 0, B01 = 0, B10 = 0, B11 = 0;  // sum V_b (x_b - x_a)_i dW/dx_j
    // the image pairs' part of G: axis images (A) and wall images (W), components 00, 01, 10, 11
    // (scalars, not an array: an indexed local array left the pair loop measurably slower)
    double A00 = 0, A01 = 0, A10 = 0, A11 = 0, W00 = 0, W01 = 0, W10 = 0, W11 = 0;
    for (int k = offsets(a); k < offsets(a + 1); ++k) {
      const int b = neighbours(k);
      const double dr = xa - x(b, 0), dz = za - x(b, 1);
      const double f = W.gradient_factor(dr * dr + dz * dz);
      pair_gradient_factor(k) = f;  // grad_a W = f * (x_a - x_b); reused by the acceleration loop
      if (f == 0.0) continue;  // listed within the Verlet skin, outside the kernel
      const double gr = f * dr, gz = f * dz;
      const double Vb = mass(b) * inv_eta_a;
      const double dvr = v(b, 0) - vra, dvz = v(b, 1) - vza;
      G00 += Vb * dvr * gr; G01 += Vb * dvr * gz;
      G10 += Vb * dvz * gr; G11 += Vb * dvz * gz;
      B00 -= Vb * dr * gr; B01 -= Vb * dr * gz;
      B10 -= Vb * dz * gr; B11 -= Vb * dz * gz;
      if (b >= first_image) {
        if (Vb < 0) {  // axis images (and corner images) carry negative ring mass
          A00 += Vb * dvr * gr; A01 += Vb * dvr * gz; A10 += Vb * dvz * gr; A11 += Vb * dvz * gz;
        } else {
          W00 += Vb * dvr * gr; W01 += Vb * dvr * gz; W10 += Vb * dvz * gr; W11 += Vb * dvz * gz;
        }
      }
    }
    double L00 = G00, L01 = G01, L10 = G10, L11 = G11;
    if (p.kernel_correction) {
      // L = G B^-1 reproduces linear velocity fields exactly (Randles & Libersky 1996).
      const double det = B00 * B11 - B01 * B10;
      if (math::abs(det) > 0.25) {  // well-conditioned (det = 1 in the bulk)
        const double i00 = B11 / det, i01 = -B01 / det, i10 = -B10 / det, i11 = B00 / det;
        L00 = G00 * i00 + G01 * i10; L01 = G00 * i01 + G01 * i11;
        L10 = G10 * i00 + G11 * i10; L11 = G10 * i01 + G11 * i11;
        // the images' part of L = G B^-1, likewise
        double c00 = A00 * i00 + A01 * i10, c01 = A00 * i01 + A01 * i11;
        double c10 = A10 * i00 + A11 * i10, c11 = A10 * i01 + A11 * i11;
        A00 = c00; A01 = c01; A10 = c10; A11 = c11;
        c00 = W00 * i00 + W01 * i10; c01 = W00 * i01 + W01 * i11;
        c10 = W10 * i00 + W11 * i10; c11 = W10 * i01 + W11 * i11;
        W00 = c00; W01 = c01; W10 = c10; W11 = c11;
      }
    }
    // Hoop factor chi/r. SPH's discrete radial first moment B00 = sum_b V_b (r_b - r_a)
    // dW/dr is not exactly 1 on a lattice (0.984 for Wendland C2 at h = 1.3 dp); with the
    // analytic 1/r, a uniform stress sigma_rr = sigma_tt then leaves a radial body force
    // (B00 - 1) sigma / (rho r) that bends geostatic columns. Using chi = B00 in both the
    // hoop rate and the hoop force keeps them conjugate (energy) and makes a uniform
    // stress an exact discrete equilibrium. Near a free surface B00 is truncated (~0.5):
    // there chi returns smoothly to 1 (full B00 within 5 % of 1, analytic beyond 10 %).
    const double dev = math::abs(B00 - 1.0);
    const double blend = dev <= 0.05 ? 1.0 : (dev >= 0.10 ? 0.0 : (0.10 - dev) / 0.05);
    const double chi = 1.0 + blend * (B00 - 1.0);
    hoop_factor(a) = chi;
    const double d_tt = vra * chi / r_reg;
    const double div = L00 + L11 + d_tt;
    // L01 = dv_r/dz, L10 = dv_z/dr
    const double deps[4] = {L00 * dt, L11 * dt, d_tt * dt, 0.5 * (L01 + L10) * dt};
    const double w_rz_dt = 0.5 * (L01 - L10) * dt;

    const MaterialParams& m = materials(material(a));
    double s[4] = {sigma(a, 0), sigma(a, 1), sigma(a, 2), sigma(a, 3)};
    const double s_old[4] = {s[0], s[1], s[2], s[3]};
    MaterialState state;
    state.plastic_strain = plastic_strain(a);
    state.compaction = compaction(a);
    if constexpr (Models::has_history)
      for (int k = 0; k < kHistorySlots; ++k) state.history[k] = history(a, k);
    update_stress<Models>(m, s, deps, w_rz_dt, state, dt);
    double& eps_v = state.compaction;

    // Continuity, bounded to [0.7, 1.5] rho_0: at a free surface (crater rims, splashed
    // particles) the truncated kernel gives a spurious div v, and the hypoelastic stress
    // does not push back on density, so rho drifted without bound (to 0.04 rho_0 after 15
    // blows of the lab test, then NaN). Soil volume changes stay far inside these bounds
    // (compaction: at most the air voids, ~15 %).
    const double rho0 = m.density;
    double rho_new = math::min(1.5 * rho0, math::max(0.7 * rho0, rho(a) * math::exp(-div * dt)));
    // Separated grains: a granular material looser than its loosest packing has no grain
    // contacts and carries no stress (Dunatunga & Kamrin 2015, JFM 779: the "disconnected"
    // phase below the critical packing density). Without this, a grain dilated to 0.7 rho_0
    // under the pounder kept the compressive stress it was loaded with and, reaching its
    // neighbours 2.5-3.5 spacings away through the kernel's tail, held the pounder up (a
    // sparse skeleton). Its elastic energy is released into the internal energy's
    // dissipated part: the internal energy (the work done) is unchanged.
    // A separated grain keeps its loosest packing: its density is held at the separation
    // density, and it takes load again at its first compression. One particle is one grain;
    // a grain that leaves the surface (a splash, a grain sliding down a heap's flank) sees
    // its neighbours only on one side, and the truncated kernel's spurious expansion took its
    // continuity density down to the floor (0.7 rho_0), so that on landing it had to be
    // compressed by a fifth, stress-free, before it touched anything: it slid on (the poured
    // heap's moving grains, docs/drop-sequence.md). The price: a uniformly dilated cloud of
    // grains also reconnects at its first compression, not back at its loosest packing.
    // A grain without contacts keeps no packing history but its density: its compaction
    // (log volumetric strain from the placed density, compression positive) is set from
    // it, so that a charge loosened by flowing can be compacted again (effect (a); the
    // hardening variable of Cam-Clay likewise) instead of having spent its air voids once.
    if (m.separation_density > 0.0 && rho_new < m.separation_density) {
      for (int c = 0; c < 4; ++c) s[c] = 0.0;
      rho_new = m.separation_density;
      eps_v = math::log(rho_new / rho0);
    }
    compaction(a) = eps_v;
    // Stress power per unit mass, trapezoidal in the stress: du = sigma : deps / rho.
    double work = 0;
    for (int c = 0; c < 3; ++c) work += 0.5 * (s[c] + s_old[c]) * deps[c];
    work += 2.0 * 0.5 * (s[3] + s_old[3]) * deps[3];
    internal_energy(a) += work / (0.5 * (rho(a) + rho_new));
    if (first_image < kNoImages) {  // the images' share of that work, same rule
      const double k = 0.5 * dt / (0.5 * (rho(a) + rho_new));
      image_work(a, 0) += k * ((s[0] + s_old[0]) * A00 + (s[1] + s_old[1]) * A11 + (s[3] + s_old[3]) * (A01 + A10));
      image_work(a, 1) += k * ((s[0] + s_old[0]) * W00 + (s[1] + s_old[1]) * W11 + (s[3] + s_old[3]) * (W01 + W10));
    }

    for (int c = 0; c < 4; ++c) sigma(a, c) = s[c];
    plastic_strain(a) = state.plastic_strain;
    if constexpr (Models::has_history)
      for (int k = 0; k < kHistorySlots; ++k) history(a, k) = state.history[k];
    rho(a) = rho_new;

    // Artificial stress (Gray, Monaghan & Swift 2001): R' = -eps sigma' / rho^2 for each
    // tensile in-plane principal stress sigma' > 0, rotated back to (r, z) with the double
    // angle (cos 2t, sin 2t) of the principal direction (no trigonometric calls).
    const double mean = 0.5 * (s[0] + s[1]), half = 0.5 * (s[0] - s[1]);
    const double rad = math::sqrt(half * half + s[3] * s[3]);
    const double l1 = mean + rad, l2 = mean - rad;
    if (l1 <= 0.0 || p.artificial_stress_epsilon == 0.0) {
      art_stress(a, 0) = 0.0;
      art_stress(a, 1) = 0.0;
      art_stress(a, 2) = 0.0;
    } else {
      const double k = -p.artificial_stress_epsilon / (rho_new * rho_new);
      const double R1 = k * l1, R2 = l2 > 0 ? k * l2 : 0.0;
      const double c2 = rad > 0 ? half / rad : 1.0, s2 = rad > 0 ? s[3] / rad : 0.0;
      art_stress(a, 0) = 0.5 * (R1 + R2) + 0.5 * (R1 - R2) * c2;
      art_stress(a, 1) = 0.5 * (R1 + R2) - 0.5 * (R1 - R2) * c2;
      art_stress(a, 2) = 0.5 * (R1 - R2) * s2;
    }
  }
};
using StrainRateAndStress = StrainRateAndStressT<>;

// Loop B: acceleration from the stress divergence (symmetric SPH form), artificial
// stress, Monaghan viscosity, hoop terms, gravity, damping and external accelerations;
// and the rate of viscous heating (the energy-conjugate of the viscous pair force).
// The artificial stress is a numerical stabiliser with no stored energy: its part of the
// acceleration is written apart (a_art) so that the energy account can sum its work.
// Writes only particle a.
struct Acceleration {
  ViewN<double, 2> x, v, a, a_ext;
  ViewN<double, 2> a_wall;    // out: the part of a from fixed-wall ghosts (if fixed_walls)
  ViewN<double, 2> a_art;     // out: the artificial stress's part of a (if artificial_stress_epsilon > 0)
  ViewN<double, 4> image_force;  // out: the stress pair force of the images (axis r, z; walls r, z), if first_image is set
  View1<int> flags;
  View1<double> mass, rho, du_visc;
  ViewN<double, 4> sigma;
  ViewN<double, 3> pair_stress, art_stress;
  View1<int> material;
  View1<int> offsets, neighbours;
  View1<double> pair_gradient_factor;       // from StrainRateAndStress, same positions
  View1<double> hoop_factor;  // from StrainRateAndStress
  Kokkos::View<const MaterialParams*, MemSpace> materials;
  SphParams p;
  Kokkos::View<const double*, MemSpace> artificial_stress_factors;  // (W(q)/W(dp))^n tabulated, see below
  // P-wave speed of each material (m/s), MaterialParams::wave_speed() computed once: the
  // viscosity of every approaching pair needs its neighbour's, and a square root and a
  // division per pair were measurable in the step.
  Kokkos::View<const double*, MemSpace> wave_speeds;
  int fixed_walls = 0;  // 1: the model has a fixed wall; sum its ghosts' pair forces apart
  int first_image = kNoImages;  // index of the first mirror image (n_real + n_tie); none by default
  // index of the first tie particle (n_real) when the model has tie particles; none by default
  int first_tie = kNoImages;

  // Built by name; the parts written apart (a_wall, a_art) and fixed_walls are set by the
  // caller by name.
  Acceleration(const Particles& P, const NeighbourList& list, const View1<double>& pair_gradient_factor_in,
               const Kokkos::View<const MaterialParams*, MemSpace>& materials_in, const SphParams& p_in,
               const Kokkos::View<const double*, MemSpace>& artificial_stress_factors_in,
               const Kokkos::View<const double*, MemSpace>& wave_speeds_in)
      : pair_gradient_factor(pair_gradient_factor_in), materials(materials_in), p(p_in),
        artificial_stress_factors(artificial_stress_factors_in), wave_speeds(wave_speeds_in) {
    x = P.x; v = P.v; a = P.a; a_ext = P.a_ext; flags = P.flags; mass = P.mass; rho = P.rho;
    du_visc = P.du_visc; sigma = P.sigma; pair_stress = P.pair_stress; art_stress = P.art_stress;
    material = P.material; hoop_factor = P.hoop_factor; image_force = P.image_force;
    offsets = list.offsets; neighbours = list.neighbours;
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int i) const {
    const double xa = x(i, 0), za = x(i, 1);
    const double vra = v(i, 0), vza = v(i, 1);
    const double rhoa = rho(i);
    const double r_reg = math::max(xa, p.r_min);
    const double ia2 = 1.0 / (2.0 * pi * r_reg * rhoa * rhoa);
    const double Sa_rr = sigma(i, 0) * ia2, Sa_zz = sigma(i, 1) * ia2, Sa_rz = sigma(i, 3) * ia2;
    const double Ra_rr = art_stress(i, 0), Ra_zz = art_stress(i, 1), Ra_rz = art_stress(i, 2);
    const bool Ra_on = p.artificial_stress_epsilon > 0 && (Ra_rr != 0 || Ra_zz != 0 || Ra_rz != 0);
    const double ca = wave_speeds(material(i));
    const double share_a = materials(material(i)).viscosity;  // a's share of the viscosity
    const double head_on_a = materials(material(i)).viscosity_head_on;
    double ar = 0, az = 0, heat = 0, wr = 0, wz = 0, sr = 0, sz = 0;
    double image_ar = 0, image_az = 0, image_wr = 0, image_wz = 0;  // the images' stress pair force: axis, walls
    for (int k = offsets(i); k < offsets(i + 1); ++k) {
      const double f = pair_gradient_factor(k);
      if (f == 0.0) continue;
      const int b = neighbours(k);
      const double dr = xa - x(b, 0), dz = za - x(b, 1);
      const double gr = f * dr, gz = f * dz;
      const double mb = mass(b);
      // m_b (S_a + S_b) with m_b S_b = mp_b sigma_b / rho_b^2 (sign-free for axis ghosts,
      // whose ring mass m_b is negative: Mirror.hpp)
      double Trr = mb * Sa_rr + pair_stress(b, 0);
      double Tzz = mb * Sa_zz + pair_stress(b, 1);
      double Trz = mb * Sa_rz + pair_stress(b, 2);
      if (b >= first_image) {  // the stress pair force of an image (see StrainRateAndStress)
        if (mb < 0) {
          image_ar += Trr * gr + Trz * gz; image_az += Trz * gr + Tzz * gz;
        } else {
          image_wr += Trr * gr + Trz * gz; image_wz += Trz * gr + Tzz * gz;
        }
      }
      const double mb_abs = mb < 0 ? -mb : mb;
      const double rb = math::max(math::abs(x(b, 0)), p.r_min);
      const double ring = mb_abs / (pi * (r_reg + rb));  // |m_b| / (2 pi mean r) = planar mass
      if (Ra_on || (p.artificial_stress_epsilon > 0 && (art_stress(b, 0) != 0 || art_stress(b, 1) != 0 || art_stress(b, 2) != 0))) {
        const double r = math::sqrt(dr * dr + dz * dz);
        // f_ab^n from the table (linear interpolation in q = r/h; pow per pair cost a
        // quarter of the step time)
        const int nt = static_cast<int>(artificial_stress_factors.extent(0)) - 1;
        const double u = r / p.h * (0.5 * nt);
        const int it = u < nt ? static_cast<int>(u) : nt - 1;
        const double t = u - it;
        const double fab = (1.0 - t) * artificial_stress_factors(it) + t * artificial_stress_factors(it + 1);
        const double Arr = ring * fab * (Ra_rr + art_stress(b, 0));
        const double Azz = ring * fab * (Ra_zz + art_stress(b, 1));
        const double Arz = ring * fab * (Ra_rz + art_stress(b, 2));
        Trr += Arr;
        Tzz += Azz;
        Trz += Arz;
        sr += Arr * gr + Arz * gz;
        sz += Arz * gr + Azz * gz;
      }
      const double dvr = vra - v(b, 0), dvz = vza - v(b, 1);
      const double vdotx = dvr * dr + dvz * dz;
      if (vdotx < 0) {
        const double r2 = dr * dr + dz * dz;
        const double mu = p.h * vdotx / (r2 + 0.01 * p.h * p.h);
        const double rhob = rho(b);
        const double cb = wave_speeds(material(b));
        // the pair's share of [sph] alpha and beta: the mean of its materials' (1 by default)
        const double share = 0.5 * (share_a + materials(material(b)).viscosity);
        double Pi = ring * share * (-p.alpha * 0.5 * (ca + cb) * mu + p.beta * mu * mu) / (0.5 * (rhoa + rhob));
        // Head-on viscosity (docs/sph.md): grains that slide past each other are not pushed
        // apart, grains that collide are damped; the weight 1 - s (1 - cos g), cos g in (0, 1]
        // the cosine between -v_ab and x_ab (approaching: v_ab . x_ab < 0, so neither is zero).
        const double head_on = 0.5 * (head_on_a + materials(material(b)).viscosity_head_on);
        if (head_on > 0) {
          const double cos_g = -vdotx / math::sqrt((dvr * dvr + dvz * dvz) * r2);
          Pi *= 1.0 - head_on * (1.0 - cos_g);
        }
        Trr -= Pi;
        Tzz -= Pi;
        // Heat: each particle of a pair books half of the pair's viscous dissipation. A tie
        // particle is not integrated and the elements do not receive the viscous force
        // (the tie hands them the stress traction), so the force on a is not reciprocated:
        // a books the whole work it does on a, Pi (v_a . grad W), which can be of either sign.
        heat += b >= first_tie && b < first_image ? Pi * (vra * gr + vza * gz) : 0.5 * Pi * (dvr * gr + dvz * gz);
      }
      ar += Trr * gr + Trz * gz;
      az += Trz * gr + Tzz * gz;
      if (fixed_walls && (flags(b) & FLAG_FIXED_WALL_GHOST)) {
        wr += Trr * gr + Trz * gz;
        wz += Trz * gr + Tzz * gz;
      }
    }
    if (fixed_walls) {
      a_wall(i, 0) = wr;
      a_wall(i, 1) = wz;
    }
    if (p.artificial_stress_epsilon > 0) {
      a_art(i, 0) = sr;
      a_art(i, 1) = sz;
    }
    if (first_image < kNoImages) {
      image_force(i, 0) = image_ar; image_force(i, 1) = image_az;
      image_force(i, 2) = image_wr; image_force(i, 3) = image_wz;
    }
    ar -= sigma(i, 2) * hoop_factor(i) / (rhoa * r_reg);
    az -= p.gravity;
    // mass-proportional damping on the inertia: the same rate p.damping for a mass-scaled material
    const double damp = p.damping * materials(material(i)).inertia;
    ar += a_ext(i, 0) - damp * vra;
    az += a_ext(i, 1) - damp * vza;
    a(i, 0) = ar;
    a(i, 1) = az;
    du_visc(i) = heat;
  }
};

// (dW/dr)/r for every listed pair at the current positions (as StrainRateAndStress
// stores them); used when the acceleration is needed before a strain-rate pass.
struct PairKernelFactors {
  ViewN<double, 2> x;
  View1<int> offsets, neighbours;
  View1<double> pair_gradient_factor;
  double h;
  PairKernelFactors(const Particles& P, const NeighbourList& list, const View1<double>& pair_gradient_factor_out, double h_in)
      : pair_gradient_factor(pair_gradient_factor_out), h(h_in) {
    x = P.x; offsets = list.offsets; neighbours = list.neighbours;
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int a) const {
    const Wendland2D W(h);
    for (int k = offsets(a); k < offsets(a + 1); ++k) {
      const int b = neighbours(k);
      const double dr = x(a, 0) - x(b, 0), dz = x(a, 1) - x(b, 1);
      pair_gradient_factor(k) = W.gradient_factor(dr * dr + dz * dz);
    }
  }
};

// A particle's share of the pair term: mp sigma / rho^2 (rr, zz, rz). Run on the real
// particles after every stress change; MirrorGhosts::sync_stress fills the ghosts.
struct PairStress {
  View1<double> planar_mass, rho;
  ViewN<double, 4> sigma;
  ViewN<double, 3> pair_stress;
  explicit PairStress(const Particles& P) {
    planar_mass = P.planar_mass; rho = P.rho; sigma = P.sigma; pair_stress = P.pair_stress;
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int i) const { set_pair_stress(i, planar_mass, rho, sigma, pair_stress); }
};

// Non-reflecting viscous-spring boundary. The particles held by a boundary (its boundary
// layer, 0 <= d < dp, when the boundary stress was recorded; flag bit FLAG_HELD_BOUNDARY << k)
// carry the traction of Lysmer & Kuhlemeyer (1969) dashpots and of the static springs of
// Deeks & Randolph (1994) / Liu et al. (2006), plus the static traction t0 recorded then:
//   t_n = t0_n - rho c_p v_n - K_n u_n,   t_t = t0_t - rho c_s v_t - K_t u_t,
//   c_p = sqrt((K + 4G/3)/rho),  c_s = sqrt(G/rho),  K_n = 4G/(3R),  K_t = 2G/(3R),
// u = x - x_hold, as a force on the particle's ring: a = t (face_r / r) / (rho dp)
// (face_r / r = 1 for a face z = const). The springs give the far field its static
// stiffness: with dashpots alone a lasting load (the compacted sand next to the lab's wall)
// pushes soil out through the boundary at a constant rate. Membership is kept when a
// particle moves, so a held particle pushed past the plane is still pulled back.
struct NonReflectingBoundary {
  ViewN<double, 2> x, v, a, traction0, x_hold;
  ViewN<double, 2> a_boundary;  // out: the boundary's part of a (energy account)
  View1<double> rho;
  View1<int> material, flags;
  Kokkos::View<const MaterialParams*, MemSpace> materials;
  MirrorPlanes planes;  // reused geometry: axis, position, side, spring_distance
  double dp;

  // Built by name; a_boundary (the part written apart) is set by the caller.
  NonReflectingBoundary(const Particles& P, const Kokkos::View<const MaterialParams*, MemSpace>& materials_in,
                        const MirrorPlanes& planes_in, double dp_in)
      : materials(materials_in), planes(planes_in), dp(dp_in) {
    x = P.x; v = P.v; a = P.a; traction0 = P.traction0; x_hold = P.x_hold; rho = P.rho;
    material = P.material; flags = P.flags;
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int i) const {
    a_boundary(i, 0) = 0.0;
    a_boundary(i, 1) = 0.0;
    for (int k = 0; k < planes.count; ++k) {
      if (!(flags(i) & (FLAG_HELD_BOUNDARY << k))) continue;
      const MirrorPlane& pl = planes.plane[k];
      const ViscousSpring b = viscous_spring(materials(material(i)), rho(i), pl.spring_distance);
      const int n = pl.axis, t = 1 - pl.axis;
      const double ratio = pl.axis == 0 ? pl.position / math::max(x(i, 0), 1e-12) : 1.0;
      const double k_a = ratio / (rho(i) * dp);
      const double an = k_a * (traction0(i, n) - b.dashpot_n * v(i, n) - b.spring_n * (x(i, n) - x_hold(i, n)));
      const double at = k_a * (traction0(i, t) - b.dashpot_t * v(i, t) - b.spring_t * (x(i, t) - x_hold(i, t)));
      a(i, n) += an;
      a(i, t) += at;
      a_boundary(i, n) += an;
      a_boundary(i, t) += at;
    }
  }
};

// Table of f_ab^n = (W(q h) / W(dp))^n at q = 2 k / (n_entries - 1), k = 0 .. n_entries-1
// (relative interpolation error below 1e-5 with 2049 entries).
inline Kokkos::View<double*, MemSpace> artificial_stress_table(const SphParams& p, int n_entries = 2049) {
  Kokkos::View<double*, MemSpace> table("tamp::artificial_stress_factors", n_entries);
  auto h = Kokkos::create_mirror_view(table);
  const Wendland2D W(p.h);
  for (int k = 0; k < n_entries; ++k) {
    const double q = 2.0 * k / (n_entries - 1);
    h(k) = std::pow(W.value(q * p.h) * p.inv_w_dp, p.art_n);
  }
  Kokkos::deep_copy(table, h);
  return table;
}

// Periodic stress regularisation (after Bui et al. 2008, who use a Shepard or MLS filter)
// with a first-order moving-least-squares interpolant: weights
//   w_b = V_b W_ab (beta_a . p_ab),  p_ab = (1, r_b - r_a, z_b - z_a),
//   A_a beta_a = (1, 0, 0),  A_a = sum_b V_b W_ab p_ab p_ab^T   (b includes a)
// reproduce constant and linear stress fields exactly, also at free surfaces and walls
// (the zeroth-order Shepard filter biased the near-surface stress, and repeated
// filtering drifted K0 in the geostatic column), while averaging out particle-scale
// noise. Falls back to Shepard where A is singular. Reads sigma, writes sigma_out.
struct StressRegularisation {
  ViewN<double, 2> x;
  View1<double> planar_mass, rho;
  ViewN<double, 4> sigma, sigma_out;
  View1<int> offsets, neighbours;
  double h;

  // Reads P.sigma, writes P.sigma_tmp.
  StressRegularisation(const Particles& P, const NeighbourList& list, double h_in) : h(h_in) {
    x = P.x; planar_mass = P.planar_mass; rho = P.rho; sigma = P.sigma; sigma_out = P.sigma_tmp;
    offsets = list.offsets; neighbours = list.neighbours;
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int a) const {
    const Wendland2D W(h);
    const double xa = x(a, 0), za = x(a, 1);
    // moment matrix (symmetric 3x3), self term included
    const double w0 = W.value(0.0) * planar_mass(a) / rho(a);
    LinearMlsFit fit;  // kernels/Wendland.hpp
    fit.add(w0, 0.0, 0.0);
    for (int k = offsets(a); k < offsets(a + 1); ++k) {
      const int b = neighbours(k);
      const double dr = x(b, 0) - xa, dz = x(b, 1) - za;
      fit.add(W.value(math::sqrt(dr * dr + dz * dz)) * planar_mass(b) / rho(b), dr, dz);
    }
    fit.solve();
    const double b0 = fit.b0;
    double s[4] = {sigma(a, 0) * w0 * b0, sigma(a, 1) * w0 * b0, sigma(a, 2) * w0 * b0, sigma(a, 3) * w0 * b0};
    for (int k = offsets(a); k < offsets(a + 1); ++k) {
      const int b = neighbours(k);
      const double dr = x(b, 0) - xa, dz = x(b, 1) - za;
      const double w = W.value(math::sqrt(dr * dr + dz * dz)) * planar_mass(b) / rho(b) * fit.factor(dr, dz);
      for (int c = 0; c < 4; ++c) s[c] += sigma(b, c) * w;
    }
    for (int c = 0; c < 4; ++c) sigma_out(a, c) = s[c];
  }
};

}  // namespace tamp
