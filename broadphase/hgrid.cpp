// Hierarchical grid broad phase: configuration, levels, build, update() and reports; design notes and
// references in hgrid.hpp (thesis = V. Ogarko, PhD thesis, University of Twente: mapping eq. 2.1,
// insertion eq. 2.3, §2.1.2 = Ogarko & Luding, Comput. Phys. Commun. 183 (2012) 931). The search is in
// hgrid_search.cpp, the cell storage in hgrid_storage.cpp.
#include "broadphase/hgrid.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "broadphase/parallel.hpp"
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
      throw ConfigError(
          fmt::format("hgrid cell size s_{} ({}) must be positive and finite, got {}", h + 1, origin, sizes[h]));
    }
    if (h > 0 && !(sizes[h] > sizes[h - 1])) {
      throw ConfigError(fmt::format("hgrid cell sizes ({}) must increase strictly: s_{} = {} after s_{} = {}", origin,
                                    h + 1, sizes[h], h, sizes[h - 1]));
    }
  }
}

}  // namespace hgrid

namespace {
using hgrid::kEmptyKey;
using hgrid::kGolden;
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
      throw ConfigError(
          fmt::format("hgrid: cell size s_L = {} is smaller than the largest interaction diameter "
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
    lv.shellDelta = halfShellOffsets<std::int64_t>(lv.n[0], static_cast<std::int64_t>(lv.n[0]) * lv.n[1]);
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

  const int threads = threads_;
  store_.setThreads(threads);
  const std::size_t parts = parallel::chunkCount(threads, un);

  // Level of insertion (eq. 2.3) and a stable grouping by level.
  level_.resize(un);
  parallel::forEachRange(threads, un, parts, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      const int h = hgrid::insertionLevel(sizes, spheres.radius[static_cast<Index>(i)], skin_) - 1;
      POLYDEM_ASSERT(h >= 0, "hgrid: a sphere larger than the top level (resolveConfig checks this)");
      level_[i] = static_cast<std::uint16_t>(h);
    }
  });
  // Grouped straight into the store's per-slot sphere buffer, which each level's key pass reads.
  store_.reset(un);
  levelCount_.resize(levelCount + 1);
  Index* const grouped = store_.spheres();
  parallel::stableCountingSort(
      threads, un, levelCount, 0, [&](std::size_t i) { return level_[i]; }, levelCount_.data(), sortScratch_,
      [&](std::size_t i, Index pos) { grouped[static_cast<std::size_t>(pos)] = static_cast<Index>(i); });
  for (std::size_t h = 0; h < levelCount; ++h) {
    levels_[h].begin = levelCount_[h];
    levels_[h].end = levelCount_[h + 1];
  }

  sorted_.resize(un);
  packed_.resize(4 * un);
  overflow_.clear();
  updateReady_ = false;  // the per-sphere state of update() is made by its first call (prepareUpdate)
  occupied_.clear();

