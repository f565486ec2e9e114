#pragma once
// Linked-cell (single-level grid) broad phase.
//
// Cells are at least 2 r_max + skin wide, so a sphere can only touch spheres in its own or the 26
// surrounding cells; each cell pair is visited once through the 13-cell forward half shell. Storage
// is cache friendly: particles are counting-sorted by cell into flat arrays (cell ranges plus a
// packed x, y, z, r copy in cell order), O(N + cells) memory. The number of cells is capped at a
// few per particle, so dilute systems with a huge box do not blow up memory. build() allocates only when
// N or the cell count grows: steady-state rebuilds reuse every buffer (checked with a counting
// operator new: 0 allocations over 10 build + findPairs calls of 2000 spheres).
// Periodic axes with only two cells (the two neighbours alias) take a de-duplicating path.
// Threads (setThreads): the counting sort runs over contiguous parts of the spheres with one histogram
// per part, and the search over chunks of consecutive cells (pair_chunks.hpp); slots, pairs and their
// order are those of one thread.
#include <array>
#include <vector>

#include "broadphase/broad_phase.hpp"
#include "broadphase/pair_chunks.hpp"

namespace polydem::broadphase {

class LinkedCell final : public BroadPhase {
 public:
  std::string_view name() const override { return "linked-cell"; }
  Capabilities capabilities() const override { return {.complete = true, .incremental = true}; }
  void findPairs(const SphereView& spheres, std::vector<Pair>& out) const override;
  /// Threaded (setThreads): chunks of consecutive cells holding about equal numbers of spheres.
  void findPairChunks(const SphereView& spheres, PairChunks& out) const override;
  void findNeighbours(const SphereView& spheres, Index i, double reach, std::vector<Index>& out) const override;
  std::size_t memoryBytes() const override;
  std::string describe() const override;

  /// Force a minimum cell edge (m) larger than 2 r_max + skin; 0 = automatic. For tests and tuning.
  void setMinimumCellSize(double size) { minimumCellSize_ = size; }
  const std::array<int, 3>& cellsPerAxis() const { return cells_; }
  const Eigen::Vector3d& cellSize() const { return cellSize_; }
  /// Check the sorted storage against the particles (tests).
  void validate(const SphereView& spheres) const;

 protected:
  void doBuild(const SphereView& spheres) override;
  /// O(|moved|) while every moved sphere stays in its cell; a full O(N) re-sort otherwise.
  void doUpdate(const SphereView& spheres, std::span<const Index> moved) override;

 private:
  int cellIndexOf(const double* x) const;
  std::array<int, 3> cellCoordinates(int cell) const;
  /// Distinct cells in the 3x3x3 block around `cell` (wrapped or clipped), ascending.
  int neighbourhood(int cell, std::array<int, 27>& out) const;
  /// Pairs found from the cells [cellBegin, cellEnd) (own cell and forward half shell).
  template <bool kCount>
  void pairsImpl(int cellBegin, int cellEnd, std::vector<Pair>& out) const;

  double minimumCellSize_ = 0.0;
  std::array<int, 3> cells_{1, 1, 1};
  Eigen::Vector3d cellSize_ = Eigen::Vector3d::Ones();
  Eigen::Vector3d inverseCellSize_ = Eigen::Vector3d::Ones();
  bool aliased_ = false;              // some periodic axis has 2 cells: use the de-duplicating path
  std::array<int, 13> shellDelta_{};  // cell-index offsets of kHalfShell, for cells off the boundary
  std::vector<Index> cellStart_;      // size cells + 1
  std::vector<Index> sorted_;         // particle index per slot
  std::vector<Index> slotOf_;         // slot per particle
  std::vector<int> cellOf_;           // cell per particle
  std::vector<Index> fill_;           // build scratch: next free slot per cell (per part when threaded)
  mutable PairChunks chunks_;         // findPairs() with threads: the chunks before concatenation
  Eigen::Matrix4Xd packed_;           // x, y, z, r per slot
};

}  // namespace polydem::broadphase
