// The drop sequence's measurements (kernels/DropMeasures.hpp).
#include "kernels/DropMeasures.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace tamp {

ColumnSummary measure_column(const ParticleSurvey& survey, int aggregate, double ground, double dp) {
  ColumnSummary c;
  // Bands of one spacing with edges at whole spacings below the original ground (or below
  // the aggregate's top + dp/2 where that is lower), so that the head's bands do not move
  // with the grains heaped above the ground (MaterialBands).
  const MaterialBands bands = survey.bands(aggregate, ground);
  if (!bands.any) return c;
  c.aggregate_kg = bands.mass_kg;
  const std::vector<double>& volume = bands.volume_m3;
  const int nb = static_cast<int>(volume.size());
  const double z_bot = bands.z_bot;
  // the column in the ground runs from z_ref = min(aggregate's top + dp/2, ground) down
  c.length_m = bands.z_ref - (z_bot - 0.5 * dp);
  // head and base: mean diameter of the bands whose centres lie within the top / bottom
  // 30 mm (at least one band) of the column in the ground: the head starts at z_ref
  // (aggregate heaped above the ground is loose grains, not the column's head); the widest
  // band is sought in the ground too
  const double band = std::max(0.03, dp);
  double hs = 0, hs_solid = 0, bs = 0;
  int hn = 0, bn = 0;
  for (int b = 0; b < nb; ++b) {
    if (!(volume[b] > 0)) continue;
    const double zc = bands.z_edge - (b + 0.5) * dp;
    // Two diameters of a band. Solid: that of the cylinder that holds the band's aggregate
    // volume, 2 sqrt(V_b / (pi dp)), V_b the sum of the ring volumes m / rho: a lower bound,
    // blind to the voids between separated grains (the loose top of a column has its
    // particles 1.5-2 spacings apart at their own density). Outline: the hole in the soil
    // around it, 2 (r_wall - dp/2), r_wall the innermost soil particle of the band with 3
    // soil neighbours: what the lab measured on the excavated column. The band's diameter
    // is the larger (the outline where the wall stands, the solid where soil mixed in).
    const double solid = 2.0 * std::sqrt(volume[b] / (pi * dp));
    const double wall = bands.wall_r_m[b];
    const double d = std::isfinite(wall) ? std::max(solid, 2.0 * (wall - 0.5 * dp)) : solid;
    c.rows.push_back({ground - zc, d, solid});
    if (b < bands.first_below) continue;  // heaped above the ground
    c.max_diameter_m = std::max(c.max_diameter_m, d);
    c.max_solid_diameter_m = std::max(c.max_solid_diameter_m, solid);
    const double below_top = bands.z_ref - zc;  // of the band's centre
    if (below_top <= band + 1e-12 || b == bands.first_below) {
      hs += d;
      hs_solid += solid;
      ++hn;
    }
    if (zc <= z_bot + band - 1e-12 || b == nb - 1) { bs += d; ++bn; }
  }
  c.head_diameter_m = hn ? hs / hn : 0.0;
  c.head_solid_diameter_m = hn ? hs_solid / hn : 0.0;
  c.base_diameter_m = bn ? bs / bn : 0.0;
  return c;
}

double mean_soil_top(const ParticleSurvey& survey, const DropGeometry& g, double r_in, double r_out, int neighbours) {
  const double dp = g.spacing;
  const std::vector<double> top = survey.soil_surface(-1, r_out + dp, neighbours);
  double sum = 0;
  int n = 0;
  for (size_t k = 0; k < top.size(); ++k) {
    const double rc = (k + 0.5) * dp;
    if (rc >= r_in && rc < r_out && top[k] > -1e299) { sum += top[k]; ++n; }  // -1e300: no soil
  }
  return n ? sum / n : std::numeric_limits<double>::quiet_NaN();
}

double crater_floor(const ParticleSurvey& survey, const DropGeometry& g) {
  const double top = mean_soil_top(survey, g, 0.0, 0.5 * g.pounder_base_diameter, 1);
  return std::isnan(top) ? 0.0 : g.ground - top;
}

double surface_under_pounder(const ParticleSurvey& survey, const DropGeometry& g) {
  return survey.highest_within(0.5 * g.pounder_max_diameter + 0.5 * g.spacing);
}

double uplift(const ParticleSurvey& survey, const DropGeometry& g) {
  const double dp = g.spacing;
  double r_in = 0.5 * g.pounder_max_diameter;
  const ColumnSummary c = g.aggregate < 0 ? ColumnSummary{} : measure_column(survey, g.aggregate, g.ground, dp);
  r_in = std::max(r_in, 0.5 * c.head_solid_diameter_m);  // (the rim leans over the outline)
  const std::vector<double> top = survey.soil_surface(g.aggregate, g.domain_r_max, 3);
  double best = -1e300;
  for (size_t k = 0; k < top.size(); ++k) {
    const double rc = (k + 0.5) * dp;
    if (rc >= r_in && rc <= r_in + 0.1) best = std::max(best, top[k]);
  }
  return best - g.ground;
}

double heave_volume(const ParticleSurvey& survey, const DropGeometry& g) {
  const double dp = g.spacing;
  const std::vector<double> top = survey.soil_surface(g.aggregate, g.domain_r_max, 3);
  const double r_in = 0.5 * g.pounder_max_diameter;
  double v = 0;
  for (size_t k = 0; k < top.size(); ++k) {
    const double rc = (k + 0.5) * dp;
    if (rc < r_in || top[k] < -1e299) continue;
    v += 2.0 * pi * rc * dp * std::max(0.0, top[k] - g.ground);
  }
  return v;
}

}  // namespace tamp
