// Plain-data material parameters, usable inside kernels on every back end.
// Material dispatch in kernels is a switch on `model` (no virtual functions).
#pragma once
#include "core/Config.hpp"  // bulk_from_shear
#include "core/Types.hpp"

namespace tamp {

// The device update each model runs (its `id`, models/ModelList.hpp). A new model takes
// the next free number in its own header; models/ModelList.cpp checks they are distinct.
enum ModelId : int {
  MODEL_ELASTIC = 0,       // linear (hypo-)elastic, Jaumann rate
  MODEL_MOHR_COULOMB = 1,  // elastic-perfectly plastic Mohr-Coulomb; Tresca when phi = 0
};

struct MaterialParams {
  int model = MODEL_ELASTIC;
  double density = 0;         // kg/m3, initial (reference) density
  double bulk_modulus = 0;    // K, Pa
  double shear_modulus = 0;   // G, Pa
  double cohesion = 0;        // c, Pa (Su for Tresca)
  double phi = 0;             // friction angle, rad, [0, pi/2)
  double psi = 0;             // dilation angle, rad, [0, phi]
  double tension_cutoff = 0;  // Pa, largest allowed mean stress (tension positive), >= 0;
                              // for phi > 0 the apex c cot(phi) applies if smaller
  double separation_density = 0;  // kg/m3: a granular material below its loosest packing has
                                  // no grain contacts and carries no stress (0 = never)
  double inertia = 1;  // mass scaling: the inertia of the material is this times its mass
                       // (its weight, stiffness and strength are not scaled), >= 1
  double viscosity = 1;  // its artificial viscosity relative to [sph] alpha and beta; a pair
                         // takes the mean of its two materials' (kernels/SphSolid.hpp)
  double viscosity_head_on = 0;  // s in [0, 1]: a pair's viscosity times 1 - s (1 - cos), cos the
                                 // cosine between its relative velocity and its line of centres
                                 // (s the mean of its two materials'; docs/sph.md "Head-on viscosity")

  // Effects added to Mohr-Coulomb / Tresca (models/Effects.hpp, docs/effects.md); each is
  // off at its default.
  double crush_pressure = 0;        // (a) compaction: mean pressure p_c0 where the porous
                                    //     soil starts to crush, Pa (0 = off)
  double crush_hardening = 0;       //     H: p_c = p_c0 + H eps_v^p, Pa
  double air_voids = 0;             //     largest compaction strain eps_v^p (the air-void
                                    //     volume fraction), -
  double rate_coefficient = 0;      // (b) rate: beta in c = c0 (1 + beta log10(gdot/gdot_ref))
                                    //     for gdot > gdot_ref (0 = off)
  double reference_strain_rate = 1; //     gdot_ref, 1/s
  double remoulded_ratio = 1;       // (c) remoulding: delta = c_remoulded / c0 (1 = off)
  double remoulding_strain = 1;     //     eps_95: plastic shear strain at 95 % of the loss

  // Parameters of the other models, each model naming its slots in its own header (e.g.
  // models/ModifiedCamClay.hpp), so that a new model needs no new member here.
  static constexpr int kModelSlots = 8;
  double model_param[kModelSlots] = {0, 0, 0, 0, 0, 0, 0, 0};

  KOKKOS_INLINE_FUNCTION double p_wave_modulus() const {
    return bulk_modulus + 4.0 / 3.0 * shear_modulus;
  }
  // Compression (P) wave speed of the model at the reference density, m/s: with mass
  // scaling, sqrt(M / (inertia rho)).
  KOKKOS_INLINE_FUNCTION double wave_speed() const {
    return math::sqrt(p_wave_modulus() / (inertia * density));
  }
  // Elastic strain energy per unit volume of the stress s (rr, zz, tt, rz), J/m3:
  // p^2 / (2K) + J2 / (2G), the energy an isotropic elastic unloading would give back.
  KOKKOS_INLINE_FUNCTION double elastic_energy_density(double s0, double s1, double s2, double s3) const {
    const double p = (s0 + s1 + s2) / 3.0;
    const double d0 = s0 - p, d1 = s1 - p, d2 = s2 - p;
    const double j2 = 0.5 * (d0 * d0 + d1 * d1 + d2 * d2) + s3 * s3;
    return (bulk_modulus > 0 ? p * p / (2.0 * bulk_modulus) : 0.0) + (shear_modulus > 0 ? j2 / (2.0 * shear_modulus) : 0.0);
  }
};

// History slots a particle or element keeps for its model beyond the two standard variables
// (MaterialState::history); each model declares how many it uses (its `history_count`, at
// most this: checked where models are listed, models/ModelList.hpp) and names them
// (ModelDescription::history). Raise it when a model needs more: every particle and element
// then carries the larger row.
constexpr int kHistorySlots = 2;

// What a particle or element carries from step to step for its constitutive model. Every
// model may update the two standard variables (the quantities the measurements, plots and
// effects read, as an explicit code reports an effective plastic strain for every material);
// a model that needs more keeps it in `history`, in the slots it declares. Each starts at 0
// in a new particle or element.
struct MaterialState {
  double plastic_strain = 0;  // accumulated equivalent plastic shear strain, -
  double compaction = 0;      // plastic volumetric strain, compression positive, -
  double history[kHistorySlots] = {};
};

}  // namespace tamp
