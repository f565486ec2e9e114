#pragma once
// A multi-level grid whose cells are growable buckets, so that moving one sphere is O(1) (amortised) and
// update() is O(|moved|) however far the spheres went: the index that answers the event-driven engine's
// neighbourhood exits (Donev 2006, thesis, §3.4.7, Algorithm 10: which neighbourhoods overlap the
// re-centred one), and a registered backend like any other, so it runs through the property suite against
// brute force.
//
// Level l holds the spheres with radius in [r_min 2^l, r_min 2^(l+1)), in cells of at least 2 r_max(l) +
// skin per axis (at most (8 N)^(1/3) per axis, so about 8 N cells per level at most). A query for sphere
// i visits, on every level, the cells within r_i + r_max(l) + reach of its centre (the top-down search of
// Ogarko's thesis §2.2.3; Krijgsman, Ogarko & Luding, Comp. Part. Mech. 1 (2014) 357) and skips the cells of
// that block whose box lies farther than that from the centre; an axis whose range covers all its cells is
// visited once (no wrapped duplicates), walled axes are clipped. Candidates go through the one pair
// predicate (spheresWithinReach), so the lists are those of every other backend.
//
// Storage: each cell is a run of slots in its level's array (centre and radius packed, x, y, z, r, and the
// sphere's number beside it), with spare room. A query reads a cell's spheres as one contiguous run; a move
// overwrites the slot with the cell's last entry and appends to the new cell, relocating that cell's run to
// the end of the array with doubled room when it is full. The array is compacted when relocations have
// doubled it. (Until session 16 the cells were linked lists, as backend `hgrid-linked`: the same O(1) moves, but
// a query chased one pointer per candidate.)
//
// Against the shared HGrid (hgrid.hpp): no cost-model optimiser (the levels are fixed powers of two, which
// costs more pair tests per query on narrow distributions), but a move never leaves the structure, where the
// HGrid parks every sphere that changed cell in an overflow hash until its next build. In an event-driven
// run every neighbourhood moves a few times between global rebuilds, so the HGrid's queries ran mostly
// through that hash (mono N = 10,000, phi 0.5: 28% of the time in exits; uniform volume omega = 50: 65%).
//
// A query gathers its cells in a scratch array of the index: one query at a time per index (the engine's
// exits are serial). The index keeps its own copy of the centres and radii: queries use the positions given at build()
// / update(), and update() reads the moved spheres' new centres from the view. Radii must not change between builds.
#include <array>
#include <cstdint>
#include <vector>

#include "broadphase/broad_phase.hpp"
#include "core/huge_pages.hpp"

namespace polydem::broadphase {

class HGridDynamic final : public BroadPhase {
 public:
  std::string_view name() const override { return "hgrid-dynamic"; }
  Capabilities capabilities() const override { return {.complete = true, .incremental = true}; }
  void findPairs(const SphereView& spheres, std::vector<Pair>& out) const override;
  void findNeighbours(const SphereView& spheres, Index i, double reach, std::vector<Index>& out) const override;
  std::size_t memoryBytes() const override;
  std::string describe() const override;

 protected:
  void doBuild(const SphereView& spheres) override;
  void doUpdate(const SphereView& spheres, std::span<const Index> moved) override;

 private:
  /// Sphere i now has its centre at x (inside the box; radius unchanged). O(1) amortised. What update()
  /// does for each moved sphere.
  void move(Index i, const double x[3]);

  struct Slot {
    double c[4];  // centre x, y, z and radius
  };
  struct Run {
    std::int32_t begin = 0, size = 0;
  };
  struct Level {
    double rmax = 0.0;
    std::array<double, 3> inverseCell{}, cell{};
    std::array<std::int32_t, 3> n{};
    LargeVector<Run> run;            // per cell: its spheres' slots
    LargeVector<std::int32_t> room;  // per cell: slots reserved from run.begin
    LargeVector<Slot> slots;         // the cells' runs, spare room included
    LargeVector<Index> id;           // the sphere in each slot
    std::size_t spheres = 0;
    std::size_t laidOut = 0;  // slots at the last layOut(): relocations past twice that compact the array
  };
  /// Every j != i with gap(i, j) <= reach (0 <= reach <= skin), ascending, from the index's own copy of the
  /// positions; counts cell accesses and pair tests with kCount. Clears `out` first.
  template <bool kCount>
  void query(Index i, double reach, std::vector<Index>& out) const;
  std::int32_t cellOf(const Level& lv, const double x[3]) const;
  /// Lay out every cell of `lv` afresh with room for its spheres plus spare (build and compaction).
  void layOut(Level& lv);
  /// Copy `run`'s spheres to slot `to` of the arrays `slots` / `id` (the level's own, or new ones) and point
  /// the run and the spheres' slot numbers there.
  void copyRun(Level& lv, Run& run, Slot* slots, Index* id, std::int32_t to);
  void append(Level& lv, std::int32_t cell, Index i, const Slot& s);
  void remove(Level& lv, Index i);

  std::array<bool, 3> periodic_{};
  std::array<double, 3> length_{};
  std::vector<Level> levels_;
  LargeVector<std::uint8_t> level_;
  LargeVector<std::int32_t> cell_;           // sphere -> cell on its level
  LargeVector<std::int32_t> slot_;           // sphere -> slot on its level
  mutable std::vector<Index> found_;         // a query's candidates, each written, the count advancing for hits
  mutable std::vector<std::int32_t> visit_;  // a query's cells, gathered (and prefetched) before they are read
  mutable std::vector<Index> scratch_;       // findPairs' per-sphere query, kept so steady-state calls do not allocate
  // A query's block, per axis (3 x axisStride_): squared distance of each column from the centre, and its
  // wrapped cell index. axisStride_ is the most cells per axis of any level since construction.
  mutable std::vector<double> axisGap2_;
  mutable std::vector<std::int32_t> axisCell_;
  std::size_t axisStride_ = 0;
};

}  // namespace polydem::broadphase
