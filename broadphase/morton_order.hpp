#pragma once
// Morton (Z-order) ordering of sphere centres, the one in broadphase/ (the tree backends lbvh and
// aabb_tree build from it); keys from core/morton.hpp.
#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/box.hpp"
#include "core/morton.hpp"
#include "core/particle_store.hpp"
#include "core/types.hpp"

namespace polydem::broadphase {

/// Bits per axis of the keys: 63-bit keys, 2^21 cells per axis.
inline constexpr int kMortonBits = 21;

/// (Morton key, index) of every centre, sorted by key, ties by index, so the order does not depend on the
/// sort's stability. O(N log N); reuses the capacity of `out`.
inline void mortonOrder(const SphereView& spheres, const Box& box, std::vector<std::pair<std::uint64_t, Index>>& out) {
  const Index n = spheres.count();
  out.resize(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i)
    out[static_cast<std::size_t>(i)] = {mortonKey(spheres.centre.col(i).data(), box, kMortonBits), i};
  std::sort(out.begin(), out.end());
}

}  // namespace polydem::broadphase
