#pragma once
// A stored pair list with a lazily built adjacency (CSR), for backends that find every pair at build
// time (cgal-box, delaunay): findPairs copies the list and findNeighbours filters a particle's row.
// No CGAL here, so the CGAL backends keep their headers free of it.
#include <vector>

#include "broadphase/broad_phase.hpp"

namespace polydem::broadphase {

class PairTable {
 public:
  /// Take raw pairs (i < j, any order, duplicates allowed) for `count` particles: sorts and dedupes.
  /// O(P log P). Reuses `raw`'s storage.
  void assign(std::vector<Pair>&& raw, Index count);
  /// Drop every pair touching a particle with dropped[i] != 0, then add `extra` (i < j, any order).
  /// O(P + E log E).
  void replaceRows(const std::vector<char>& dropped, std::vector<Pair>& extra);

  const std::vector<Pair>& pairs() const { return pairs_; }
  /// Every stored neighbour j of i that passes withinReach(i, j, reach), ascending.
  void neighbours(const SphereView& spheres, const Box& box, Index i, double reach, std::vector<Index>& out) const;
  std::size_t memoryBytes() const;

 private:
  void buildAdjacency() const;

  Index count_ = 0;
  std::vector<Pair> pairs_;
  std::vector<Pair> merged_;  // scratch for replaceRows
  mutable bool adjacencyValid_ = false;
  mutable std::vector<Index> start_, adjacent_;  // CSR over both directions, built on first query
};

}  // namespace polydem::broadphase
