// Cell storage of the hierarchical grid; see hgrid_storage.hpp.
#include "broadphase/hgrid_storage.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <utility>

#include "broadphase/parallel.hpp"

namespace polydem::broadphase::hgrid {

namespace {

// LSD radix sort of (key, value) by key, keys < 2^bits, 11-bit digits; stable, each pass a stable
// counting sort (threaded over parts of the items, the same result for any thread count). Returns the
// buffers holding the result (the inputs or the scratch ones).
std::pair<std::uint64_t*, Index*> radixSort(std::uint64_t* key, Index* val, std::uint64_t* keyTmp, Index* valTmp,
                                            std::size_t n, int bits, int threads, std::vector<Index>& scratch) {
  constexpr int kDigit = 11;
  constexpr std::size_t kBuckets = std::size_t{1} << kDigit;
  std::array<Index, kBuckets + 1> start;
  for (int shift = 0; shift < bits; shift += kDigit) {
    const std::uint64_t* k = key;
    const Index* v = val;
    std::uint64_t* kt = keyTmp;
    Index* vt = valTmp;
    parallel::stableCountingSort(
        threads, n, kBuckets, 0, [&](std::size_t i) { return (k[i] >> shift) & (kBuckets - 1); }, start.data(), scratch,
        [&](std::size_t i, Index pos) {
          kt[pos] = k[i];
          vt[pos] = v[i];
        });
    std::swap(key, keyTmp);
    std::swap(val, valTmp);
  }
  return {key, val};
}

}  // namespace

char storageLetter(CellStorage kind) {
  switch (kind) {
    case CellStorage::Dense:
      return 'd';
    case CellStorage::Ranked:
      return 'r';
    case CellStorage::Hashed:
      return 'h';
    case CellStorage::Empty:
      break;
  }
  return '-';
}

void CellStore::reset(std::size_t sphereCount) {
  keyA_.resize(sphereCount);
  keyB_.resize(sphereCount);
  idxA_.resize(sphereCount);
  idxB_.resize(sphereCount);
  cellStart_.clear();
  table_.clear();
  bitmap_.clear();
  rank_.clear();
  cells_.clear();
}

CellStore::Sorted CellStore::sortLevel(LevelCells& lv, std::uint64_t cellCount) {
  const Index count = lv.end - lv.begin;
  const std::size_t b = static_cast<std::size_t>(lv.begin);
  const std::size_t m = static_cast<std::size_t>(count);
  const double cells = static_cast<double>(cellCount);
  if (denseLimit_ > 0.0 && cells <= denseLimit_ * count + 64.0) {
    lv.kind = CellStorage::Dense;
    // Counting sort by cell: cs[c] = the first slot of cell c, cs[cells] = end of the level.
    lv.denseOffset = cellStart_.size();
    cellStart_.resize(lv.denseOffset + cellCount + 1, 0);
    Index* cs = cellStart_.data() + lv.denseOffset;
    const std::uint64_t* key = keyA_.data() + b;
    const Index* idx = idxA_.data() + b;
    parallel::stableCountingSort(
        threads_, m, static_cast<std::size_t>(cellCount), lv.begin, [&](std::size_t t) { return key[t]; }, cs,
        histogram_,
        [&](std::size_t t, Index slot) {
          keyB_[static_cast<std::size_t>(slot)] = key[t];
          idxB_[static_cast<std::size_t>(slot)] = idx[t];
        });
    return {keyB_.data() + b, idxB_.data() + b};
  }
  // Too sparse for a dense cell-start array but not too sparse: a "ranked" level.
  lv.kind = rankedLimit_ > 0.0 && cells <= rankedLimit_ * count + 4096.0 ? CellStorage::Ranked : CellStorage::Hashed;
  const int bits = cellCount > 1 ? std::bit_width(cellCount - 1) : 0;
  const auto [k, v] =
      radixSort(keyA_.data() + b, idxA_.data() + b, keyB_.data() + b, idxB_.data() + b, m, bits, threads_, histogram_);
  return {k, v};
}

CellStore::Sorted CellStore::addLevel(LevelCells& lv, const std::array<int, 3>& n, std::uint64_t nx,
                                      std::uint64_t nxy) {
  const std::uint64_t cellCount = nxy * static_cast<std::uint64_t>(n[2]);
  const Sorted sorted = sortLevel(lv, cellCount);
  listCells(lv, sorted, n, nx, nxy);
  if (lv.kind != CellStorage::Dense) buildSparseMap(lv, cellCount);
  return sorted;
}

void CellStore::reserveCells(std::size_t count) {
  // An eighth of headroom, not the vector's doubling (up to twice the cells held for the life of the run);
  // rebuilds whose count stays within it do not allocate.
  if (count > cells_.capacity()) cells_.reserve(count + count / 8);
}

void CellStore::listCells(LevelCells& lv, const Sorted& sorted, const std::array<int, 3>& n, std::uint64_t nx,
                          std::uint64_t nxy) {
  const std::size_t b = static_cast<std::size_t>(lv.begin);
  const std::size_t m = static_cast<std::size_t>(lv.end - lv.begin);
  const std::uint64_t* key = sorted.key;
  auto opens = [&](std::size_t t) { return t == 0 || key[t] != key[t - 1]; };
  // Coordinates from the key by two divisions, in 32 bits where the level's keys fit (a 64-bit division
  // took over half of this function's time).
  const bool narrow = nxy * static_cast<std::uint64_t>(n[2]) <= std::uint64_t{0xffffffff};
  auto cellAt = [&](std::size_t t) {
    OccupiedCell cell;
    cell.key = key[t];
    std::uint64_t z, y, x;
    if (narrow) {
      const auto k32 = static_cast<std::uint32_t>(key[t]);
      const std::uint32_t zz = k32 / static_cast<std::uint32_t>(nxy);
      const std::uint32_t rest = k32 - zz * static_cast<std::uint32_t>(nxy);
      const std::uint32_t yy = rest / static_cast<std::uint32_t>(nx);
      z = zz;
      y = yy;
      x = rest - yy * static_cast<std::uint32_t>(nx);
    } else {
      z = key[t] / nxy;
      const std::uint64_t rest = key[t] - z * nxy;
      y = rest / nx;
      x = rest - y * nx;
    }
    cell.c[0] = static_cast<std::int32_t>(x);
    cell.c[1] = static_cast<std::int32_t>(y);
    cell.c[2] = static_cast<std::int32_t>(z);
    cell.begin = static_cast<Index>(b + t);
    cell.end = lv.end;
    return cell;
  };
  lv.cellBegin = cells_.size();
  const std::size_t parts = parallel::chunkCount(threads_, m);
  if (parts == 1) {
    std::size_t opened = 0;
    for (std::size_t t = 0; t < m; ++t) opened += opens(t) ? 1 : 0;
    reserveCells(cells_.size() + opened);
    for (std::size_t t = 0; t < m; ++t) {
      if (!opens(t)) continue;
      if (t > 0) cells_.back().end = static_cast<Index>(b + t);
      cells_.push_back(cellAt(t));
    }
    lv.cellEnd = cells_.size();
    return;
  }
  // Two passes over contiguous parts of the slots: count the cells each part opens, then write them at
  // their offsets; a cell ends where the next one begins. The same list as the serial loop.
  runStart_.assign(parts + 1, 0);
  parallel::forEachTask(threads_, parts, [&](std::size_t p) {
    Index opened = 0;
    for (std::size_t t = m * p / parts; t < m * (p + 1) / parts; ++t) opened += opens(t) ? 1 : 0;
    runStart_[p + 1] = opened;
  });
  for (std::size_t p = 0; p < parts; ++p) runStart_[p + 1] += runStart_[p];
  const std::size_t first = cells_.size();
  reserveCells(first + static_cast<std::size_t>(runStart_[parts]));
  cells_.resize(first + static_cast<std::size_t>(runStart_[parts]));
  parallel::forEachTask(threads_, parts, [&](std::size_t p) {
    std::size_t at = first + static_cast<std::size_t>(runStart_[p]);
    for (std::size_t t = m * p / parts; t < m * (p + 1) / parts; ++t) {
      if (opens(t)) cells_[at++] = cellAt(t);
    }
  });
  const std::size_t last = cells_.size();
  parallel::forEachRange(threads_, last - first, parts, [&](std::size_t lo, std::size_t hi) {
    for (std::size_t c = first + lo; c < first + hi; ++c) cells_[c].end = c + 1 < last ? cells_[c + 1].begin : lv.end;
  });
  lv.cellEnd = last;
}

void CellStore::buildSparseMap(LevelCells& lv, std::uint64_t cellCount) {
  if (lv.kind == CellStorage::Ranked) {
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
    return;
  }
  // Open addressing with linear probing, load <= 1/2; entries verify the full key.
  const std::size_t occupiedCells = lv.cellEnd - lv.cellBegin;
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

std::size_t CellStore::memoryBytes() const {
  return cellStart_.capacity() * sizeof(Index) + table_.capacity() * sizeof(HashEntry) +
         bitmap_.capacity() * sizeof(std::uint64_t) + rank_.capacity() * sizeof(std::uint32_t) +
         cells_.capacity() * sizeof(OccupiedCell) + (keyA_.capacity() + keyB_.capacity()) * sizeof(std::uint64_t) +
         (idxA_.capacity() + idxB_.capacity() + histogram_.capacity() + runStart_.capacity()) * sizeof(Index);
}

std::string CellStore::checkMap(const LevelCells& lv, std::uint64_t cellCount) const {
  const std::size_t listed = lv.cellEnd - lv.cellBegin;
  if (lv.kind == CellStorage::Ranked) {
    const std::uint64_t words = cellCount / 64 + 1;
    std::size_t set = 0;
    for (std::uint64_t w = 0; w < words; ++w) {
      if (rank_[lv.bitmapOffset + w] != set) return "rank directory is wrong";
      set += static_cast<std::size_t>(std::popcount(bitmap_[lv.bitmapOffset + w]));
    }
    if (set != listed) return fmt::format("bitmap holds {} cells, expected {}", set, listed);
  } else if (lv.kind == CellStorage::Hashed) {
    std::size_t entries = 0;
    const std::size_t capacity = lv.tableMask + 1;
    for (std::size_t t = 0; t < capacity; ++t) entries += table_[lv.tableOffset + t].key != kEmptyKey;
    if (entries != listed) return fmt::format("hash table holds {} cells, expected {}", entries, listed);
  }
  return {};
}

}  // namespace polydem::broadphase::hgrid
