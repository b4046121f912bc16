// Particle storage: structure-of-arrays Kokkos views (Cabana-style), in the default
// memory space. Real particles occupy [0, n_real); mirror (ghost) particles that stand in
// for the axis and rigid walls occupy [n_real, n_total). Capacity grows on the host,
// never inside a kernel.
#pragma once
#include <string>
#include <type_traits>
#include <utility>
#include "core/Config.hpp"
#include "core/Material.hpp"  // kHistorySlots
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

// The particle fields, declared once. Storage, growth (reserve), the values of a new
// particle (fill_new: the generator and the backfill), checkpoint save and restore
// (kernels/solver/Simulation.cpp) all iterate this list; adding a field is one line here (then
// the kernel or model that uses it). Mirror particles (kernels/Mirror.hpp) transform the
// fields they need by the wall's symmetry, which is physics, not a copy, and stay written
// out there; snapshots (core/Output.hpp) hold the fields a user reads.
//   X(name, element type, components, value of a new particle, checkpoint, meaning)
// checkpoint: Saved (a checkpoint must hold it), SavedOptional (a checkpoint from before
// the field existed restores the new-particle value), NotSaved (derived or scratch).
// art_stress and hoop_factor are derived in the strain-rate pass, but saved: a stage that
// starts by placing the pounder or adding a charge computes the accelerations before any
// strain-rate pass, and without them a restart there was not the uninterrupted run.
#define TAMP_PARTICLE_FIELDS(X)                                                                                \
  X(x, double, 2, 0.0, Saved, "position (r, z), m")                                                          \
  X(v, double, 2, 0.0, Saved, "velocity (v_r, v_z), m/s")                                                    \
  X(a, double, 2, 0.0, Saved, "acceleration, m/s2")                                                          \
  X(a_ext, double, 2, 0.0, Saved, "external acceleration (surface tractions), m/s2")                         \
  X(v_prescribed, double, 2, 0.0, Saved, "velocity of FLAG_DRIVEN particles, m/s")                           \
  X(x_ref, double, 2, 0.0, SavedOptional, "position at the last neighbour-list build, m (a restart rebuilds the list there)") \
  X(traction0, double, 2, 0.0, Saved, "static traction on non-reflecting boundary particles, Pa")            \
  X(x_hold, double, 2, 0.0, SavedOptional, "their position when that traction was recorded, m")              \
  X(mass, double, 1, 0.0, Saved, "ring mass (the whole ring of revolution), kg")                             \
  X(planar_mass, double, 1, 0.0, NotSaved, "mass / (2 pi r): mass per radian of revolution / r, kg/m")      \
  X(rho, double, 1, 0.0, Saved, "density, kg/m3")                                                            \
  X(sigma, double, 4, 0.0, Saved, "Cauchy stress rr, zz, tt, rz (tension positive), Pa")                     \
  X(sigma_tmp, double, 4, 0.0, NotSaved, "scratch for stress regularisation, Pa")                            \
  X(art_stress, double, 3, 0.0, SavedOptional, "Gray-Monaghan-Swift R (rr, zz, rz), Pa / (kg/m3)^2")         \
  X(pair_stress, double, 3, 0.0, NotSaved, "mp sigma / rho^2 (rr, zz, rz): a particle's share of the pair term") \
  X(plastic_strain, double, 1, 0.0, Saved, "accumulated equivalent plastic shear strain, -")                 \
  X(compaction, double, 1, 0.0, SavedOptional, "plastic volumetric strain, compression positive, -")         \
  X(history, double, kHistorySlots, 0.0, SavedOptional, "the model's own history slots (MaterialState::history)") \
  X(internal_energy, double, 1, 0.0, Saved, "specific internal energy (strain + dissipated), J/kg")          \
  X(du_visc, double, 1, 0.0, Saved, "rate of viscous heating, W/kg")                                         \
  X(image_force, double, 4, 0.0, SavedOptional, "stress pair force of the mirror images (axis r, z; walls r, z), N/kg") \
  X(image_work, double, 2, 0.0, SavedOptional, "energy the image pairs gave the particle (axis, walls): numerical, J/kg") \
  X(hoop_factor, double, 1, 1.0, SavedOptional, "chi: the hoop terms use chi / r (kernels/SphSolid.hpp)")    \
  X(material, int, 1, 0, Saved, "index into the material table")                                             \
  X(flags, int, 1, 0, Saved, "ParticleFlag bits")                                                            \
  X(ghost_source, int, 1, 0, NotSaved, "ghosts: the particle this one mirrors")

// The planar mass m / (2 pi r~) of a particle ring, kg/m, with the regularised radius
// r~ = max(r, r_floor). Every particle uses the floor of the SPH sums' 1/r, r_floor =
// planar_mass_floor(sph) = axis_radius_factor h (kernels/SphSolid.hpp): the pair term
// m_b sigma_b / (2 pi r~_b rho_b^2) built from it is then the conjugate of b's strain rate,
// whose weights use the same r~_b, and the pair forces do exactly the work the stress
// power books. (Until 2026-12-01 the floor was 1e-3 dp: a particle pushed within c h of
// the axis exerted up to c h / r times the force its strain rate paid for, and the energy
// account of the lab blows missed 2-6 %.)
KOKKOS_INLINE_FUNCTION double planar_mass_of(double mass, double r, double r_floor) {
  return mass / (2.0 * pi * math::max(r, r_floor));
}
inline double planar_mass_floor(const SphSpec& sph) { return sph.axis_radius_factor * sph.h_factor * sph.spacing; }

