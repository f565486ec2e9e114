#pragma once
// Hierarchical grid (HGrid) broad phase for polydisperse spheres, Top-Down and Bottom-Up.
//
// References (thesis numbering): V. Ogarko, PhD thesis on polydisperse smooth hard spheres (University of
// Twente), ch. 2: §2.1.2 (the grid, = Ogarko & Luding, Comput. Phys. Commun. 183 (2012) 931) and §2.2.2-
// §2.2.3 (Top-Down / Bottom-Up and the cost model, = Krijgsman, Ogarko & Luding, Comp. Part. Mech. 1
// (2014) 357).
//
// L regular grids ("levels") with free, strictly increasing cell edges s_1 < ... < s_L (thesis eq. 2.1).
// A sphere goes to the finest level whose cells hold its interaction diameter,
// h(p) = min{h : s_h >= 2 r_p + skin} (eq. 2.3; the skin turns r into the interaction radius r + skin/2,
// thesis eq. 2.11). Pairs on one level come from the own cell plus the 13-cell forward half shell (the
// linked-cell search of §2.1.2); pairs across levels from a search box of half-width beta around the
// sphere on every other level (eqs. 2.12-2.13, §2.2.2): Top-Down searches the finer levels j < h,
// Bottom-Up the coarser levels j > h.
//
// Search box. A partner q on level j satisfies 2 r_q + skin <= s_j (nominal size), and a pair counts
// when |x_p - x_q| <= r_p + r_q + skin <= r_p + skin/2 + s_j/2, so per axis
//   beta = r_p + skin/2 + s_j/2,  cells floor((x - beta)/s'_j) .. floor((x + beta)/s'_j)
// (the thesis's beta = r_p + s_j/2 with r_p -> r_p + skin/2). The range is widened by 1e-9 cell so
// that rounding in x / s' can never drop a partner.
//
// Cell sizes. Insertion uses the nominal s_h; the mapping uses per-axis snapped edges
// s'_h = L_k / n_h with n_h = floor(L_k / (s_h (1 + 1e-9))) >= 1 (capped at 2^20 cells per axis), on
// periodic AND walled axes. Any s' >= s keeps both searches complete, the snapped cells tile the box
// so periodic indices wrap exactly, and the 1e-9 margin keeps two spheres within s_h of each other
// at most one computed cell apart despite rounding (as in linked_cell.cpp). The cost model should
// therefore use s'_h for the cell counts and (2r + skin + s_j)/s'_j + 1 cells per axis (eqs. 2.57-2.64).
// A level with n_h = 1 holds everything in one cell; periodic levels with n_h <= 2 visit the
// distinct cells of the 3x3x3 block once instead of the half shell (forward and backward alias).
// Walls clamp indices; a centre exactly at L belongs to the last cell. A search box spanning a whole
// periodic axis visits each cell once.
//
// Storage, O(N) for any box (hgrid_storage.hpp): per level the spheres are sorted by cell key (z-major)
// into flat slot arrays, with a packed x, y, z, r copy kept here, and the occupied cells are listed in
// key order. A cell maps to its slot range through a dense cell-start array, a ranked occupancy bitmap
// or a hash table, chosen per level by cells per sphere (setStorageLimits). With explicit or default
// sizes, steady-state builds reuse every buffer; a configurator returns its HGridConfig by value (two
// small allocations per build). A search box with more cells than the level has occupied cells tests
// those cells against the box instead of walking it.
// Measured findPairs time, N = 1e5 random centres at nu = 0.3, one core (dense : ranked : hashed):
// mono 1 : 1.1 : 1.55; uniform volume omega = 50 with optimised sizes, TD 1 : 1.3 : 2.9, BU
// 1 : 1.4 : 1.7. The AABB pre-check of cross-level candidates (thesis §2.1.2) is off by default: its
// three unpredictable comparisons cost more than the exact test they would save (measured 4 Dec 2026,
// N = 2e5, one core, the optimiser's sizes: findPairs 10-23 % faster without it for uniform volume omega
// 10-100 and power law -3 omega 20-100, at packing 0.3 and 0.6, skin 0 to 1 r_min; 5 % for bidisperse omega
// 10; docs/benchmarks/broadphase_ratio/README.md). setAabbPrecheck(true) restores it.
//
// Work counters (setCounting) are the cost model's T_cd and T_ca per level of the searching sphere
// (thesis §2.2.3, eqs. 2.20-2.30): per sphere 1 own-cell look-up + one per existing
// half-shell cell (13 with periodic boundaries and >= 3 cells per axis; cells behind a wall do not
// exist), own-cell pairs with later slots, and per searched level every cell of the clamped search
// box plus every sphere found in it. Empty levels are skipped and not counted (the model has none).
// The fast path iterates occupied cells; the counts it reports are the per-sphere ones (a cell of m
// spheres counts m look-ups of each stencil cell), identical to the per-sphere pseudo-code of §1.9.
//
// update(): O(|moved|). A sphere that stays in its cell refreshes its packed copy; one that changes
// cell leaves a tombstone (NaN coordinates) in its slot and moves to a per-level overflow hash of
// linked lists, which findPairs / findNeighbours search like any level. The index is rebuilt when the
// overflow holds more than max(64, N / 8) spheres, so a cell change costs O(1) amortised. Its per-sphere
// state (home slot, home cell, overflow links: 16 bytes per sphere) is made by the first update() after a
// build, in O(N), so users that only build and search (DEM) neither hold nor write it.
//
// Threads (setThreads): the grouping by level, each level's sort by cell (counting or radix sort, stable)
// and the packed copy run over contiguous parts of the spheres, the pair search over chunks of cells and
// slots (pair_chunks.hpp); slots, pairs and their order are those of one thread. update() is serial.
//
// Files: hgrid.cpp (configuration, levels, build, update, reports), hgrid_search.cpp (search boxes,
// pair search, overflow search, findNeighbours), hgrid_storage.{hpp,cpp} (cell storage).
#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "broadphase/broad_phase.hpp"
#include "broadphase/half_shell.hpp"
#include "broadphase/hgrid_config.hpp"
#include "broadphase/hgrid_storage.hpp"
#include "broadphase/pair_chunks.hpp"

