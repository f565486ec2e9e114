#pragma once
// Cell storage of the hierarchical grid (hgrid.hpp): for every level, the spheres sorted by cell key into
// one range of slots, the occupied cells listed in key order, and a map from a cell key to its slot range.
// The levels and the search (which cells to visit) are the HGrid's; this file only stores and looks up.
//
// Per level the keys are sorted by a counting sort over the cells (dense levels) or an LSD radix sort
// (11-bit digits, stable), and the map is one of three, chosen by cells per sphere on the level:
//   dense   cell-start array, 4 bytes per cell (default: <= 8 cells per sphere, + 64);
//   ranked  occupancy bitmap + rank directory over the sorted cell list, 0.19 bytes per cell (default:
//           <= 256 cells per sphere, + 4096); look-ups stay spatially coherent and empty cells cost a
//           bit test;
//   hashed  open-addressing hash of the occupied cells, load <= 1/2, verifying the full key (sparser
//           levels; 32 bytes per occupied cell).
// With dense and ranked levels a run of cells along x is one contiguous slot range (startOf). Memory is
// O(N) for any finite limits; nothing is allocated per cell, and a rebuild reuses every buffer. The
// thesis stores its grid in a hash table (V. Ogarko, PhD thesis, University of Twente, §2.1.2 = Ogarko &
// Luding, Comput. Phys. Commun. 183 (2012) 931) and names more cache-friendly structures as future work
// (its Conclusions and Outlook); dense and ranked storage are that.
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/types.hpp"

namespace polydem::broadphase::hgrid {

/// How a level maps a cell key to its slot range.
enum class CellStorage : std::uint8_t {
  Empty,   ///< no spheres on the level: nothing stored
  Dense,   ///< cell-start array
  Ranked,  ///< occupancy bitmap + rank directory
  Hashed,  ///< open-addressing hash table of the occupied cells
};

/// '-', 'd', 'r' or 'h' (reports).
char storageLetter(CellStorage kind);

/// A key no cell has (empty hash slots).
inline constexpr std::uint64_t kEmptyKey = ~std::uint64_t{0};
/// Multiplier of Fibonacci hashing: slot = (key * kGolden) >> (64 - log2 capacity).
inline constexpr std::uint64_t kGolden = 0x9E3779B97F4A7C15ULL;

/// Slots [begin, end) of a cell; empty when begin >= end.
struct SlotRange {
  Index begin, end;
};

/// An occupied cell: z-major key c0 + nx c1 + nxy c2, its coordinates and its slots [begin, end).
struct OccupiedCell {
  std::uint64_t key;
  std::int32_t c[3];
  Index begin, end;
};

/// Where one level's cells live in the CellStore's shared buffers.
struct LevelCells {
  Index begin = 0, end = 0;      ///< the level's slots
  std::size_t denseOffset = 0;   ///< into the cell starts (cells + 1 entries)
  std::size_t bitmapOffset = 0;  ///< into the bitmap and rank directory (one word per 64 cells)
  std::size_t tableOffset = 0;   ///< into the hash table
  std::uint64_t tableMask = 0;
  int tableShift = 64;
  CellStorage kind = CellStorage::Empty;   // beside tableShift: no padding of its own
  std::size_t cellBegin = 0, cellEnd = 0;  ///< into cells()

  /// Dense or ranked: the slots of a run of consecutive keys are contiguous, found with startOf().
  bool contiguous() const { return kind == CellStorage::Dense || kind == CellStorage::Ranked; }
};

class CellStore {
 public:
  /// Storage by cells per sphere (+ 64 and + 4096 slack): at most `dense` -> dense, else at most `ranked`
  /// -> ranked, else hashed. 0 disables a kind.
  void setLimits(double dense, double ranked) {
    denseLimit_ = dense;
    rankedLimit_ = ranked;
  }
  double denseLimit() const { return denseLimit_; }
  double rankedLimit() const { return rankedLimit_; }

  /// Start a build of `sphereCount` spheres: forget every level's cells, size the sort buffers.
  void reset(std::size_t sphereCount);
  /// Forget a level's cells: an empty level, or one about to be added.
  void clearLevel(LevelCells& lv) const {
    lv.kind = CellStorage::Empty;
    lv.cellBegin = lv.cellEnd = cells_.size();
  }
  /// Sort buffers, indexed by slot: fill keys()[s] and spheres()[s] for the level's slots, then addLevel().
  std::uint64_t* keys() { return keyA_.data(); }
  Index* spheres() { return idxA_.data(); }

