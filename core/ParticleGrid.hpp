// How many particles a deck asks for, counted before anything is allocated: the regular
// grid of spacing dp in each block (clipped to the SPH zone when elements take the rest),
// in 64 bits so that a huge model is refused by validation instead of overflowing an int.
// Host only, no Kokkos (the deck reader uses it; kernels/solver/Simulation.cpp builds from it).
#pragma once
#include <cmath>
#include <vector>

#include "core/Config.hpp"

namespace tamp {

struct BlockParticles {
  int block = 0;            // index in Config::blocks
  BlockSpec spec;           // the block, clipped to the SPH zone when [fem] is enabled
  double nr = 0, nz = 0;    // particles along r and z (rounded; doubles, so never overflow)
  double count() const { return nr * nz; }
};

// One entry per block that holds particles. A block with fewer than one particle along r
// or z (extent < spacing / 2) is left out when the FEM zone clips it away, and reported by
// thin_block otherwise (-1: none).
inline std::vector<BlockParticles> particle_grid(const Config& cfg, int* thin_block = nullptr) {
  const double dp = cfg.sph.spacing;
  std::vector<BlockParticles> out;
  if (thin_block) *thin_block = -1;
  for (int i = 0; i < static_cast<int>(cfg.blocks.size()); ++i) {
    BlockSpec b = cfg.blocks[i];
    if (cfg.fem.enabled) {  // particles only inside the SPH zone; elements elsewhere
      const FemSpec& f = cfg.fem;
      b.r_min = std::fmax(b.r_min, f.zone_r_min); b.r_max = std::fmin(b.r_max, f.zone_r_max);
      b.z_min = std::fmax(b.z_min, f.zone_z_min); b.z_max = std::fmin(b.z_max, f.zone_z_max);
      if (!(b.r_max - b.r_min > 0.5 * dp && b.z_max - b.z_min > 0.5 * dp)) continue;
    }
    const double nr = std::round((b.r_max - b.r_min) / dp), nz = std::round((b.z_max - b.z_min) / dp);
    if (!(nr >= 1 && nz >= 1)) {
      if (thin_block && *thin_block < 0) *thin_block = i;
      continue;
    }
    out.push_back({i, b, nr, nz});
  }
  return out;
}

// Particles are indexed by int; the capacity reserve (1.5x) and the mirror particles must fit too.
constexpr double kMaxParticles = 1.0e9;

// Bytes of device memory per particle: the fields of core/Particles.hpp (38 doubles and 3
// ints), the 1.5x capacity reserve, the neighbour list (about 30 pairs of a 4-byte index and
// an 8-byte kernel factor) and the kept acceleration parts. An estimate, to refuse a model
// that cannot fit, not a budget.
constexpr double kBytesPerParticle = 1.5 * (38 * 8 + 3 * 4) + 30 * 12 + 4 * 16;

}  // namespace tamp