namespace polydem::broadphase {

namespace hgrid {

/// Inclusive cell-index range of a search box on one level, unwrapped and unclamped.
struct CellRange {
  std::array<std::int64_t, 3> lo, hi;
};

/// Relative margin applied when snapping cell edges, and widening of search boxes in cells.
inline constexpr double kSnapMargin = 1e-9;
inline constexpr double kBoxMargin = 1e-9;
inline constexpr int kMaxCellsPerAxis = 1 << 20;

/// Cells along an axis of length `length` (m) for a nominal edge `size`: floor(L / (s (1 + 1e-9))),
/// at least 1, at most 2^20. The snapped edge is length / count.
int snappedCellCount(double length, double size);

/// Half-width beta = r + skin/2 + s/2 (m) of the box searched on a level of nominal edge s.
inline double searchHalfWidth(double radius, double skin, double nominalSize) {
  return radius + 0.5 * skin + 0.5 * nominalSize;
}

/// Cells floor((x_k -+ beta) / cellSize_k) -+ 1e-9 of the search box for a sphere at x (eq. 2.12).
CellRange searchBox(const Eigen::Vector3d& x, double beta, const Eigen::Vector3d& cellSize);

/// Level of insertion (1-based) of a sphere: first h with sizes[h-1] >= 2 r + skin; 0 if none. The
/// sizes ascend, so that is one more than the number of sizes below 2 r + skin (std::lower_bound's
/// position), counted without branches: radii come in no order, and a binary search's branches
/// mispredicted (9% of an HGrid build).
inline int insertionLevel(std::span<const double> sizes, double radius, double skin) {
  const double diameter = 2.0 * radius + skin;  // the same expression as defaultConfig's top level
  std::size_t below = 0;
  for (const double s : sizes) below += static_cast<std::size_t>(s < diameter);
  return below == sizes.size() ? 0 : static_cast<int>(below) + 1;
}

/// Default sizes: s_1 = 2 r_min + skin doubled until >= 2 r_max + skin, the last set to exactly that.
HGridConfig defaultConfig(double minRadius, double maxRadius, double skin, CrossLevel mode);

/// Throws ConfigError unless the sizes are non-empty, positive, finite and strictly increasing.
void validateCellSizes(std::span<const double> sizes, std::string_view origin);

/// The half shell (half_shell.hpp), for the HGrid's files.
using broadphase::kHalfShell;
using broadphase::kHalfShellRuns;

}  // namespace hgrid

template <CrossLevel kMode>
class HGrid final : public BroadPhase {
 public:
  using Configurator = std::function<HGridConfig(const SphereView&, const Box&, double skin, CrossLevel)>;

  /// Per-level layout after a build (level h = 1..L).
  struct LevelInfo {
    double nominalSize = 0.0;                            ///< s_h (m)
    Eigen::Vector3d cellSize = Eigen::Vector3d::Zero();  ///< snapped s'_h per axis (m)
    std::array<int, 3> cells{};
    Index spheres = 0;  ///< spheres inserted at this level at the last build
    Index occupiedCells = 0;
    hgrid::CellStorage storage = hgrid::CellStorage::Empty;  ///< how the level maps cells to slots
  };

