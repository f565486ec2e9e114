#pragma once
// The forward half shell of a cell in a regular grid (the linked-cell search: each pair of neighbouring
// cells is visited once, from the cell with the smaller z, then y, then x), shared by linked cell and the
// HGrid's same-level search.
#include <array>
#include <cstddef>

namespace polydem::broadphase {

/// The 13 forward offsets (dx, dy, dz) of the half shell, z-major: (1,0,0), then (-1..1, 1, 0), then
/// (-1..1, -1..1, 1).
inline constexpr std::array<std::array<int, 3>, 13> kHalfShell = [] {
  std::array<std::array<int, 3>, 13> shell{};
  int count = 0;
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx)
        if (dz > 0 || (dz == 0 && dy > 0) || (dz == 0 && dy == 0 && dx > 0)) shell[count++] = {dx, dy, dz};
  return shell;
}();

/// The half shell as 5 runs of cells along x, in the order of kHalfShell: (first offset, length). In a
/// grid stored by cell key (x fastest), a run of consecutive keys is one contiguous slot range, so a cell
/// off the boundary looks up 5 ranges instead of 13 cells.
inline constexpr std::array<std::array<int, 2>, 5> kHalfShellRuns = {{{0, 1}, {1, 3}, {4, 3}, {7, 3}, {10, 3}}};

/// Key offsets of the kHalfShell cells in a grid with keys x + nx y + nxy z (valid for cells off the boundary,
/// where no neighbour wraps).
template <class Key>
constexpr std::array<Key, 13> halfShellOffsets(Key nx, Key nxy) {
  std::array<Key, 13> offset{};
  for (std::size_t o = 0; o < kHalfShell.size(); ++o) {
    offset[o] = static_cast<Key>(kHalfShell[o][0]) + nx * static_cast<Key>(kHalfShell[o][1]) +
                nxy * static_cast<Key>(kHalfShell[o][2]);
  }
  return offset;
}

static_assert(kHalfShell[0] == std::array<int, 3>{1, 0, 0} && kHalfShell[1] == std::array<int, 3>{-1, 1, 0} &&
                  kHalfShell[4] == std::array<int, 3>{-1, -1, 1} && kHalfShell[7] == std::array<int, 3>{-1, 0, 1} &&
                  kHalfShell[10] == std::array<int, 3>{-1, 1, 1},
              "each run starts at dx = -1 (or is the single cell (1, 0, 0)) and its cells follow along x");

}  // namespace polydem::broadphase
