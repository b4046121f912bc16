#include "drivers/sequence/BlowAccount.hpp"

#include <cmath>
#include <limits>

namespace tamp {

const std::vector<BlowColumn>& blow_columns() {
  using B = BlowRecord;
  static const std::vector<BlowColumn> columns{
      {"drop_height_m", &B::drop_height_m},       {"crater_depth_m", &B::crater_depth_m},
      {"deepest_m", &B::deepest_m},               {"penetration_m", &B::penetration_m},
      {"contacts", &B::contacts},                 {"restitution", &B::restitution},
      {"peak_deceleration_m_s2", &B::peak_deceleration_m_s2},
      {"rest_in_contact", &B::rest_in_contact},   {"crater_floor_m", &B::crater_floor_m},
      {"uplift_m", &B::uplift_m},                 {"aggregate_added_kg", &B::aggregate_added_kg},
      {"energy_in_J", &B::energy_in_J},           {"elastic_J", &B::elastic_J},
      {"soil_motion_J", &B::soil_motion_J},       {"viscous_heat_J", &B::viscous_heat_J},
      {"radiated_J", &B::radiated_J},             {"damping_J", &B::damping_J},
      {"wall_friction_J", &B::wall_friction_J},   {"contact_J", &B::contact_J},
      {"artificial_stress_J", &B::artificial_stress_J},
      {"returned_J", &B::returned_J},             {"residual_J", &B::residual_J},
      {"contact_time_s", &B::contact_time_s},     {"flight_time_s", &B::flight_time_s},
      {"rest_time_s", &B::rest_time_s},           {"ballistic_time_s", &B::ballistic_time_s},
      {"axis_images_J", &B::axis_images_J},       {"wall_images_J", &B::wall_images_J}};
  return columns;
}

std::vector<double> BlowEnergies::flat() const {
  if (!known) return {};
  std::vector<double> e{pounder, contact, damping, boundary, wall_friction, artificial_stress};
  for (const Material& m : materials)
    for (double v : {m.kinetic, m.internal, m.potential, m.elastic, m.numerical_heat}) e.push_back(v);
  for (double v : {node_motion, node_boundary, node_damping, axis_images, wall_images}) e.push_back(v);
  return e;
}

BlowEnergies BlowEnergies::from_flat(const std::vector<double>& v, size_t n_materials) {
  size_t k = 0;
  auto next = [&] { return k < v.size() ? v[k++] : std::numeric_limits<double>::quiet_NaN(); };
  BlowEnergies e;
  e.known = !v.empty();
  for (double* x : {&e.pounder, &e.contact, &e.damping, &e.boundary, &e.wall_friction, &e.artificial_stress}) *x = next();
  e.materials.resize(n_materials);
  for (Material& m : e.materials)
    for (double* x : {&m.kinetic, &m.internal, &m.potential, &m.elastic, &m.numerical_heat}) *x = next();
  for (double* x : {&e.node_motion, &e.node_boundary, &e.node_damping, &e.axis_images, &e.wall_images}) *x = next();
  return e;
}

void account_blow_energy(const BlowEnergies& before, const BlowEnergies& after, BlowRecord& rec) {
  const BlowEnergies& e0 = before;
  const BlowEnergies& e1 = after;
  // (a term a checkpoint from before it lacks is NaN in e0: it counts from the restart)
  auto d = [](double now, double then) { return std::isnan(then) ? 0.0 : now - then; };
  rec.energy_in_J = -d(e1.pounder, e0.pounder);
  rec.contact_J = d(e1.contact, e0.contact);
  rec.damping_J = -d(e1.damping, e0.damping);
  rec.radiated_J = -d(e1.boundary, e0.boundary);
  rec.wall_friction_J = -d(e1.wall_friction, e0.wall_friction);
  rec.artificial_stress_J = d(e1.artificial_stress, e0.artificial_stress);
  rec.elastic_J = rec.soil_motion_J = rec.viscous_heat_J = 0;
  const size_t nm = after.materials.size();
  rec.plastic_J.assign(nm, 0.0);
  double internal = 0;
  for (size_t m = 0; m < nm; ++m) {
    const BlowEnergies::Material& now = e1.materials[m];
    const BlowEnergies::Material then = m < e0.materials.size() ? e0.materials[m] : BlowEnergies::Material{NAN, NAN, NAN, NAN, NAN};
    rec.soil_motion_J += d(now.kinetic, then.kinetic) + d(now.potential, then.potential);
    rec.elastic_J += d(now.elastic, then.elastic);
    rec.viscous_heat_J += d(now.numerical_heat, then.numerical_heat);
    rec.plastic_J[m] = d(now.internal, then.internal) - d(now.elastic, then.elastic) - d(now.numerical_heat, then.numerical_heat);
    internal += d(now.internal, then.internal);
  }
  rec.soil_motion_J += d(e1.node_motion, e0.node_motion);  // the tied elements' nodes
  rec.radiated_J -= d(e1.node_boundary, e0.node_boundary);
  rec.damping_J -= d(e1.node_damping, e0.node_damping);
  rec.axis_images_J = d(e1.axis_images, e0.axis_images);
  rec.wall_images_J = d(e1.wall_images, e0.wall_images);
  rec.residual_J = rec.energy_in_J + rec.artificial_stress_J + rec.axis_images_J + rec.wall_images_J -
                   (rec.soil_motion_J + internal + rec.contact_J + rec.radiated_J + rec.damping_J + rec.wall_friction_J);
}

}  // namespace tamp