  std::string_view name() const override { return kMode == CrossLevel::TopDown ? "hgrid-td" : "hgrid-bu"; }
  Capabilities capabilities() const override { return {.complete = true, .incremental = true}; }
  void findPairs(const SphereView& spheres, std::vector<Pair>& out) const override;
  /// Threaded (setThreads): the same-level search of each level over chunks of its cells, then each
  /// cross-level search over chunks of the searching level's slots, in the serial order. Serial while
  /// counting or while update() has spheres in the overflow.
  void findPairChunks(const SphereView& spheres, PairChunks& out) const override;
  /// Searches every level (own level and both directions), filters with spheresWithinReach(reach).
  void findNeighbours(const SphereView& spheres, Index i, double reach, std::vector<Index>& out) const override;
  std::size_t memoryBytes() const override;
  /// e.g. "hgrid-td L=3 sizes 2.2,4.4,6.2 (snapped 2.207,4.415,6.307; default: ...)".
  std::string describe() const override;

  /// Use these nominal cell sizes at every build. Throws ConfigError unless they are positive, finite
  /// and strictly increasing; build() throws if s_L is below 2 r_max + skin. The mode is the backend's.
  void setConfig(HGridConfig config);
  /// Called at build() when no explicit config is set (e.g. the cost-model optimiser). Its sizes are
  /// validated like setConfig's; if they miss the largest sphere a top level 2 r_max + skin is added.
  void setConfigurator(Configurator configurator) { configurator_ = std::move(configurator); }
  /// Forget setConfig(): the configurator, else the default doubling sizes, are used again.
  void clearConfig() { explicitConfig_ = false; }
  /// The configuration used by the last build (nominal sizes, mode, origin).
  const HGridConfig& config() const { return config_; }
  /// Cell-range storage per level, by cells per sphere on the level (+ 64 and + 4096 slack): at most
  /// `dense` -> dense cell-start array (4 bytes per cell), else at most `ranked` -> occupancy bitmap with
  /// a rank directory (0.19 bytes per cell), else a hash table of the occupied cells (32 bytes per
  /// occupied cell); see hgrid_storage.hpp. Memory stays O(N) for any finite limits. 0 disables a kind.
  void setStorageLimits(double dense, double ranked) { store_.setLimits(dense, ranked); }
  double denseCellLimit() const { return store_.denseLimit(); }
  double rankedCellLimit() const { return store_.rankedLimit(); }

  /// Test the axis-aligned bounding boxes of cross-level candidates before the exact test (thesis §2.1.2;
  /// off by default). Pair sets are identical either way; here it costs more than it saves (measurements
  /// at the top of this file).
  void setAabbPrecheck(bool on) { aabbPrecheck_ = on; }
  bool aabbPrecheck() const { return aabbPrecheck_; }

  int levelCount() const { return static_cast<int>(levels_.size()); }
  LevelInfo levelInfo(int h) const;
  /// Level of insertion (1-based) of sphere i at the last build.
  int levelOf(Index i) const { return level_[static_cast<std::size_t>(i)] + 1; }
  /// Work of the last findPairs() per level of the searching sphere (index h - 1) when counting;
  /// counters() holds the running totals.
  const std::vector<Counters>& levelCounters() const { return levelCounters_; }
  /// Spheres currently held in the overflow after update() moved them across cells.
  Index overflowCount() const { return static_cast<Index>(overflow_.size()); }

  /// Check every invariant of the index against the spheres; throws std::logic_error (tests).
  void validate(const SphereView& spheres) const;

 protected:
  void doBuild(const SphereView& spheres) override;
  void doUpdate(const SphereView& spheres, std::span<const Index> moved) override;

 private:
  struct OverflowEntry {
    std::uint64_t key;
    Index head;
  };
  // A level: its geometry, where its cells live in store_ (the LevelCells base: slots [begin, end),
  // storage kind, offsets, occupied cells [cellBegin, cellEnd)) and its overflow.
  struct Level : hgrid::LevelCells {
    double nominal = 0.0;
    std::array<double, 3> size{}, inv{};
    std::array<int, 3> n{};
    std::uint64_t nx = 1, nxy = 1;
    bool aliased = false;
    std::array<std::int64_t, 13> shellDelta{};  // key offsets of the half shell (interior cells)
    // Overflow (spheres moved out of their cell by update()): key -> first sphere of a linked list.
    std::size_t overflowSpheres = 0;
    std::vector<OverflowEntry> overflowTable;  // open addressing, power-of-two capacity
    std::size_t overflowUsed = 0;              // keys in overflowTable
  };
  struct OverflowRecord {
    Index sphere;
    std::uint64_t key;
    double xyzr[4];
  };

