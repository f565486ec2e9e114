// Hierarchical grid broad phase; design notes in hgrid.hpp. Seed 000 = Ogarko & Luding, Comput. Phys.
// Commun. 183 (2012) 931 and Krijgsman, Ogarko & Luding, Comp. Part. Mech. (2014), reprinted in
// shared/seeds/000_3b5cd2443ded9063.txt (mapping eq. 2.1 :899, insertion eq. 2.3 :933, same-level
// half shell :988-994, search box eqs. 2.12-2.13 :2048-2083, AABB pre-check :1046-1054, hashing of
// occupied cells :1074-1078, cost quantities eqs. 2.20-2.30 :2253-2346).
#include "broadphase/hgrid.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>

#include "core/errors.hpp"

namespace polydem::broadphase {

namespace hgrid {

int snappedCellCount(double length, double size) {
  const double n = std::floor(length / (size * (1.0 + kSnapMargin)));
  if (!(n >= 1.0)) return 1;  // also NaN
  return n >= kMaxCellsPerAxis ? kMaxCellsPerAxis : static_cast<int>(n);
}

CellRange searchBox(const Eigen::Vector3d& x, double beta, const Eigen::Vector3d& cellSize) {
  CellRange r;
  for (int k = 0; k < 3; ++k) {
    const double inv = 1.0 / cellSize[k];
    r.lo[k] = static_cast<std::int64_t>(std::floor((x[k] - beta) * inv - kBoxMargin));
    r.hi[k] = static_cast<std::int64_t>(std::floor((x[k] + beta) * inv + kBoxMargin));
  }
  return r;
}

int insertionLevel(std::span<const double> sizes, double radius, double skin) {
  const double diameter = 2.0 * radius + skin;  // the same expression as defaultConfig's top level
  const auto it = std::lower_bound(sizes.begin(), sizes.end(), diameter);
  return it == sizes.end() ? 0 : static_cast<int>(it - sizes.begin()) + 1;
}

HGridConfig defaultConfig(double minRadius, double maxRadius, double skin, CrossLevel mode) {
  HGridConfig c;
  c.mode = mode;
  const double top = 2.0 * maxRadius + skin;
  for (double s = 2.0 * minRadius + skin; s < top; s *= 2.0) c.cellSizes.push_back(s);
  c.cellSizes.push_back(top);
  c.origin = "default: doubling from 2 r_min + skin to 2 r_max + skin";
  return c;
}

void validateCellSizes(std::span<const double> sizes, std::string_view origin) {
  if (sizes.empty()) throw ConfigError(fmt::format("hgrid cell sizes ({}): need at least one level", origin));
  if (sizes.size() > std::numeric_limits<std::uint16_t>::max()) {
    throw ConfigError(fmt::format("hgrid cell sizes ({}): {} levels, at most 65535", origin, sizes.size()));
  }
  for (std::size_t h = 0; h < sizes.size(); ++h) {
    if (!(std::isfinite(sizes[h]) && sizes[h] > 0.0)) {
      throw ConfigError(fmt::format("hgrid cell size s_{} ({}) must be positive and finite, got {}", h + 1, origin,
                                    sizes[h]));
    }
    if (h > 0 && !(sizes[h] > sizes[h - 1])) {
      throw ConfigError(fmt::format("hgrid cell sizes ({}) must increase strictly: s_{} = {} after s_{} = {}", origin,
                                    h + 1, sizes[h], h, sizes[h - 1]));
    }
  }
}

}  // namespace hgrid

namespace {

constexpr std::uint64_t kEmptyKey = ~std::uint64_t{0};
constexpr std::uint64_t kGolden = 0x9E3779B97F4A7C15ULL;  // Fibonacci hashing

inline void emit(std::vector<Pair>& out, Index a, Index b) { out.push_back(a < b ? Pair{a, b} : Pair{b, a}); }

// The 13 forward offsets of the half shell (digest §1.5), in the order linked_cell.cpp uses.
constexpr std::array<std::array<int, 3>, 13> kHalfShell = [] {
  std::array<std::array<int, 3>, 13> shell{};
  int count = 0;
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx)
        if (dz > 0 || (dz == 0 && dy > 0) || (dz == 0 && dy == 0 && dx > 0)) shell[count++] = {dx, dy, dz};
  return shell;
}();

// LSD radix sort of (key, value) by key, keys < 2^bits, 11-bit digits; stable. Returns the buffers
// holding the result (the inputs or the scratch ones).
std::pair<std::uint64_t*, Index*> radixSort(std::uint64_t* key, Index* val, std::uint64_t* keyTmp, Index* valTmp,
                                            std::size_t n, int bits) {
  constexpr int kDigit = 11;
  constexpr std::size_t kBuckets = std::size_t{1} << kDigit;
  std::array<Index, kBuckets> count;
  for (int shift = 0; shift < bits; shift += kDigit) {
    count.fill(0);
    for (std::size_t i = 0; i < n; ++i) ++count[(key[i] >> shift) & (kBuckets - 1)];
    Index running = 0;
    for (Index& c : count) {
      const Index here = c;
      c = running;
      running += here;
    }
    for (std::size_t i = 0; i < n; ++i) {
      const Index pos = count[(key[i] >> shift) & (kBuckets - 1)]++;
      keyTmp[pos] = key[i];
      valTmp[pos] = val[i];
    }
    std::swap(key, keyTmp);
    std::swap(val, valTmp);
  }
  return {key, val};
}

}  // namespace

// ---------------------------------------------------------------------------------------------------
// Configuration

template <CrossLevel kMode>
void HGrid<kMode>::setConfig(HGridConfig config) {
  hgrid::validateCellSizes(config.cellSizes, "setConfig");
  config.mode = kMode;
  if (config.origin.empty()) config.origin = "explicit";
  explicit_ = std::move(config);
  explicitConfig_ = true;
}

template <CrossLevel kMode>
void HGrid<kMode>::resolveConfig(const SphereView& spheres) {
  const double top = 2.0 * maxRadius_ + skin_;  // largest interaction diameter
  const bool any = spheres.count() > 0;
  note_.clear();
  if (explicitConfig_) {
    config_ = explicit_;
    if (any && config_.cellSizes.back() < top) {
      throw ConfigError(fmt::format("hgrid: cell size s_L = {} is smaller than the largest interaction diameter "
                                    "2 r_max + skin = {}: add a level of at least that size",
                                    config_.cellSizes.back(), top));
    }
  } else if (!any) {
    config_ = HGridConfig{{box_.lengths().maxCoeff()}, kMode, "default (no spheres)"};  // nothing to optimise
  } else if (configurator_) {
    config_ = configurator_(spheres, box_, skin_, kMode);
    hgrid::validateCellSizes(config_.cellSizes, "configurator");
    if (config_.origin.empty()) config_.origin = "configurator";
    if (any && config_.cellSizes.back() < top) {
      // Lenient: an optimiser working from a sampled distribution may miss the largest sphere by a hair.
      note_ = fmt::format("added top level 2 r_max + skin = {:.6g} above the configurator's s_L = {:.6g}", top,
                          config_.cellSizes.back());
      config_.cellSizes.push_back(top);
    }
  } else {
    // hgrid::defaultConfig() filled in place, so that steady-state rebuilds do not allocate.
    config_.cellSizes.clear();
    for (double s = 2.0 * minRadius_ + skin_; s < top; s *= 2.0) config_.cellSizes.push_back(s);
    config_.cellSizes.push_back(top);
    config_.origin = "default: doubling from 2 r_min + skin to 2 r_max + skin";
  }
  config_.mode = kMode;
}