  for (std::size_t h = 0; h < levelCount; ++h) {
    Level& lv = levels_[h];
    store_.clearLevel(lv);
    lv.overflowSpheres = 0;
    if (lv.overflowUsed > 0) {
      std::fill(lv.overflowTable.begin(), lv.overflowTable.end(), OverflowEntry{hgrid::kEmptyKey, -1});
      lv.overflowUsed = 0;
    }
    if (lv.end == lv.begin) continue;
    occupied_.push_back(static_cast<int>(h));
    std::uint64_t* key = store_.keys();
    Index* sphere = store_.spheres();
    const std::size_t b = static_cast<std::size_t>(lv.begin);
    const std::size_t m = static_cast<std::size_t>(lv.end - lv.begin);
    const std::size_t levelParts = parallel::chunkCount(threads, m);
    parallel::forEachRange(threads, m, levelParts, [&](std::size_t lo, std::size_t hi) {
      for (std::size_t slot = b + lo; slot < b + hi; ++slot)
        key[slot] = keyOf(lv, spheres.centre.col(sphere[slot]).data());
    });
    // Slots in cell order, then the packed copy laid out in that order.
    const hgrid::CellStore::Sorted order = store_.addLevel(lv, lv.n, lv.nx, lv.nxy);
    parallel::forEachRange(threads, m, levelParts, [&](std::size_t lo, std::size_t hi) {
      constexpr std::size_t kAhead = 16;
      for (std::size_t t = lo; t < hi; ++t) {
        const std::size_t slot = b + t;
        const Index i = order.sphere[t];
        if (t + kAhead < hi) {
          const Index ahead = order.sphere[t + kAhead];
          __builtin_prefetch(spheres.centre.col(ahead).data());
          __builtin_prefetch(spheres.radius.data() + ahead);
        }
        sorted_[slot] = i;
        double* p = packed_.data() + 4 * slot;
        p[0] = spheres.centre(0, i);
        p[1] = spheres.centre(1, i);
        p[2] = spheres.centre(2, i);
        p[3] = spheres.radius[i];
      }
    });
  }
  levelCounters_.assign(levelCount, Counters{});
}

// ---------------------------------------------------------------------------------------------------
// Incremental update

template <CrossLevel kMode>
void HGrid<kMode>::homes(std::vector<Index>& slotOf, std::vector<std::uint64_t>& homeKey) const {
  slotOf.resize(sorted_.size());
  homeKey.resize(sorted_.size());
  for (const hgrid::OccupiedCell& cell : store_.cells()) {
    for (Index s = cell.begin; s < cell.end; ++s) {
      const Index i = sorted_[static_cast<std::size_t>(s)];
      if (i < 0) continue;  // a tombstone (update() moved its sphere to the overflow)
      slotOf[static_cast<std::size_t>(i)] = s;
      homeKey[static_cast<std::size_t>(i)] = cell.key;
    }
  }
}

template <CrossLevel kMode>
void HGrid<kMode>::prepareUpdate() {
  // Only update() needs these (16 bytes per sphere and two random writes per sphere in every build), so a
  // DEM run, which only rebuilds, never pays for them. The buffers keep their capacity across builds.
  homes(slotOf_, homeKey_);
  overflowPos_.assign(sorted_.size(), -1);
  overflowNext_.assign(sorted_.size(), -1);
  updateReady_ = true;
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
  if (n != static_cast<Index>(level_.size())) {
    throw ConfigError(
        fmt::format("hgrid update: {} spheres, but the index was built for {}: call build()", n, level_.size()));
  }
  if (!updateReady_) prepareUpdate();
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
  info.storage = lv.kind;
  return info;
}