  void resolveConfig(const SphereView& spheres);
  void setUpLevels();
  void index(const SphereView& spheres);
  std::uint64_t keyOf(const Level& lv, const double* x) const;
  std::array<std::int32_t, 3> cellOf(const Level& lv, const double* x) const;

  /// Same-level pairs found from the occupied cells [cellBegin, cellEnd) of level h (indices into
  /// store_.cells()).
  template <bool kCount>
  void sameLevel(int h, std::size_t cellBegin, std::size_t cellEnd, std::vector<Pair>& out) const;
  /// Cross-level pairs of the spheres in slots [slotBegin, slotEnd) of level h with level j.
  template <bool kCount, bool kAabb>
  void crossLevel(int h, int j, Index slotBegin, Index slotEnd, std::vector<Pair>& out) const;
  template <bool kCount>
  void pairsImpl(std::vector<Pair>& out) const;
  template <bool kCount>
  void overflowPairs(std::vector<Pair>& out) const;

  // Cell range of a search box on a level: clamped at walls, whole axis when it spans a periodic one.
  struct BoxCells {
    std::int64_t lo[3], hi[3];
    bool wrap[3];  // indices outside [0, n) wrap (periodic, span < n)
    std::uint64_t rows, cells;
  };
  BoxCells boxOn(const Level& lv, const double* x, double beta) const;
  static bool inBox(const BoxCells& box, const Level& lv, const std::int32_t* c);
  // Visit every slot range of level j inside the search box of a sphere at x with half-width beta
  // (each wrapped cell once); returns the number of cells looked up.
  template <class Visit>
  std::uint64_t forEachBoxRange(const Level& lv, const double* x, double beta, Visit&& visit) const;
  template <class Visit>
  void forEachOverflowInBox(const Level& lv, const double* x, double beta, Visit&& visit) const;

  /// Home slot and cell key of every sphere in a slot, from the occupied cells.
  void homes(std::vector<Index>& slotOf, std::vector<std::uint64_t>& homeKey) const;
  /// update()'s per-sphere state after a build: homes, no sphere in the overflow.
  void prepareUpdate();
  void overflowInsert(Level& lv, Index sphere, std::uint64_t key, const double* x, double r);
  void overflowRemove(Level& lv, Index sphere);
  Index overflowHead(const Level& lv, std::uint64_t key) const;
  Index* overflowHeadSlot(Level& lv, std::uint64_t key);

  // Configuration.
  HGridConfig explicit_;
  bool explicitConfig_ = false;
  Configurator configurator_;
  HGridConfig config_;
  std::string note_;  // how config_ came about (e.g. "default", "added top level")
  bool aabbPrecheck_ = false;

  // Geometry and layout.
  std::array<bool, 3> periodic_{};
  std::array<double, 3> length_{}, halfLength_{};
  std::vector<Level> levels_;
  std::vector<int> occupied_;  // 0-based levels holding spheres at the last build, ascending
  hgrid::CellStore store_;     // slot ranges and occupied cells of every level

  // Per slot and per sphere.
  std::vector<Index> sorted_;   // sphere per slot, -1 for a tombstone
  std::vector<double> packed_;  // x, y, z, r per slot
  // update()'s per-sphere state, made by its first call after a build (prepareUpdate): home slot and cell key.
  bool updateReady_ = false;
  std::vector<Index> slotOf_;
  std::vector<std::uint16_t> level_;  // 0-based level per sphere
  std::vector<std::uint64_t> homeKey_;

  // Overflow: records in insertion order (swap-removed), per-sphere position and list link.
  std::vector<OverflowRecord> overflow_;
  std::vector<Index> overflowPos_;   // index into overflow_, -1 when at home
  std::vector<Index> overflowNext_;  // next sphere in the same overflow cell, -1 ends

  // Build scratch (kept to avoid allocations).
  std::vector<Index> levelCount_;
  std::vector<Index> sortScratch_;  // histograms of the grouping by level

  // Threaded search: pieces of work in the serial order (h == j: same level over cells [begin, end),
  // else level h's slots [begin, end) searching level j), and their pairs.
  struct SearchTask {
    int h, j;
    std::size_t begin, end;
  };
  mutable std::vector<SearchTask> tasks_;
  mutable PairChunks chunks_;

  mutable std::vector<Counters> levelCounters_;
};

using HGridTopDown = HGrid<CrossLevel::TopDown>;
using HGridBottomUp = HGrid<CrossLevel::BottomUp>;

extern template class HGrid<CrossLevel::TopDown>;
extern template class HGrid<CrossLevel::BottomUp>;

}  // namespace polydem::broadphase