template <CrossLevel kMode>
void HGrid<kMode>::setUpLevels() {
  for (int k = 0; k < 3; ++k) {
    periodic_[k] = box_.periodic(k);
    length_[k] = box_.length(k);
    halfLength_[k] = 0.5 * box_.length(k);  // as Box::minimumImage computes it
  }
  const std::size_t count = config_.cellSizes.size();
  levels_.resize(count);
  for (std::size_t h = 0; h < count; ++h) {
    Level& lv = levels_[h];
    lv.nominal = config_.cellSizes[h];
    lv.aliased = false;
    for (int k = 0; k < 3; ++k) {
      lv.n[k] = hgrid::snappedCellCount(length_[k], lv.nominal);
      lv.size[k] = length_[k] / lv.n[k];
      lv.inv[k] = 1.0 / lv.size[k];
      if (periodic_[k] && lv.n[k] <= 2) lv.aliased = true;
    }
    lv.nx = static_cast<std::uint64_t>(lv.n[0]);
    lv.nxy = lv.nx * static_cast<std::uint64_t>(lv.n[1]);
    for (int o = 0; o < 13; ++o) {
      const auto& d = kHalfShell[o];
      lv.shellDelta[o] = d[0] + static_cast<std::int64_t>(lv.n[0]) * (d[1] + static_cast<std::int64_t>(lv.n[1]) * d[2]);
    }
  }
}

template <CrossLevel kMode>
std::array<std::int32_t, 3> HGrid<kMode>::cellOf(const Level& lv, const double* x) const {
  std::array<std::int32_t, 3> c;
  for (int k = 0; k < 3; ++k) {
    // x in [0, L] (a wall may hold a centre exactly at L), so truncation is floor; clamp into range.
    const double u = x[k] * lv.inv[k];
    c[k] = u >= static_cast<double>(lv.n[k] - 1) ? lv.n[k] - 1 : static_cast<std::int32_t>(u);
  }
  return c;
}

template <CrossLevel kMode>
std::uint64_t HGrid<kMode>::keyOf(const Level& lv, const double* x) const {
  const auto c = cellOf(lv, x);
  return static_cast<std::uint64_t>(c[0]) + lv.nx * static_cast<std::uint64_t>(c[1]) +
         lv.nxy * static_cast<std::uint64_t>(c[2]);
}

// ---------------------------------------------------------------------------------------------------
// Build

template <CrossLevel kMode>
void HGrid<kMode>::doBuild(const SphereView& spheres) {
  resolveConfig(spheres);
  setUpLevels();
  index(spheres);
}

