// Construction of the SPH-FEM tie (docs/coupling.md, "The tie particles"): the interface
// edges of an element mesh (boundary edges with particles just beyond them) and the tie
// particles that sample the elements within the kernel reach of the interface. Host code run
// once per model; the search for particles beyond an edge goes through the particles' cell
// list (kernels/Measurements.hpp). The kernels that use the tie are in kernels/Tie.hpp.
#pragma once
#include <vector>

#include "kernels/FemModel.hpp"
#include "kernels/Measurements.hpp"
#include "kernels/Tie.hpp"

namespace tamp {

// The tie particles of `fem` next to the real particles of `particles`: sph_material[m] is
// the particle material of FEM material m, dp the particle spacing, band the reach from the
// interface within which elements are sampled (the kernel support with a margin for motion),
// m. The element volumes must be current (FemModel::compute_forces). Writes the number of
// interface edges to *interface_edges. Throws std::invalid_argument for a mesh it cannot tie
// (no interface, or an element with particles beyond two of its edges).
TieParticles build_tie_particles(const fem::FemModel& fem, const std::vector<int>& sph_material,
                                 const ParticleSurvey& particles, double dp, double band, int* interface_edges = nullptr);

}  // namespace tamp
