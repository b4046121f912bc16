#include "kernels/FemMeshGenerator.hpp"

#include <algorithm>
#include <cmath>

namespace tamp {

DeckMesh deck_mesh(const FemSpec& f, const std::vector<BlockSpec>& blocks,
                   const std::function<int(const std::string&)>& material_index) {
  // Node lines through the cuts. Uniform (grading 1): each interval in equal elements no
  // longer than element_size. Graded: marching from the end nearer the zone with the edge
  // h = element_size + (grading - 1) d at distance d from the zone (a geometric series in
  // the element count); a remainder below half an element joins the last one.
  auto lines = [&](std::vector<double> cuts, auto distance) {
    std::sort(cuts.begin(), cuts.end());
    std::vector<double> out{cuts.front()};
    for (size_t k = 1; k < cuts.size(); ++k) {
      const double lo = out.back(), hi = cuts[k], len = hi - lo;
      if (len < 1e-9) continue;
      if (f.grading <= 1.0) {
        const int n = std::max(1, static_cast<int>(std::ceil(len / f.element_size - 1e-6)));
        for (int q = 1; q <= n; ++q) out.push_back(q == n ? hi : lo + len * q / n);
        continue;
      }
      const bool from_lo = distance(lo) <= distance(hi);
      std::vector<double> piece{from_lo ? lo : hi};
      const double end = from_lo ? hi : lo, sign = from_lo ? 1.0 : -1.0;
      while (true) {
        const double h = f.element_size + (f.grading - 1.0) * distance(piece.back());
        const double next = piece.back() + sign * h;
        if (sign * (end - next) < 0.5 * h) { piece.push_back(end); break; }
        piece.push_back(next);
      }
      if (!from_lo) std::reverse(piece.begin(), piece.end());
      out.insert(out.end(), piece.begin() + 1, piece.end());
    }
    return out;
  };
  std::vector<double> rc{f.zone_r_min, f.zone_r_max}, zc{f.zone_z_min, f.zone_z_max};
  for (const BlockSpec& b : blocks) {
    rc.push_back(b.r_min); rc.push_back(b.r_max);
    zc.push_back(b.z_min); zc.push_back(b.z_max);
  }
  DeckMesh mesh;
  fem::FemGrid& grid = mesh.grid;
  grid.r = lines(rc, [&](double r) { return std::max({0.0, f.zone_r_min - r, r - f.zone_r_max}); });
  grid.z = lines(zc, [&](double z) { return std::max({0.0, f.zone_z_min - z, z - f.zone_z_max}); });
  const int nr = grid.nr(), nz = grid.nz();
  grid.material.assign(static_cast<size_t>(nr) * nz, -1);
  std::vector<int>& deck_of = mesh.deck_material;  // FEM material -> deck material
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < nr; ++i) {
      const double r = 0.5 * (grid.r[i] + grid.r[i + 1]), z = 0.5 * (grid.z[j] + grid.z[j + 1]);
      if (r > f.zone_r_min && r < f.zone_r_max && z > f.zone_z_min && z < f.zone_z_max) continue;
      for (const BlockSpec& b : blocks) {
        if (!(r > b.r_min && r < b.r_max && z > b.z_min && z < b.z_max)) continue;
        const int dm = std::max(0, material_index(b.material));
        auto it = std::find(deck_of.begin(), deck_of.end(), dm);
        if (it == deck_of.end()) {
          deck_of.push_back(dm);
          mesh.material_name.push_back(b.material);
          it = deck_of.end() - 1;
        }
        grid.material[j * nr + i] = static_cast<int>(it - deck_of.begin());
      }
    }
  return mesh;
}

}  // namespace tamp