template <CrossLevel kMode>
void HGrid<kMode>::index(const SphereView& spheres) {
  const Index n = spheres.count();
  const std::size_t un = static_cast<std::size_t>(n);
  const std::size_t levelCount = levels_.size();
  const std::span<const double> sizes(config_.cellSizes);

  // Level of insertion (eq. 2.3) and a stable grouping by level.
  level_.resize(un);
  levelCount_.assign(levelCount + 1, 0);
  for (Index i = 0; i < n; ++i) {
    const int h = hgrid::insertionLevel(sizes, spheres.radius[i], skin_) - 1;
    POLYDEM_ASSERT(h >= 0, "hgrid: a sphere larger than the top level (resolveConfig checks this)");
    level_[i] = static_cast<std::uint16_t>(h);
    ++levelCount_[static_cast<std::size_t>(h) + 1];
  }
  for (std::size_t h = 0; h < levelCount; ++h) levelCount_[h + 1] += levelCount_[h];
  for (std::size_t h = 0; h < levelCount; ++h) {
    levels_[h].begin = levelCount_[h];
    levels_[h].end = levelCount_[h + 1];
  }
  byLevel_.resize(un);
  for (Index i = 0; i < n; ++i) byLevel_[static_cast<std::size_t>(levelCount_[level_[i]]++)] = i;

  sorted_.resize(un);
  slotOf_.resize(un);
  homeKey_.resize(un);
  packed_.resize(4 * un);
  keyA_.resize(un);
  keyB_.resize(un);
  idxA_.resize(un);
  idxB_.resize(un);
  overflow_.clear();
  overflowPos_.assign(un, -1);
  overflowNext_.assign(un, -1);
  occupied_.clear();
  cellStart_.clear();
  table_.clear();
  bitmap_.clear();
  rank_.clear();
  cells_.clear();

  for (std::size_t h = 0; h < levelCount; ++h) {
    Level& lv = levels_[h];
    lv.dense = false;
    lv.ranked = false;
    lv.cellBegin = lv.cellEnd = cells_.size();
    lv.overflowSpheres = 0;
    if (lv.overflowUsed > 0) {
      std::fill(lv.overflowTable.begin(), lv.overflowTable.end(), OverflowEntry{kEmptyKey, -1});
      lv.overflowUsed = 0;
    }
    const Index count = lv.end - lv.begin;
    if (count == 0) continue;
    occupied_.push_back(static_cast<int>(h));
    const std::size_t b = static_cast<std::size_t>(lv.begin);
    const std::size_t m = static_cast<std::size_t>(count);
    for (std::size_t t = 0; t < m; ++t) {
      const Index i = byLevel_[b + t];
      keyA_[b + t] = keyOf(lv, spheres.centre.col(i).data());
      idxA_[b + t] = i;
    }
    const std::uint64_t cellCount = lv.nxy * static_cast<std::uint64_t>(lv.n[2]);
    lv.dense = denseCellLimit_ > 0.0 && static_cast<double>(cellCount) <= denseCellLimit_ * count + 64.0;
    const std::uint64_t* slotKey = nullptr;  // keys in slot order
    const Index* slotSphere = nullptr;       // spheres in slot order
    if (lv.dense) {
      // Counting sort by cell: cs[c] ends as the first slot of cell c, cs[cells] = end of the level.
      lv.denseOffset = cellStart_.size();
      cellStart_.resize(lv.denseOffset + cellCount + 1, 0);
      Index* cs = cellStart_.data() + lv.denseOffset;
      for (std::size_t t = 0; t < m; ++t) ++cs[keyA_[b + t]];
      Index running = lv.begin;
      for (std::uint64_t c = 0; c < cellCount; ++c) {
        running += cs[c];
        cs[c] = running;
      }
      cs[cellCount] = running;
      for (std::size_t t = m; t-- > 0;) {
        const Index slot = --cs[keyA_[b + t]];
        keyB_[static_cast<std::size_t>(slot)] = keyA_[b + t];
        idxB_[static_cast<std::size_t>(slot)] = idxA_[b + t];
      }
      slotKey = keyB_.data() + b;
      slotSphere = idxB_.data() + b;
    } else {
      const int bits = cellCount > 1 ? std::bit_width(cellCount - 1) : 0;
      const auto [k, v] = radixSort(keyA_.data() + b, idxA_.data() + b, keyB_.data() + b, idxB_.data() + b, m, bits);
      slotKey = k;
      slotSphere = v;
    }
    // Slots, packed copy and the occupied-cell list.
    for (std::size_t t = 0; t < m; ++t) {
      const Index i = slotSphere[t];
      const std::size_t slot = b + t;
      sorted_[slot] = i;
      slotOf_[static_cast<std::size_t>(i)] = static_cast<Index>(slot);
      homeKey_[static_cast<std::size_t>(i)] = slotKey[t];
      double* p = packed_.data() + 4 * slot;
      p[0] = spheres.centre(0, i);
      p[1] = spheres.centre(1, i);
      p[2] = spheres.centre(2, i);
      p[3] = spheres.radius[i];
      if (t == 0 || slotKey[t] != slotKey[t - 1]) {
        if (t > 0) cells_.back().end = static_cast<Index>(slot);
        const std::uint64_t key = slotKey[t];
        OccupiedCell cell;
        cell.key = key;
        cell.c[0] = static_cast<std::int32_t>(key % lv.nx);
        cell.c[1] = static_cast<std::int32_t>((key / lv.nx) % static_cast<std::uint64_t>(lv.n[1]));
        cell.c[2] = static_cast<std::int32_t>(key / lv.nxy);
        cell.begin = static_cast<Index>(slot);
        cell.end = lv.end;
        cells_.push_back(cell);
      }
    }
    lv.cellEnd = cells_.size();
    if (lv.dense) continue;
    const std::size_t occupiedCells = lv.cellEnd - lv.cellBegin;
    // Too sparse for a dense cell-start array but not too sparse: a "ranked" level. Look-ups stay
    // spatially coherent (unlike hashing), and empty cells cost a bit test.
    lv.ranked = rankedCellLimit_ > 0.0 && static_cast<double>(cellCount) <= rankedCellLimit_ * count + 4096.0;
    if (lv.ranked) {
      // Occupancy bitmap plus the number of occupied cells before each 64-cell word: the occupied cells
      // are sorted by key, so rank(key) indexes cells_ and the slots of a run of keys are contiguous.
      // One extra word makes rank(cell count) valid.
      const std::size_t words = static_cast<std::size_t>(cellCount / 64) + 1;
      lv.bitmapOffset = bitmap_.size();
      bitmap_.resize(lv.bitmapOffset + words, 0);
      rank_.resize(lv.bitmapOffset + words, 0);
      std::uint64_t* bits = bitmap_.data() + lv.bitmapOffset;
      std::uint32_t* rank = rank_.data() + lv.bitmapOffset;
      for (std::size_t c = lv.cellBegin; c < lv.cellEnd; ++c) {
        bits[cells_[c].key >> 6] |= std::uint64_t{1} << (cells_[c].key & 63);
      }
      std::uint32_t running = 0;
      for (std::size_t w = 0; w < words; ++w) {
        rank[w] = running;
        running += static_cast<std::uint32_t>(std::popcount(bits[w]));
      }
    } else {
      // Open addressing with linear probing, load <= 1/2; entries verify the full key.
      const std::size_t capacity = std::bit_ceil(std::max<std::size_t>(16, 2 * occupiedCells));
      lv.tableOffset = table_.size();
      lv.tableMask = capacity - 1;
      lv.tableShift = 64 - std::countr_zero(capacity);
      table_.resize(lv.tableOffset + capacity, HashEntry{kEmptyKey, 0, 0});
      HashEntry* table = table_.data() + lv.tableOffset;
      for (std::size_t c = lv.cellBegin; c < lv.cellEnd; ++c) {
        std::uint64_t at = (cells_[c].key * kGolden) >> lv.tableShift;
        while (table[at].key != kEmptyKey) at = (at + 1) & lv.tableMask;
        table[at] = {cells_[c].key, cells_[c].begin, cells_[c].end};
      }
    }
  }
  levelCounters_.assign(levelCount, Counters{});
}

// ---------------------------------------------------------------------------------------------------
// Look-ups

template <CrossLevel kMode>
[[gnu::always_inline]] inline Index HGrid<kMode>::startOf(const Level& lv, std::uint64_t key) const {
  // First slot of the first occupied cell with a key >= `key` (dense and ranked levels), key <= cells.
  if (lv.dense) return cellStart_[lv.denseOffset + key];
  const std::size_t w = lv.bitmapOffset + (key >> 6);
  const std::uint64_t below = bitmap_[w] & ((std::uint64_t{1} << (key & 63)) - 1);
  const std::size_t r = lv.cellBegin + rank_[w] + static_cast<std::size_t>(std::popcount(below));
  return r < lv.cellEnd ? cells_[r].begin : lv.end;
}