// A particle's share of the SPH pair term, mp sigma / rho^2 (rr, zz, rz) (docs/sph.md): the
// one definition for real particles, mirror ghosts and tie particles.
template <class Mass, class Rho, class Sigma, class Out>
KOKKOS_INLINE_FUNCTION void set_pair_stress(int i, const Mass& planar_mass, const Rho& rho, const Sigma& sigma,
                                            const Out& pair_stress) {
  const double k = planar_mass(i) / (rho(i) * rho(i));
  pair_stress(i, 0) = k * sigma(i, 0);
  pair_stress(i, 1) = k * sigma(i, 1);
  pair_stress(i, 2) = k * sigma(i, 3);
}

enum class FieldCheckpoint { Saved, SavedOptional, NotSaved };

struct FieldInfo {
  const char* name;
  FieldCheckpoint checkpoint;
  const char* meaning;
};

// View of a field with n components: View1 for one, ViewN otherwise.
template <class T, int N>
struct FieldViewOf { using type = ViewN<T, N>; };
template <class T>
struct FieldViewOf<T, 1> { using type = View1<T>; };
template <class T, int N>
using FieldView = typename FieldViewOf<T, N>::type;

struct Particles {
  int n_real = 0;
  int n_tie = 0;  // tie particles [n_real, n_real + n_tie): FEM material seen by the SPH
  int n_total = 0;
  int capacity = 0;

#define TAMP_FIELD_MEMBER(name, T, N, init, ckpt, meaning) FieldView<T, N> name;
  TAMP_PARTICLE_FIELDS(TAMP_FIELD_MEMBER)
#undef TAMP_FIELD_MEMBER

  // f(info, view, value of a new particle) for every field, in declaration order.
  template <class F>
  void for_each_field(F&& f) {
#define TAMP_FIELD_VISIT(name, T, N, init, ckpt, meaning) \
  f(FieldInfo{#name, FieldCheckpoint::ckpt, meaning}, name, static_cast<T>(init));
    TAMP_PARTICLE_FIELDS(TAMP_FIELD_VISIT)
#undef TAMP_FIELD_VISIT
  }

  void reserve(int new_capacity);        // grows every view, keeping contents
  void fill_new(int begin, int end);     // rows [begin, end) of every field: a new particle's values
  // Renumbers the real particles: row i of every field takes the old row old_of_new(i),
  // i < n_real (a permutation of [0, n_real); the rows beyond are left as they are).
  void permute_real(const View1<int>& old_of_new);
};

inline void Particles::reserve(int new_capacity) {
  if (new_capacity <= capacity) return;
  for_each_field([&](const FieldInfo& info, auto& view, auto) {
    if (view.extent(0) == 0 && view.data() == nullptr)
      view = std::decay_t<decltype(view)>(std::string(info.name), static_cast<size_t>(new_capacity));
    else
      Kokkos::resize(view, new_capacity);
  });
  capacity = new_capacity;
}

inline void Particles::fill_new(int begin, int end) {
  if (end <= begin) return;
  for_each_field([&](const FieldInfo&, auto& view, auto value) {
    using V = std::decay_t<decltype(view)>;
    if constexpr (V::rank == 1)
      Kokkos::deep_copy(Kokkos::subview(view, std::make_pair(begin, end)), value);
    else
      Kokkos::deep_copy(Kokkos::subview(view, std::make_pair(begin, end), Kokkos::ALL), value);
  });
}

// Row i of `out` takes row old_of_new(i) of `in` (one field of Particles::permute_real; a
// functor, not a lambda, since CUDA does not take device lambdas inside generic lambdas).
template <class V>
struct GatherRows {
  V out, in;
  View1<int> old_of_new;
  KOKKOS_INLINE_FUNCTION void operator()(const int i) const {
    if constexpr (V::rank == 1) {
      out(i) = in(old_of_new(i));
    } else {
      for (int c = 0; c < static_cast<int>(out.extent(1)); ++c) out(i, c) = in(old_of_new(i), c);
    }
  }
};

// Rows [0, n) of a particle view renumbered: row i takes the old row old_of_new(i).
template <class V>
void permute_rows(V& view, const View1<int>& old_of_new, int n) {
  V old(std::string("tamp::permute_copy"), view.extent(0));  // same shape: a plain copy
  Kokkos::deep_copy(old, view);
  Kokkos::parallel_for("tamp::permute_rows", Kokkos::RangePolicy<ExecSpace>(0, n), GatherRows<V>{view, old, old_of_new});
}

inline void Particles::permute_real(const View1<int>& old_of_new) {
  for_each_field([&](const FieldInfo&, auto& view, auto) { permute_rows(view, old_of_new, n_real); });
  Kokkos::fence();
}

}  // namespace tamp
