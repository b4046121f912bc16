// The geostatic (at-rest) stress of a layered soil: horizontal layers (the deck's blocks),
// sigma_zz at height z = minus the weight per unit area of the layers above it, and
// sigma_rr = sigma_tt = K0 sigma_zz with K0 = nu / (1 - nu) of the point's material (Jaky's
// elastic K0 for a laterally confined layer; a given k0 >= 0 overrides it). Used on the
// particles (GeostaticStress) and on the element centres, one formula for both.
#pragma once
#include "core/Material.hpp"
#include "core/Particles.hpp"

namespace tamp {

// Layers as rows (z_bottom, z_top, unit weight gamma = rho g) of a view (device, or its
// host mirror); any number of them.
using LayerView = Kokkos::View<double* [3], MemSpace>;
template <class V = LayerView>
struct GeostaticLayers {
  V layer;
  int n = 0;
  // sigma_zz at height z, Pa (tension positive, so <= 0)
  KOKKOS_INLINE_FUNCTION double sigma_v(double z) const {
    double sv = 0;
    for (int k = 0; k < n; ++k) {
      const double lo = math::max(z, layer(k, 0));
      if (layer(k, 1) > lo) sv -= layer(k, 2) * (layer(k, 1) - lo);
    }
    return sv;
  }
};

// The at-rest stress (rr, zz, tt, rz) for vertical stress sv in material m.
KOKKOS_INLINE_FUNCTION void at_rest_stress(const MaterialParams& m, double sv, double k0, double s[4]) {
  const double K = m.bulk_modulus, G = m.shear_modulus;
  const double nu = (3 * K - 2 * G) / (2 * (3 * K + G));
  const double k = k0 >= 0 ? k0 : nu / (1 - nu);
  s[0] = k * sv;
  s[1] = sv;
  s[2] = k * sv;
  s[3] = 0;
}

// The at-rest stress on every real particle.
struct GeostaticStress {
  ViewN<double, 2> x;
  ViewN<double, 4> sigma;
  View1<int> material;
  Kokkos::View<const MaterialParams*, MemSpace> materials;
  GeostaticLayers<> layers;
  double k0;
  GeostaticStress(const Particles& P, const Kokkos::View<const MaterialParams*, MemSpace>& materials_in,
                  const GeostaticLayers<>& layers_in, double k0_in)
      : materials(materials_in), layers(layers_in), k0(k0_in) {
    x = P.x; sigma = P.sigma; material = P.material;
  }
  KOKKOS_INLINE_FUNCTION void operator()(const int i) const {
    double s[4];
    at_rest_stress(materials(material(i)), layers.sigma_v(x(i, 1)), k0, s);
    for (int c = 0; c < 4; ++c) sigma(i, c) = s[c];
  }
};

// The at-rest stress of every element, at its centre height: the mean of its lowest and highest
// node in the reference configuration (a structured grid's element: the mid-height of its row).
struct ElementGeostaticStress {
  ViewN<double, 2> x0;
  Kokkos::View<int* [4], MemSpace> conn;
  View1<int> material;
  Kokkos::View<MaterialParams*, MemSpace> materials;
  ViewN<double, 4> stress;
  GeostaticLayers<> layers;
  double k0;
  KOKKOS_INLINE_FUNCTION void operator()(const int e) const {
    double lo = x0(conn(e, 0), 1), hi = lo;
    for (int k = 1; k < 4; ++k) {
      lo = math::min(lo, x0(conn(e, k), 1));
      hi = math::max(hi, x0(conn(e, k), 1));
    }
    double s[4];
    at_rest_stress(materials(material(e)), layers.sigma_v(0.5 * (lo + hi)), k0, s);
    for (int c = 0; c < 4; ++c) stress(e, c) = s[c];
  }
};

}  // namespace tamp
