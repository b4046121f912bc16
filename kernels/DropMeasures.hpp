// The drop sequence's measurements, each a function of one survey of the particles
// (kernels/Measurements.hpp, ParticleSurvey) and the geometry it needs, so that each can be
// tested alone on particles laid out by hand (tests/test_drop_sequence.cpp): the column of
// aggregate, the uplift beside it, the heave volume, the crater floor, the soil's top under
// the pounder. What each means and why: docs/drop-sequence.md "Measurements".
#pragma once
#include <cmath>
#include <vector>

#include "kernels/Measurements.hpp"

namespace tamp {

struct DropGeometry {
  double ground = 0;                 // m, the original ground level
  double spacing = 0;                // m, sph.spacing
  double pounder_max_diameter = 0;   // m
  double pounder_base_diameter = 0;  // m
  double domain_r_max = 0;           // m, the blocks' outer radius
  int aggregate = -1;                // the backfill's material (-1: none)
};

struct ColumnRow {
  double depth_m;           // below the original ground level, centre of the band
  double diameter_m;        // of the column in the band: the hole in the soil it fills
  double solid_diameter_m;  // of the solid cylinder holding the band's aggregate volume
};

struct ColumnSummary {
  double length_m = 0, head_diameter_m = 0, max_diameter_m = 0, base_diameter_m = 0;
  double head_solid_diameter_m = 0, max_solid_diameter_m = 0;  // the same from the solid diameters
  double aggregate_kg = 0;
  std::vector<ColumnRow> rows;
};

// The column of aggregate (material `aggregate`) the particles hold, measured in bands of
// one spacing dp below the original ground level `ground` (m): docs/drop-sequence.md.
ColumnSummary measure_column(const ParticleSurvey& survey, int aggregate, double ground, double dp);

// Mean top of the soil (any material; particles with at least `neighbours` within 1.5 dp)
// over the radial columns of width dp whose centres lie in [r_in, r_out), m; NaN where no
// column there has soil.
double mean_soil_top(const ParticleSurvey& survey, const DropGeometry& g, double r_in, double r_out, int neighbours);

// Crater floor after extraction, m below the original ground: the mean top of the material
// (any, aggregate included) in the radial columns under the pounder's base (r < base
// diameter / 2), particles with one neighbour within 1.5 dp counted (the loose grains on the
// floor are what the pounder rested on; lab run, blow 7: the uplift's 3-neighbour rule put
// the floor 34 mm below the pounder's base). 0 where there is no material.
double crater_floor(const ParticleSurvey& survey, const DropGeometry& g);

// Top of the particles under the pounder: the centre of the highest particle whose column
// overlaps the pounder's widest radius, m.
double surface_under_pounder(const ParticleSurvey& survey, const DropGeometry& g);

// Uplift: the highest soil surface (not aggregate; particles with 3 neighbours) in the radial
// columns from the column head's edge (or the pounder's widest radius, before any backfill)
// out 0.1 m, above the original ground, m.
double uplift(const ParticleSurvey& survey, const DropGeometry& g);

// Heave volume: the soil surface above the ground level, integrated over the rings outside
// the pounder's widest radius, m3.
double heave_volume(const ParticleSurvey& survey, const DropGeometry& g);

// The pounder at rest in contact (docs/drop-sequence.md): touching the soil, its speed below
// rest_speed (m/s) and the upward contact force `lift` within rest_force_tolerance x weight
// of its weight (N). The sequencer asks it every step and ends the blow once it has held for
// the schedule's rest_hold.
inline bool pounder_at_rest(bool touching, double v_z, double lift, double weight, double rest_speed,
                            double rest_force_tolerance) {
  return touching && std::fabs(v_z) < rest_speed && std::fabs(lift - weight) < rest_force_tolerance * weight;
}

// Ballistic flight: the time for a body at height z (m) moving up at v (m/s) to fall to z_land
// under gravity g (m/s2), the later root of z + v t - g t^2 / 2 = z_land (z > z_land).
inline double landing_time(double z, double v, double g, double z_land) {
  return (v + std::sqrt(v * v + 2.0 * g * (z - z_land))) / g;
}

}  // namespace tamp
