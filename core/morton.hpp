#pragma once
// Morton (Z-order) keys of positions in a box, for sorting particles so that neighbours in space are
// neighbours in memory (DEM start-up, EDMD synchronisations, benchmark scenes).
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "core/box.hpp"

namespace polydem {

/// Spread the low 21 bits of v so that two zero bits separate consecutive ones.
inline std::uint64_t spreadBits21(std::uint64_t v) {
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffffULL;
  v = (v | v << 16) & 0x1f0000ff0000ffULL;
  v = (v | v << 8) & 0x100f00f00f00f00fULL;
  v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
  v = (v | v << 2) & 0x1249249249249249ULL;
  return v;
}

/// Morton key of position x (3 doubles) on a grid of 2^bits cells per axis (bits <= 21) over the box
/// [0, L); coordinates outside are clamped to the edge cells.
inline std::uint64_t mortonKey(const double* x, const Box& box, int bits) {
  const double cells = static_cast<double>(std::uint64_t{1} << bits);
  const auto last = (std::uint64_t{1} << bits) - 1;
  std::uint64_t key = 0;
  for (int k = 0; k < 3; ++k) {
    const double t = std::clamp(x[k] / box.length(k), 0.0, 1.0) * cells;
    // floor(t) clamped to the last cell; t >= 0 here, so truncation is the floor (NaN: the last cell).
    key |= spreadBits21(t < cells - 1.0 ? static_cast<std::uint64_t>(t) : last) << k;
  }
  return key;
}

}  // namespace polydem
