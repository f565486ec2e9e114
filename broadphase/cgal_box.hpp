#pragma once
// CGAL box intersection (Zomorodian and Edelsbrunner's streamed segment tree, CGAL::box_self_
// intersection_d) on the spheres' axis-aligned boxes, then the one exact predicate: a ready,
// well-tested library algorithm as a second sorting-based reference next to sweep and prune.
//
// Each sphere's box has half-extent r + skin / 2 (plus a round-off margin) and closed topology, so
// touching boxes count. Periodic axes: spheres within their half-extent of a periodic face get image
// boxes shifted by -+L (every combination over periodic axes, up to 7 images); image ids map back to
// the particle and the pair list is deduplicated. All pairs are found in build() and stored; CGAL
// stays in cgal_box.cpp.
#include <vector>

#include "broadphase/broad_phase.hpp"
#include "broadphase/pair_table.hpp"

namespace polydem::broadphase {

class CgalBox final : public BroadPhase {
 public:
  std::string_view name() const override { return "cgal-box"; }
  Capabilities capabilities() const override { return {.complete = true, .incremental = false}; }
  void findPairs(const SphereView& spheres, std::vector<Pair>& out) const override;
  void findNeighbours(const SphereView& spheres, Index i, double reach, std::vector<Index>& out) const override;
  std::size_t memoryBytes() const override;
  std::string describe() const override;

  /// Image boxes added for periodic faces at the last build.
  Index imageCount() const { return images_; }
  /// Candidate box pairs CGAL reported at the last build (before the exact test and deduplication).
  std::size_t candidateCount() const { return candidates_; }

 protected:
  /// O(N log^3 N) worst case; all pairs are computed here.
  void doBuild(const SphereView& spheres) override;

 private:
  PairTable table_;
  std::vector<Pair> scratch_;
  Index images_ = 0;
  std::size_t candidates_ = 0;
  std::size_t boxBytes_ = 0;
};

}  // namespace polydem::broadphase
