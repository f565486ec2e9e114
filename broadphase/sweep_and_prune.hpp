#pragma once
// Sweep and prune (sort and sweep) along one axis.
//
// Each sphere's box along the sweep axis is [x - e, x + e] with half-extent e = r + skin / 2 (plus a
// round-off margin), so two boxes overlap exactly when the centres are within r_i + r_j + skin along
// that axis. Boxes are kept sorted by their lower end; the sweep visits, for each box, the following
// boxes whose lower end lies inside it, checks the other two axes (minimum image on periodic axes),
// then applies the one exact predicate. Insensitive to particle size (no cells), O(N) memory.
//
// Sorting: the previous order is kept and repaired by insertion sort, O(N + inversions), which is
// what makes SAP cheap between DEM steps (positions change little); a repair that needs too many
// shifts falls back to std::sort. Periodic sweep axis: lower ends are wrapped into [0, L) and boxes
// whose lower end lies below the largest box width are swept a second time shifted by +L (ghosts),
// so boxes that straddle the face still meet. See Krijgsman, Ogarko &
// Luding, Comp. Part. Mech. 1 (2014) 357 (Ogarko's thesis §2.2.1: the sort-based family).
#include <vector>

#include "broadphase/broad_phase.hpp"

namespace polydem::broadphase {

class SweepAndPrune final : public BroadPhase {
 public:
  std::string_view name() const override { return "sap"; }
  Capabilities capabilities() const override { return {.complete = true, .incremental = true}; }
  void findPairs(const SphereView& spheres, std::vector<Pair>& out) const override;
  void findNeighbours(const SphereView& spheres, Index i, double reach, std::vector<Index>& out) const override;
  std::size_t memoryBytes() const override;
  std::string describe() const override;

  int axis() const { return axis_; }
  /// True when the last build()/update() repaired the previous order by insertion sort.
  bool lastSortWasInsertion() const { return lastInsertion_; }
  /// Element shifts done by the last insertion sort (0 for an already sorted order).
  std::size_t lastSortShifts() const { return lastShifts_; }
  /// Check that slots are sorted and mirror the particles (tests).
  void validate(const SphereView& spheres) const;

 protected:
  /// Reuses the previous order (insertion sort) when the particle count is unchanged.
  void doBuild(const SphereView& spheres) override;
  /// Re-keys the moved spheres and repairs the order by insertion sort: O(N + inversions).
  void doUpdate(const SphereView& spheres, std::span<const Index> moved) override;

 private:
  struct Slot {
    double c[3];  // centre
    double r, e;  // radius, half-extent of the box
    Index particle;
  };
  double lowerEnd(const SphereView& spheres, Index i) const;
  void sortAndPack(const SphereView& spheres, bool reuseOrder);
  template <bool kCount>
  void sweep(std::vector<Pair>& out) const;

  int axis_ = 0;
  double margin_ = 0.0;        // absolute round-off margin added to every half-extent
  double maxWidth_ = 0.0;      // largest box width 2 e along the sweep axis
  Index ghosts_ = 0;           // leading slots swept again at +L (periodic sweep axis)
  bool mayDuplicate_ = false;  // two boxes can meet both directly and through the face
  bool lastInsertion_ = false;
  std::size_t lastShifts_ = 0;
  std::vector<Index> order_;   // particle per slot, sorted by (lower end, index)
  std::vector<double> key_;    // lower end per particle
  std::vector<Index> slotOf_;  // slot per particle
  std::vector<double> start_;  // lower end per slot
  std::vector<double> cross_;  // per slot: the two other coordinates and e, for the box test
  std::vector<Slot> slots_;    // per slot: everything the exact test needs
};

}  // namespace polydem::broadphase