  /// Keys and spheres of a level's slots in sorted order (t = slot - lv.begin), valid until reset().
  struct Sorted {
    const std::uint64_t* key;  // keys in slot order
    const Index* sphere;       // spheres in slot order
  };
  /// Sort the slots [lv.begin, lv.end) (non-empty) of a level of n[0] x n[1] x n[2] cells by key (stable:
  /// slots of one cell keep their order), list its occupied cells and build its map. The caller lays out
  /// its per-slot data from the returned order. O(m + cells) dense, O(m) otherwise; threaded
  /// (setThreads), with the same result for any thread count.
  Sorted addLevel(LevelCells& lv, const std::array<int, 3>& n, std::uint64_t nx, std::uint64_t nxy);
  /// Threads for addLevel (>= 1).
  void setThreads(int threads) { threads_ = threads; }

  /// First slot of the first occupied cell with a key >= `key` (key <= cells; dense and ranked levels).
  [[gnu::always_inline]] inline Index startOf(const LevelCells& lv, std::uint64_t key) const;
  /// The slots of cell `key` (any non-empty level).
  [[gnu::always_inline]] inline SlotRange rangeOf(const LevelCells& lv, std::uint64_t key) const;
  /// Occupied cells of every level; a level's are [lv.cellBegin, lv.cellEnd), ascending keys.
  const std::vector<OccupiedCell>& cells() const { return cells_; }

  std::size_t memoryBytes() const;
  /// Check the level's map against its cell list (of a level of `cellCount` cells): the bitmap and rank
  /// directory, or the hash table's entries. Empty when consistent, else what is wrong.
  std::string checkMap(const LevelCells& lv, std::uint64_t cellCount) const;

 private:
  struct HashEntry {
    std::uint64_t key;
    Index begin, end;
  };
  /// Choose the level's storage kind and sort its slots (a counting sort fills the dense cell starts).
  Sorted sortLevel(LevelCells& lv, std::uint64_t cellCount);
  /// The ranked bitmap or the hash table of a sparse level, from its occupied cells.
  void buildSparseMap(LevelCells& lv, std::uint64_t cellCount);
  /// Append the level's occupied cells (runs of equal keys in `sorted`) to cells_.
  void listCells(LevelCells& lv, const Sorted& sorted, const std::array<int, 3>& n, std::uint64_t nx,
                 std::uint64_t nxy);
  /// Room for `count` occupied cells in cells_ (grows only).
  void reserveCells(std::size_t count);

  double denseLimit_ = 8.0;
  double rankedLimit_ = 256.0;
  std::vector<Index> cellStart_;
  std::vector<HashEntry> table_;
  std::vector<std::uint64_t> bitmap_;
  std::vector<std::uint32_t> rank_;  // occupied cells of the level before each bitmap word
  std::vector<OccupiedCell> cells_;
  // Sort buffers (kept to avoid allocations).
  std::vector<std::uint64_t> keyA_, keyB_;
  std::vector<Index> idxA_, idxB_;
  std::vector<Index> histogram_;  // counting-sort histograms (one per part when threaded)
  std::vector<Index> runStart_;   // listCells with threads: occupied cells per part
  int threads_ = 1;
};

inline Index CellStore::startOf(const LevelCells& lv, std::uint64_t key) const {
  if (lv.kind == CellStorage::Dense) return cellStart_[lv.denseOffset + key];
  const std::size_t w = lv.bitmapOffset + (key >> 6);
  const std::uint64_t below = bitmap_[w] & ((std::uint64_t{1} << (key & 63)) - 1);
  const std::size_t r = lv.cellBegin + rank_[w] + static_cast<std::size_t>(std::popcount(below));
  return r < lv.cellEnd ? cells_[r].begin : lv.end;
}

inline SlotRange CellStore::rangeOf(const LevelCells& lv, std::uint64_t key) const {
  if (lv.kind == CellStorage::Dense) {
    const Index* cs = cellStart_.data() + lv.denseOffset + key;
    return {cs[0], cs[1]};
  }
  if (lv.kind == CellStorage::Ranked) {
    const std::size_t w = lv.bitmapOffset + (key >> 6);
    const std::uint64_t word = bitmap_[w];
    if (!((word >> (key & 63)) & 1)) return {0, 0};
    const std::uint64_t below = word & ((std::uint64_t{1} << (key & 63)) - 1);
    const OccupiedCell& cell = cells_[lv.cellBegin + rank_[w] + static_cast<std::size_t>(std::popcount(below))];
    return {cell.begin, cell.end};
  }
  // Linear probing; the full key is compared, so an empty cell never returns a colliding cell's spheres.
  const HashEntry* table = table_.data() + lv.tableOffset;
  for (std::uint64_t at = (key * kGolden) >> lv.tableShift;; at = (at + 1) & lv.tableMask) {
    const HashEntry& e = table[at];
    if (e.key == key) return {e.begin, e.end};
    if (e.key == kEmptyKey) return {0, 0};
  }
}

}  // namespace polydem::broadphase::hgrid
