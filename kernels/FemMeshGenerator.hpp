// The element mesh of a deck's [fem] table (docs/coupling.md, "The mesh"): node lines at
// every block and SPH-zone edge, each interval split into elements no longer than
// element_size, uniform or graded away from the zone; a cell takes the material of the block
// around its centre, or none inside the SPH zone or outside every block. Host code, run once
// per model.
#pragma once
#include <functional>
#include <string>
#include <vector>

#include "core/Config.hpp"
#include "kernels/FemModel.hpp"

namespace tamp {

struct DeckMesh {
  fem::FemGrid grid;                       // cells' material: index into deck_material
  std::vector<int> deck_material;          // FEM material -> deck material index
  std::vector<std::string> material_name;  // FEM material -> deck material name
};

// material_index: the deck material of a name (-1 when unknown; material 0 is then used).
DeckMesh deck_mesh(const FemSpec& f, const std::vector<BlockSpec>& blocks,
                   const std::function<int(const std::string&)>& material_index);

}  // namespace tamp