template <CrossLevel kMode>
std::size_t HGrid<kMode>::memoryBytes() const {
  std::size_t bytes = levels_.capacity() * sizeof(Level) + occupied_.capacity() * sizeof(int) + store_.memoryBytes() +
                      sorted_.capacity() * sizeof(Index) + packed_.capacity() * sizeof(double) +
                      slotOf_.capacity() * sizeof(Index) + level_.capacity() * sizeof(std::uint16_t) +
                      homeKey_.capacity() * sizeof(std::uint64_t) + overflow_.capacity() * sizeof(OverflowRecord) +
                      overflowPos_.capacity() * sizeof(Index) + overflowNext_.capacity() * sizeof(Index) +
                      levelCount_.capacity() * sizeof(Index) + sortScratch_.capacity() * sizeof(Index) +
                      tasks_.capacity() * sizeof(SearchTask) + chunks_.memoryBytes() +
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
    occupancy += fmt::format("{}{}", sep, lv.end - lv.begin);
    if (lv.end != lv.begin) occupancy += hgrid::storageLetter(lv.kind);
  }
  std::string text =
      fmt::format("{} L={} sizes {} (snapped {}); spheres per level {} (d = dense, r = ranked bitmap, h = hashed); {}",
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
  if (level_.size() != un || sorted_.size() != un || packed_.size() != 4 * un) fail("storage size differs from N");
  // Before the first update() after a build there is no overflow and the homes follow from the cells.
  std::vector<Index> slotOfBuilt;
  std::vector<std::uint64_t> homeKeyBuilt;
  if (!updateReady_) homes(slotOfBuilt, homeKeyBuilt);
  const std::vector<Index>& slotOf = updateReady_ ? slotOf_ : slotOfBuilt;
  const std::vector<std::uint64_t>& homeKey = updateReady_ ? homeKey_ : homeKeyBuilt;
  auto overflowAt = [&](std::size_t i) { return updateReady_ ? overflowPos_[i] : Index{-1}; };
  if (levels_.size() != config_.cellSizes.size()) fail("level count differs from the configuration");
  const std::span<const double> sizes(config_.cellSizes);
  for (Index i = 0; i < n; ++i) {
    const std::size_t ui = static_cast<std::size_t>(i);
    if (level_[ui] + 1 != hgrid::insertionLevel(sizes, spheres.radius[i], skin_)) {
      fail(fmt::format("particle {} on the wrong level", i));
    }
    const Level& lv = levels_[level_[ui]];
    const Index slot = slotOf[ui];
    if (slot < lv.begin || slot >= lv.end) fail(fmt::format("particle {}: home slot outside its level", i));
    const std::uint64_t key = keyOf(lv, spheres.centre.col(i).data());
    const double* pk = packed_.data() + 4 * static_cast<std::size_t>(slot);
    if (pk[3] != spheres.radius[i]) fail(fmt::format("particle {}: packed radius is stale", i));
    if (overflowAt(ui) < 0) {
      if (sorted_[static_cast<std::size_t>(slot)] != i) fail(fmt::format("particle {}: slot is stale", i));
      if (homeKey[ui] != key) fail(fmt::format("particle {} stored in the wrong cell", i));
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
    const std::vector<hgrid::OccupiedCell>& cells = store_.cells();
    for (std::size_t c = lv.cellBegin; c < lv.cellEnd; ++c) {
      const hgrid::OccupiedCell& cell = cells[c];
      if (cell.begin != expected || cell.end <= cell.begin)
        fail(fmt::format("level {}: cell ranges not contiguous", h + 1));
      expected = cell.end;
      if (cell.key != static_cast<std::uint64_t>(cell.c[0]) + lv.nx * static_cast<std::uint64_t>(cell.c[1]) +
                          lv.nxy * static_cast<std::uint64_t>(cell.c[2])) {
        fail(fmt::format("level {}: cell coordinates disagree with the key", h + 1));
      }
      if (c > lv.cellBegin && !(cells[c - 1].key < cell.key)) fail(fmt::format("level {}: cells not sorted", h + 1));
      for (Index s = cell.begin; s < cell.end; ++s) {
        const Index i = sorted_[static_cast<std::size_t>(s)];
        if (i >= 0 && homeKey[static_cast<std::size_t>(i)] != cell.key) {
          fail(fmt::format("level {}: slot {} in the wrong cell range", h + 1, s));
        }
      }
      const auto [b, e] = store_.rangeOf(lv, cell.key);
      if (b != cell.begin || e != cell.end) fail(fmt::format("level {}: look-up of cell {} is wrong", h + 1, cell.key));
    }
    if (expected != lv.end && lv.cellEnd > lv.cellBegin) fail(fmt::format("level {}: cells miss slots", h + 1));
    if (lv.end > lv.begin) {
      const std::string map = store_.checkMap(lv, lv.nxy * static_cast<std::uint64_t>(lv.n[2]));
      if (!map.empty()) fail(fmt::format("level {}: {}", h + 1, map));
    }
  }
  if (overflowTotal != overflow_.size()) fail("overflow counts per level do not add up");
}

template class HGrid<CrossLevel::TopDown>;
template class HGrid<CrossLevel::BottomUp>;

}  // namespace polydem::broadphase