template <CrossLevel kMode>
[[gnu::always_inline]] inline typename HGrid<kMode>::SlotRange HGrid<kMode>::rangeOf(const Level& lv, std::uint64_t key) const {
  if (lv.dense) {
    const Index* cs = cellStart_.data() + lv.denseOffset + key;
    return {cs[0], cs[1]};
  }
  if (lv.ranked) {
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

template <CrossLevel kMode>
typename HGrid<kMode>::BoxCells HGrid<kMode>::boxOn(const Level& lv, const double* x, double beta) const {
  BoxCells b;
  for (int k = 0; k < 3; ++k) {
    b.lo[k] = static_cast<std::int64_t>(std::floor((x[k] - beta) * lv.inv[k] - hgrid::kBoxMargin));
    b.hi[k] = static_cast<std::int64_t>(std::floor((x[k] + beta) * lv.inv[k] + hgrid::kBoxMargin));
    const std::int64_t n = lv.n[k];
    if (periodic_[k]) {
      if (b.hi[k] - b.lo[k] + 1 >= n) {  // the box spans the axis: each cell once
        b.lo[k] = 0;
        b.hi[k] = n - 1;
      }
      // Otherwise the span is below n, so -n < lo and hi < 2n: one add or subtract wraps an index.
      b.wrap[k] = b.lo[k] < 0 || b.hi[k] >= n;
    } else {
      b.lo[k] = std::max<std::int64_t>(b.lo[k], 0);
      b.hi[k] = std::min<std::int64_t>(b.hi[k], n - 1);
      b.wrap[k] = false;
    }
  }
  b.rows = static_cast<std::uint64_t>(b.hi[1] - b.lo[1] + 1) * static_cast<std::uint64_t>(b.hi[2] - b.lo[2] + 1);
  b.cells = b.rows * static_cast<std::uint64_t>(b.hi[0] - b.lo[0] + 1);
  return b;
}

template <CrossLevel kMode>
bool HGrid<kMode>::inBox(const BoxCells& b, const Level& lv, const std::int32_t* c) {
  for (int k = 0; k < 3; ++k) {
    std::int64_t d = c[k] - b.lo[k];
    if (b.wrap[k]) {
      const std::int64_t n = lv.n[k];
      d = d < 0 ? d + n : (d >= n ? d - n : d);
    }
    if (d < 0 || d > b.hi[k] - b.lo[k]) return false;
  }
  return true;
}

template <CrossLevel kMode>
template <class Visit>
std::uint64_t HGrid<kMode>::forEachBoxRange(const Level& lv, const double* x, double beta, Visit&& visit) const {
  const BoxCells box = boxOn(lv, x, beta);
  const std::int64_t* lo = box.lo;
  const std::int64_t* hi = box.hi;
  const bool* wrap = box.wrap;
  const std::int64_t n0 = lv.n[0], n1 = lv.n[1], n2 = lv.n[2];
  const std::uint64_t cells = box.cells;

  // Sparse level (a Top-Down scan of a fine level holding few spheres): testing each occupied cell
  // against the box is cheaper than walking the box. Same cells, same candidates, same counts.
  const std::uint64_t occupiedCells = lv.cellEnd - lv.cellBegin;
  const std::uint64_t walkCost = lv.dense || lv.ranked ? 2 * box.rows + cells / 16 : 4 * cells;
  if (occupiedCells < walkCost) {
    for (std::size_t c = lv.cellBegin; c < lv.cellEnd; ++c) {
      const OccupiedCell& cell = cells_[c];
      if (inBox(box, lv, cell.c)) visit(cell.begin, cell.end);
    }
    return cells;
  }

  auto wrapped = [](std::int64_t c, std::int64_t n) { return c < 0 ? c + n : (c >= n ? c - n : c); };
  constexpr int kPending = 32;
  Index pending[kPending][2];
  int pendingCount = 0;
  auto flush = [&] {
    for (int r = 0; r < pendingCount; ++r) visit(pending[r][0], pending[r][1]);
    pendingCount = 0;
  };
  for (std::int64_t z = lo[2]; z <= hi[2]; ++z) {
    const std::int64_t zz = wrap[2] ? wrapped(z, n2) : z;
    for (std::int64_t y = lo[1]; y <= hi[1]; ++y) {
      const std::int64_t yy = wrap[1] ? wrapped(y, n1) : y;
      const std::uint64_t row = lv.nx * static_cast<std::uint64_t>(yy + n1 * zz);
      // The x-run [lo, hi] of the row, split in two where it wraps.
      std::int64_t runs[2][2];
      int runCount = 1;
      if (!wrap[0]) {
        runs[0][0] = lo[0];
        runs[0][1] = hi[0];
      } else if (lo[0] < 0) {
        runs[0][0] = lo[0] + n0;
        runs[0][1] = n0 - 1;
        runs[1][0] = 0;
        runs[1][1] = hi[0];
        runCount = 2;
      } else {
        runs[0][0] = lo[0];
        runs[0][1] = n0 - 1;
        runs[1][0] = 0;
        runs[1][1] = hi[0] - n0;
        runCount = 2;
      }
      for (int r = 0; r < runCount; ++r) {
        const std::uint64_t k0 = row + static_cast<std::uint64_t>(runs[r][0]);
        const std::uint64_t k1 = row + static_cast<std::uint64_t>(runs[r][1]);
        if (lv.dense || lv.ranked) {
          // Cells are sorted by key, so a run of cells along x is a contiguous run of slots. The
          // slot ranges are gathered first and their spheres prefetched: the look-ups of different
          // rows are independent, so their cache misses overlap instead of queueing behind the tests.
          const Index b = startOf(lv, k0), e = startOf(lv, k1 + 1);
          if (b < e) {
            __builtin_prefetch(packed_.data() + 4 * static_cast<std::size_t>(b));
            pending[pendingCount][0] = b;
            pending[pendingCount][1] = e;
            if (++pendingCount == kPending) flush();
          }
        } else {
          for (std::uint64_t key = k0; key <= k1; ++key) {
            const auto [b, e] = rangeOf(lv, key);
            if (b < e) visit(b, e);
          }
        }
      }
    }
  }
  flush();
  return cells;
}

template <CrossLevel kMode>
Index HGrid<kMode>::overflowHead(const Level& lv, std::uint64_t key) const {
  if (lv.overflowTable.empty()) return -1;
  const std::uint64_t mask = lv.overflowTable.size() - 1;
  const int shift = 64 - std::countr_zero(lv.overflowTable.size());
  for (std::uint64_t at = (key * kGolden) >> shift;; at = (at + 1) & mask) {
    const OverflowEntry& e = lv.overflowTable[at];
    if (e.key == key) return e.head;
    if (e.key == kEmptyKey) return -1;
  }
}

template <CrossLevel kMode>
Index* HGrid<kMode>::overflowHeadSlot(Level& lv, std::uint64_t key) {
  if (2 * (lv.overflowUsed + 1) > lv.overflowTable.size()) {
    // Grow (rare; amortised O(1)), dropping keys whose lists have emptied.
    std::vector<OverflowEntry> old;
    old.swap(lv.overflowTable);
    std::size_t live = 0;
    for (const OverflowEntry& e : old) live += e.key != kEmptyKey && e.head >= 0;
    lv.overflowTable.assign(std::bit_ceil(std::max<std::size_t>(16, 4 * (live + 1))), OverflowEntry{kEmptyKey, -1});
    lv.overflowUsed = 0;
    const std::uint64_t mask = lv.overflowTable.size() - 1;
    const int shift = 64 - std::countr_zero(lv.overflowTable.size());
    for (const OverflowEntry& e : old) {
      if (e.key == kEmptyKey || e.head < 0) continue;
      std::uint64_t at = (e.key * kGolden) >> shift;
      while (lv.overflowTable[at].key != kEmptyKey) at = (at + 1) & mask;
      lv.overflowTable[at] = e;
      ++lv.overflowUsed;
    }
  }
  const std::uint64_t mask = lv.overflowTable.size() - 1;
  const int shift = 64 - std::countr_zero(lv.overflowTable.size());
  std::uint64_t at = (key * kGolden) >> shift;
  for (;; at = (at + 1) & mask) {
    OverflowEntry& e = lv.overflowTable[at];
    if (e.key == key) return &e.head;
    if (e.key == kEmptyKey) break;
  }
  lv.overflowTable[at] = {key, -1};
  ++lv.overflowUsed;
  return &lv.overflowTable[at].head;
}

template <CrossLevel kMode>
template <class Visit>
void HGrid<kMode>::forEachOverflowInBox(const Level& lv, const double* x, double beta, Visit&& visit) const {
  if (lv.overflowSpheres == 0) return;
  const BoxCells box = boxOn(lv, x, beta);
  if (box.cells > 4 * lv.overflowSpheres) {
    // Few overflow spheres on this level: test each against the box rather than probing every cell.
    for (const OverflowRecord& rec : overflow_) {
      if (&levels_[level_[static_cast<std::size_t>(rec.sphere)]] != &lv) continue;
      const std::int32_t c[3] = {static_cast<std::int32_t>(rec.key % lv.nx),
                                 static_cast<std::int32_t>((rec.key / lv.nx) % static_cast<std::uint64_t>(lv.n[1])),
                                 static_cast<std::int32_t>(rec.key / lv.nxy)};
      if (inBox(box, lv, c)) visit(rec.sphere, rec.xyzr);
    }
    return;
  }
  auto wrapped = [](std::int64_t c, std::int64_t n) { return c < 0 ? c + n : (c >= n ? c - n : c); };
  for (std::int64_t z = box.lo[2]; z <= box.hi[2]; ++z) {
    for (std::int64_t y = box.lo[1]; y <= box.hi[1]; ++y) {
      for (std::int64_t xc = box.lo[0]; xc <= box.hi[0]; ++xc) {
        const std::uint64_t key = static_cast<std::uint64_t>(wrapped(xc, lv.n[0])) +
                                  lv.nx * static_cast<std::uint64_t>(wrapped(y, lv.n[1])) +
                                  lv.nxy * static_cast<std::uint64_t>(wrapped(z, lv.n[2]));
        for (Index q = overflowHead(lv, key); q >= 0; q = overflowNext_[static_cast<std::size_t>(q)]) {
          visit(q, overflow_[static_cast<std::size_t>(overflowPos_[static_cast<std::size_t>(q)])].xyzr);
        }
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------------
// Pair search

template <CrossLevel kMode>
template <bool kCount>
void HGrid<kMode>::sameLevel(int h, std::vector<Pair>& out) const {
  const Level& lv = levels_[static_cast<std::size_t>(h)];
  const double* p = packed_.data();
  const Index* sorted = sorted_.data();
  std::uint64_t tests = 0, accesses = 0;

  auto crossCells = [&](Index a0, Index a1, Index b0, Index b1) {
    for (Index s = a0; s < a1; ++s) {
      const double* ps = p + 4 * s;
      for (Index t = b0; t < b1; ++t) {
        const double* pt = p + 4 * t;
        if (spheresWithinReach(box_, ps, ps[3], pt, pt[3], skin_)) emit(out, sorted[s], sorted[t]);
      }
    }
  };

  std::array<std::uint64_t, 27> block{};
  for (std::size_t c = lv.cellBegin; c < lv.cellEnd; ++c) {
    const OccupiedCell& cell = cells_[c];
    const Index a0 = cell.begin, a1 = cell.end;
    const std::uint64_t m = static_cast<std::uint64_t>(a1 - a0);
    // Own cell: each pair once (later slots only).
    for (Index s = a0; s < a1; ++s) {
      const double* ps = p + 4 * s;
      for (Index t = s + 1; t < a1; ++t) {
        const double* pt = p + 4 * t;
        if (spheresWithinReach(box_, ps, ps[3], pt, pt[3], skin_)) emit(out, sorted[s], sorted[t]);
      }
    }
    if constexpr (kCount) {
      accesses += m;  // T_ca1: each sphere reads its cell
      tests += m * (m - 1) / 2;
    }
    if (lv.aliased) {
      // A periodic axis with <= 2 cells: forward and backward neighbours alias, so visit each distinct
      // cell of the 3x3x3 block with a larger key once.
      int count = 0;
      for (int dz = -1; dz <= 1; ++dz) {
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            const int d[3] = {dx, dy, dz};
            std::int64_t q[3];
            bool inside = true;
            for (int k = 0; k < 3; ++k) {
              q[k] = cell.c[k] + d[k];
              if (q[k] < 0 || q[k] >= lv.n[k]) {
                if (periodic_[k]) {
                  q[k] = q[k] < 0 ? q[k] + lv.n[k] : q[k] - lv.n[k];
                } else {
                  inside = false;
                }
              }
            }
            if (inside) {
              block[count++] = static_cast<std::uint64_t>(q[0]) + lv.nx * static_cast<std::uint64_t>(q[1]) +
                               lv.nxy * static_cast<std::uint64_t>(q[2]);
            }
          }
        }
      }
      std::sort(block.begin(), block.begin() + count);
      count = static_cast<int>(std::unique(block.begin(), block.begin() + count) - block.begin());
      for (int k = 0; k < count; ++k) {
        const std::uint64_t key = block[k];
        if (key <= cell.key) continue;
        const auto [b0, b1] = rangeOf(lv, key);
        if constexpr (kCount) {
          accesses += m;
          tests += m * static_cast<std::uint64_t>(b1 - b0);
        }
        crossCells(a0, a1, b0, b1);
      }
      continue;
    }
    const bool interior = cell.c[0] >= 1 && cell.c[0] <= lv.n[0] - 2 && cell.c[1] >= 1 && cell.c[1] <= lv.n[1] - 2 &&
                          cell.c[2] >= 1 && cell.c[2] <= lv.n[2] - 2;
    for (int o = 0; o < 13; ++o) {
      std::uint64_t key;
      if (interior) {
        key = cell.key + static_cast<std::uint64_t>(lv.shellDelta[o]);
      } else {
        std::int64_t q[3];
        bool inside = true;
        for (int k = 0; k < 3; ++k) {
          q[k] = cell.c[k] + kHalfShell[o][k];
          if (q[k] < 0 || q[k] >= lv.n[k]) {
            if (periodic_[k]) {
              q[k] = q[k] < 0 ? q[k] + lv.n[k] : q[k] - lv.n[k];  // n >= 3 here
            } else {
              inside = false;  // behind a wall: the cell does not exist
            }
          }
        }
        if (!inside) continue;
        key = static_cast<std::uint64_t>(q[0]) + lv.nx * static_cast<std::uint64_t>(q[1]) +
              lv.nxy * static_cast<std::uint64_t>(q[2]);
      }
      const auto [b0, b1] = rangeOf(lv, key);
      if constexpr (kCount) {
        accesses += m;  // T_ca2: every sphere looks the neighbour up, even when it is empty
        tests += m * static_cast<std::uint64_t>(b1 - b0);
      }
      if (b0 < b1) crossCells(a0, a1, b0, b1);
    }
  }
  if constexpr (kCount) {
    levelCounters_[static_cast<std::size_t>(h)].pairTests += tests;
    levelCounters_[static_cast<std::size_t>(h)].cellAccesses += accesses;
  }
}

template <CrossLevel kMode>
template <bool kCount, bool kAabb>
void HGrid<kMode>::crossLevel(int h, int j, std::vector<Pair>& out) const {
  const Level& from = levels_[static_cast<std::size_t>(h)];
  const Level& to = levels_[static_cast<std::size_t>(j)];
  const double* p = packed_.data();
  const Index* sorted = sorted_.data();
  const double halfBase = 0.5 * skin_ + 0.5 * to.nominal;  // beta = r_p + skin/2 + s_j/2
  const double skin = skin_;
  std::uint64_t tests = 0, accesses = 0;
  for (Index s = from.begin; s < from.end; ++s) {
    const Index ip = sorted[s];
    if (ip < 0) continue;  // tombstone: the sphere is in the overflow
    const double* ps = p + 4 * s;
    const double rp = ps[3];
    const std::uint64_t cells = forEachBoxRange(to, ps, rp + halfBase, [&](Index b0, Index b1) {
      if constexpr (kCount) tests += static_cast<std::uint64_t>(b1 - b0);
      for (Index t = b0; t < b1; ++t) {
        const double* pt = p + 4 * t;
        if constexpr (kAabb) {
          // AABB pre-check (seed :1046-1054), made conservative by 1e-12 so that it never rejects a
          // pair the exact test accepts; tombstones (NaN) fall through to the exact test, which rejects
          // them.
          const double reach = ((rp + pt[3]) + skin) * (1.0 + 1e-12);
          bool apart = false;
          for (int k = 0; k < 3; ++k) {
            double d = ps[k] - pt[k];
            if (periodic_[k]) {
              if (d > halfLength_[k]) {
                d -= length_[k];
              } else if (d < -halfLength_[k]) {
                d += length_[k];
              }
            }
            apart |= std::abs(d) > reach;
          }
          if (apart) continue;
        }
        if (spheresWithinReach(box_, ps, rp, pt, pt[3], skin)) emit(out, ip, sorted[t]);
      }
    });
    if constexpr (kCount) accesses += cells;
  }
  if constexpr (kCount) {
    levelCounters_[static_cast<std::size_t>(h)].pairTests += tests;
    levelCounters_[static_cast<std::size_t>(h)].cellAccesses += accesses;
  }
}

template <CrossLevel kMode>
template <bool kCount>
void HGrid<kMode>::overflowPairs(std::vector<Pair>& out) const {
  // Each overflow sphere searches every level, home spheres and other overflow spheres with a larger
  // index, so each of its pairs is found once; home spheres never see the overflow (tombstones).
  const double* p = packed_.data();
  for (const OverflowRecord& rec : overflow_) {
    const Index io = rec.sphere;
    const double* xo = rec.xyzr;
    const double ro = xo[3];
    std::uint64_t tests = 0, accesses = 0;
    for (int j : occupied_) {
      const Level& lv = levels_[static_cast<std::size_t>(j)];
      const double beta = ro + 0.5 * skin_ + 0.5 * lv.nominal;
      accesses += forEachBoxRange(lv, xo, beta, [&](Index b0, Index b1) {
        if constexpr (kCount) tests += static_cast<std::uint64_t>(b1 - b0);
        for (Index t = b0; t < b1; ++t) {
          const double* pt = p + 4 * t;
          if (spheresWithinReach(box_, xo, ro, pt, pt[3], skin_)) emit(out, io, sorted_[static_cast<std::size_t>(t)]);
        }
      });
      forEachOverflowInBox(lv, xo, beta, [&](Index q, const double* xq) {
        if (q <= io) return;
        if constexpr (kCount) ++tests;
        if (spheresWithinReach(box_, xo, ro, xq, xq[3], skin_)) emit(out, io, q);
      });
    }
    if constexpr (kCount) {
      Counters& c = levelCounters_[level_[static_cast<std::size_t>(io)]];
      c.pairTests += tests;
      c.cellAccesses += accesses;
    }
  }
}

template <CrossLevel kMode>
template <bool kCount>
void HGrid<kMode>::pairsImpl(std::vector<Pair>& out) const {
  if constexpr (kCount) levelCounters_.assign(levels_.size(), Counters{});
  for (int h : occupied_) sameLevel<kCount>(h, out);
  for (int h : occupied_) {
    for (int j : occupied_) {
      const bool searched = kMode == CrossLevel::TopDown ? j < h : j > h;
      if (!searched) continue;
      if (aabbPrecheck_) {
        crossLevel<kCount, true>(h, j, out);
      } else {
        crossLevel<kCount, false>(h, j, out);
      }
    }
  }
  if (!overflow_.empty()) overflowPairs<kCount>(out);
  if constexpr (kCount) {
    for (const Counters& c : levelCounters_) {
      counters_.pairTests += c.pairTests;
      counters_.cellAccesses += c.cellAccesses;
    }
  }
}

template <CrossLevel kMode>
void HGrid<kMode>::findPairs(const SphereView&, std::vector<Pair>& out) const {
  out.clear();
  if (counting_) {
    pairsImpl<true>(out);
  } else {
    pairsImpl<false>(out);
  }
}

template <CrossLevel kMode>
void HGrid<kMode>::findNeighbours(const SphereView& spheres, Index i, double reach, std::vector<Index>& out) const {
  out.clear();
  if (!(reach >= 0.0 && reach <= skin_)) {
    throw ConfigError(fmt::format("findNeighbours: reach {} must lie in [0, skin = {}]", reach, skin_));
  }
  if (i < 0 || i >= static_cast<Index>(slotOf_.size())) {
    throw ConfigError(fmt::format("findNeighbours: particle {} out of range [0, {})", i, slotOf_.size()));
  }
  const double* xi = spheres.centre.col(i).data();
  const double ri = spheres.radius[i];
  const double* p = packed_.data();
  for (int j : occupied_) {
    const Level& lv = levels_[static_cast<std::size_t>(j)];
    // A partner q on level j has r_q <= (s_j - skin) / 2, so |d| <= r_i + reach + (s_j - skin) / 2.
    const double beta = ri + 0.5 * lv.nominal + (reach - 0.5 * skin_);
    forEachBoxRange(lv, xi, beta, [&](Index b0, Index b1) {
      for (Index t = b0; t < b1; ++t) {
        const Index q = sorted_[static_cast<std::size_t>(t)];
        const double* pt = p + 4 * t;
        if (q != i && spheresWithinReach(box_, xi, ri, pt, pt[3], reach)) out.push_back(q);
      }
    });
    forEachOverflowInBox(lv, xi, beta, [&](Index q, const double* xq) {
      if (q != i && spheresWithinReach(box_, xi, ri, xq, xq[3], reach)) out.push_back(q);
    });
  }
  std::sort(out.begin(), out.end());
}

// ---------------------------------------------------------------------------------------------------
// Incremental update

template <CrossLevel kMode>
void HGrid<kMode>::overflowInsert(Level& lv, Index sphere, std::uint64_t key, const double* x, double r) {
  const std::size_t us = static_cast<std::size_t>(sphere);
  overflowPos_[us] = static_cast<Index>(overflow_.size());
  overflow_.push_back(OverflowRecord{sphere, key, {x[0], x[1], x[2], r}});
  Index* head = overflowHeadSlot(lv, key);
  overflowNext_[us] = *head;
  *head = sphere;
  ++lv.overflowSpheres;
}

template <CrossLevel kMode>
void HGrid<kMode>::overflowRemove(Level& lv, Index sphere) {
  const std::size_t us = static_cast<std::size_t>(sphere);
  const std::size_t pos = static_cast<std::size_t>(overflowPos_[us]);
  Index* link = overflowHeadSlot(lv, overflow_[pos].key);
  while (*link != sphere) link = &overflowNext_[static_cast<std::size_t>(*link)];
  *link = overflowNext_[us];
  overflowNext_[us] = -1;
  if (pos + 1 != overflow_.size()) {
    overflow_[pos] = overflow_.back();
    overflowPos_[static_cast<std::size_t>(overflow_[pos].sphere)] = static_cast<Index>(pos);
  }
  overflow_.pop_back();
  overflowPos_[us] = -1;
  --lv.overflowSpheres;
}

template <CrossLevel kMode>
void HGrid<kMode>::doUpdate(const SphereView& spheres, std::span<const Index> moved) {
  const Index n = spheres.count();
  if (n != static_cast<Index>(slotOf_.size())) {
    throw ConfigError(fmt::format("hgrid update: {} spheres, but the index was built for {}: call build()", n,
                                  slotOf_.size()));
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (Index i : moved) {
    if (i < 0 || i >= n) throw ConfigError(fmt::format("hgrid update: particle {} out of range [0, {})", i, n));
    const Eigen::Vector3d x = spheres.centre.col(i);
    if (!box_.contains(x)) {
      throw ConfigError(fmt::format("hgrid update: particle {}: centre ({}, {}, {}) outside the box {}", i, x[0], x[1],
                                    x[2], box_.describe()));
    }
    const std::size_t ui = static_cast<std::size_t>(i);
    Level& lv = levels_[level_[ui]];
    const std::uint64_t key = keyOf(lv, x.data());
    double* home = packed_.data() + 4 * static_cast<std::size_t>(slotOf_[ui]);
    if (overflowPos_[ui] < 0) {
      if (key == homeKey_[ui]) {
        home[0] = x[0];
        home[1] = x[1];
        home[2] = x[2];
        continue;
      }
      sorted_[static_cast<std::size_t>(slotOf_[ui])] = -1;  // tombstone: no pair test ever passes NaN
      home[0] = home[1] = home[2] = nan;
      overflowInsert(lv, i, key, x.data(), spheres.radius[i]);
    } else {
      OverflowRecord& rec = overflow_[static_cast<std::size_t>(overflowPos_[ui])];
      if (key == rec.key) {
        rec.xyzr[0] = x[0];
        rec.xyzr[1] = x[1];
        rec.xyzr[2] = x[2];
        continue;
      }
      overflowRemove(lv, i);
      if (key == homeKey_[ui]) {  // back home: revive the slot
        sorted_[static_cast<std::size_t>(slotOf_[ui])] = i;
        home[0] = x[0];
        home[1] = x[1];
        home[2] = x[2];
      } else {
        overflowInsert(lv, i, key, x.data(), spheres.radius[i]);
      }
    }
  }
  if (overflow_.size() > std::max<std::size_t>(64, static_cast<std::size_t>(n) / 8)) index(spheres);
}

// ---------------------------------------------------------------------------------------------------
// Reports

template <CrossLevel kMode>
typename HGrid<kMode>::LevelInfo HGrid<kMode>::levelInfo(int h) const {
  if (h < 1 || h > levelCount()) {
    throw ConfigError(fmt::format("hgrid levelInfo: level {} out of range [1, {}]", h, levelCount()));
  }
  const Level& lv = levels_[static_cast<std::size_t>(h - 1)];
  LevelInfo info;
  info.nominalSize = lv.nominal;
  info.cellSize = Eigen::Vector3d(lv.size[0], lv.size[1], lv.size[2]);
  info.cells = lv.n;
  info.spheres = lv.end - lv.begin;
  info.occupiedCells = static_cast<Index>(lv.cellEnd - lv.cellBegin);
  info.storage = lv.end == lv.begin ? '-' : (lv.dense ? 'd' : (lv.ranked ? 'r' : 'h'));
  return info;
}

template <CrossLevel kMode>
std::size_t HGrid<kMode>::memoryBytes() const {
  std::size_t bytes = levels_.capacity() * sizeof(Level) + occupied_.capacity() * sizeof(int) +
                      cellStart_.capacity() * sizeof(Index) + table_.capacity() * sizeof(HashEntry) +
                      bitmap_.capacity() * sizeof(std::uint64_t) + rank_.capacity() * sizeof(std::uint32_t) +
                      cells_.capacity() * sizeof(OccupiedCell) + sorted_.capacity() * sizeof(Index) +
                      packed_.capacity() * sizeof(double) + slotOf_.capacity() * sizeof(Index) +
                      level_.capacity() * sizeof(std::uint16_t) + homeKey_.capacity() * sizeof(std::uint64_t) +
                      overflow_.capacity() * sizeof(OverflowRecord) + overflowPos_.capacity() * sizeof(Index) +
                      overflowNext_.capacity() * sizeof(Index) + levelCount_.capacity() * sizeof(Index) +
                      byLevel_.capacity() * sizeof(Index) +
                      (keyA_.capacity() + keyB_.capacity()) * sizeof(std::uint64_t) +
                      (idxA_.capacity() + idxB_.capacity()) * sizeof(Index) +
                      levelCounters_.capacity() * sizeof(Counters);
  for (const Level& lv : levels_) bytes += lv.overflowTable.capacity() * sizeof(OverflowEntry);
  return bytes;
}

template <CrossLevel kMode>
std::string HGrid<kMode>::describe() const {
  if (levels_.empty()) return fmt::format("{} (not built)", name());
  std::string nominal, snapped, occupancy;
  for (std::size_t h = 0; h < levels_.size(); ++h) {
    const Level& lv = levels_[h];
    const char* sep = h == 0 ? "" : ",";
    nominal += fmt::format("{}{:.6g}", sep, lv.nominal);
    if (lv.size[0] == lv.size[1] && lv.size[1] == lv.size[2]) {
      snapped += fmt::format("{}{:.6g}", sep, lv.size[0]);
    } else {
      snapped += fmt::format("{}{:.6g}x{:.6g}x{:.6g}", sep, lv.size[0], lv.size[1], lv.size[2]);
    }
    occupancy += fmt::format("{}{}{}", sep, lv.end - lv.begin,
                             lv.end == lv.begin ? "" : (lv.dense ? "d" : (lv.ranked ? "r" : "h")));
  }
  std::string text = fmt::format("{} L={} sizes {} (snapped {}); spheres per level {} (d = dense, r = ranked bitmap, h = hashed); {}",
                                 name(), levels_.size(), nominal, snapped, occupancy, config_.origin);
  if (!note_.empty()) text += "; " + note_;
  if (!overflow_.empty()) text += fmt::format("; {} spheres in the overflow", overflow_.size());
  return text;
}

template <CrossLevel kMode>
void HGrid<kMode>::validate(const SphereView& spheres) const {
  auto fail = [&](const std::string& what) { throw std::logic_error(fmt::format("{}: {}", name(), what)); };
  const Index n = spheres.count();
  const std::size_t un = static_cast<std::size_t>(n);
  if (slotOf_.size() != un || sorted_.size() != un || packed_.size() != 4 * un) fail("storage size differs from N");
  if (levels_.size() != config_.cellSizes.size()) fail("level count differs from the configuration");
  const std::span<const double> sizes(config_.cellSizes);
  for (Index i = 0; i < n; ++i) {
    const std::size_t ui = static_cast<std::size_t>(i);
    if (level_[ui] + 1 != hgrid::insertionLevel(sizes, spheres.radius[i], skin_)) {
      fail(fmt::format("particle {} on the wrong level", i));
    }
    const Level& lv = levels_[level_[ui]];
    const Index slot = slotOf_[ui];
    if (slot < lv.begin || slot >= lv.end) fail(fmt::format("particle {}: home slot outside its level", i));
    const std::uint64_t key = keyOf(lv, spheres.centre.col(i).data());
    const double* pk = packed_.data() + 4 * static_cast<std::size_t>(slot);
    if (pk[3] != spheres.radius[i]) fail(fmt::format("particle {}: packed radius is stale", i));
    if (overflowPos_[ui] < 0) {
      if (sorted_[static_cast<std::size_t>(slot)] != i) fail(fmt::format("particle {}: slot is stale", i));
      if (homeKey_[ui] != key) fail(fmt::format("particle {} stored in the wrong cell", i));
      for (int k = 0; k < 3; ++k) {
        if (pk[k] != spheres.centre(k, i)) fail(fmt::format("particle {}: packed centre is stale", i));
      }
    } else {
      if (sorted_[static_cast<std::size_t>(slot)] != -1) fail(fmt::format("particle {}: no tombstone", i));
      const OverflowRecord& rec = overflow_[static_cast<std::size_t>(overflowPos_[ui])];
      if (rec.sphere != i || rec.key != key) fail(fmt::format("particle {}: stale overflow record", i));
      bool listed = false;
      for (Index q = overflowHead(lv, key); q >= 0; q = overflowNext_[static_cast<std::size_t>(q)]) listed |= q == i;
      if (!listed) fail(fmt::format("particle {}: not in its overflow cell list", i));
      for (int k = 0; k < 4; ++k) {
        if (rec.xyzr[k] != (k < 3 ? spheres.centre(k, i) : spheres.radius[i])) {
          fail(fmt::format("particle {}: overflow copy is stale", i));
        }
      }
    }
  }
  std::size_t overflowTotal = 0;
  for (std::size_t h = 0; h < levels_.size(); ++h) {
    const Level& lv = levels_[h];
    overflowTotal += lv.overflowSpheres;
    Index expected = lv.begin;
    std::size_t hashed = 0;
    for (std::size_t c = lv.cellBegin; c < lv.cellEnd; ++c) {
      const OccupiedCell& cell = cells_[c];
      if (cell.begin != expected || cell.end <= cell.begin) fail(fmt::format("level {}: cell ranges not contiguous", h + 1));
      expected = cell.end;
      if (cell.key != static_cast<std::uint64_t>(cell.c[0]) + lv.nx * static_cast<std::uint64_t>(cell.c[1]) +
                          lv.nxy * static_cast<std::uint64_t>(cell.c[2])) {
        fail(fmt::format("level {}: cell coordinates disagree with the key", h + 1));
      }
      if (c > lv.cellBegin && !(cells_[c - 1].key < cell.key)) fail(fmt::format("level {}: cells not sorted", h + 1));
      for (Index s = cell.begin; s < cell.end; ++s) {
        const Index i = sorted_[static_cast<std::size_t>(s)];
        if (i >= 0 && homeKey_[static_cast<std::size_t>(i)] != cell.key) {
          fail(fmt::format("level {}: slot {} in the wrong cell range", h + 1, s));
        }
      }
      const auto [b, e] = rangeOf(lv, cell.key);
      if (b != cell.begin || e != cell.end) fail(fmt::format("level {}: look-up of cell {} is wrong", h + 1, cell.key));
      ++hashed;
    }
    if (expected != lv.end && lv.cellEnd > lv.cellBegin) fail(fmt::format("level {}: cells miss slots", h + 1));
    if (lv.ranked) {
      const std::uint64_t words = lv.nxy * static_cast<std::uint64_t>(lv.n[2]) / 64 + 1;
      std::size_t set = 0;
      for (std::uint64_t w = 0; w < words; ++w) {
        if (rank_[lv.bitmapOffset + w] != set) fail(fmt::format("level {}: rank directory is wrong", h + 1));
        set += static_cast<std::size_t>(std::popcount(bitmap_[lv.bitmapOffset + w]));
      }
      if (set != hashed) fail(fmt::format("level {}: bitmap holds {} cells, expected {}", h + 1, set, hashed));
    } else if (!lv.dense && lv.end > lv.begin) {
      std::size_t entries = 0;
      const std::size_t capacity = lv.tableMask + 1;
      for (std::size_t t = 0; t < capacity; ++t) entries += table_[lv.tableOffset + t].key != kEmptyKey;
      if (entries != hashed) fail(fmt::format("level {}: hash table holds {} cells, expected {}", h + 1, entries, hashed));
    }
  }
  if (overflowTotal != overflow_.size()) fail("overflow counts per level do not add up");
}

template class HGrid<CrossLevel::TopDown>;
template class HGrid<CrossLevel::BottomUp>;

}  // namespace polydem::broadphase
