// Cell storage of the hierarchical grid; see hgrid_storage.hpp.
#include "broadphase/hgrid_storage.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <utility>

namespace polydem::broadphase::hgrid {

namespace {

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
    return {keyB_.data() + b, idxB_.data() + b};
  }
  // Too sparse for a dense cell-start array but not too sparse: a "ranked" level.
  lv.kind = rankedLimit_ > 0.0 && cells <= rankedLimit_ * count + 4096.0 ? CellStorage::Ranked : CellStorage::Hashed;
  const int bits = cellCount > 1 ? std::bit_width(cellCount - 1) : 0;
  const auto [k, v] = radixSort(keyA_.data() + b, idxA_.data() + b, keyB_.data() + b, idxB_.data() + b, m, bits);
  return {k, v};
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
         (idxA_.capacity() + idxB_.capacity()) * sizeof(Index);
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
