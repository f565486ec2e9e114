#include "broadphase/hgrid_dynamic.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace polydem::broadphase {

namespace {

// Spare slots given to a cell when it is laid out: enough that most moves into it need no relocation.
std::int32_t roomFor(std::int32_t spheres) { return spheres == 0 ? 0 : spheres + spheres / 2 + 2; }

}  // namespace

void HGridDynamic::doBuild(const SphereView& spheres) {
  const Index n = spheres.count();
  for (int k = 0; k < 3; ++k) {
    periodic_[k] = box_.periodic(k);
    length_[k] = box_.length(k);
  }
  levels_.clear();
  level_.resize(static_cast<std::size_t>(n));
  cell_.resize(static_cast<std::size_t>(n));
  slot_.resize(static_cast<std::size_t>(n));
  if (n == 0) return;
  const double rmin = minRadius_;
  for (Index i = 0; i < n; ++i) {
    const double r = spheres.radius[i];
    const int l = std::clamp(static_cast<int>(std::floor(std::log2(r / rmin))), 0, 60);
    level_[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(l);
    if (static_cast<std::size_t>(l) >= levels_.size()) levels_.resize(static_cast<std::size_t>(l) + 1);
    Level& lv = levels_[static_cast<std::size_t>(l)];
    lv.rmax = std::max(lv.rmax, r);
    ++lv.spheres;
  }
  // Cells of at least the level's largest pair distance 2 r_max + skin (finer cells, 1.5x and 2x per axis,
  // meant fewer candidates but more cells per query and were slower: docs/edmd-results.md, session 16); at
  // most ~8 N cells per level: per axis min(L / (2 r_max + skin), (8 N)^(1/3)).
  const double perAxisCap = std::max(1.0, std::floor(std::cbrt(8.0 * static_cast<double>(n))));
  for (Level& lv : levels_) {
    if (lv.spheres == 0) continue;
    std::size_t cells = 1;
    for (int k = 0; k < 3; ++k) {
      const double fit = std::floor(length_[k] / (2.0 * lv.rmax + skin_));
      lv.n[k] = static_cast<std::int32_t>(std::clamp(fit, 1.0, perAxisCap));
      lv.cell[k] = length_[k] / lv.n[k];
      lv.inverseCell[k] = 1.0 / lv.cell[k];
      cells *= static_cast<std::size_t>(lv.n[k]);
    }
    lv.run.assign(cells, Run{});
    lv.room.assign(cells, 0);
    axisStride_ = std::max({axisStride_, static_cast<std::size_t>(lv.n[0]), static_cast<std::size_t>(lv.n[1]),
                            static_cast<std::size_t>(lv.n[2])});
  }
  axisGap2_.resize(3 * axisStride_);
  axisCell_.resize(3 * axisStride_);
  for (Index i = 0; i < n; ++i) {
    const auto ui = static_cast<std::size_t>(i);
    Level& lv = levels_[level_[ui]];
    const double x[3] = {spheres.centre(0, i), spheres.centre(1, i), spheres.centre(2, i)};
    cell_[ui] = cellOf(lv, x);
    ++lv.run[static_cast<std::size_t>(cell_[ui])].size;
  }
  // Counting sort into tight runs, then layOut() gives every cell its spare room.
  for (Level& lv : levels_) {
    std::int32_t at = 0;
    for (Run& run : lv.run) {
      run.begin = at;
      at += run.size;
      run.size = 0;
    }
    lv.slots.resize(static_cast<std::size_t>(at));
    lv.id.resize(static_cast<std::size_t>(at));
  }
  for (Index i = 0; i < n; ++i) {
    const auto ui = static_cast<std::size_t>(i);
    Level& lv = levels_[level_[ui]];
    Run& run = lv.run[static_cast<std::size_t>(cell_[ui])];
    const auto at = static_cast<std::size_t>(run.begin + run.size++);
    lv.slots[at] = Slot{{spheres.centre(0, i), spheres.centre(1, i), spheres.centre(2, i), spheres.radius[i]}};
    lv.id[at] = i;
  }
  for (Level& lv : levels_) layOut(lv);
}

std::int32_t HGridDynamic::cellOf(const Level& lv, const double x[3]) const {
  std::int64_t key = 0;
  for (int k = 2; k >= 0; --k) {
    const auto c = static_cast<std::int64_t>(std::floor(x[k] * lv.inverseCell[k]));
    key = key * lv.n[k] + std::clamp<std::int64_t>(c, 0, lv.n[k] - 1);
  }
  return static_cast<std::int32_t>(key);
}

void HGridDynamic::copyRun(Level& lv, Run& run, Slot* slots, Index* id, std::int32_t to) {
  for (std::int32_t k = 0; k < run.size; ++k) {
    const auto from = static_cast<std::size_t>(run.begin + k), at = static_cast<std::size_t>(to + k);
    slots[at] = lv.slots[from];
    id[at] = lv.id[from];
    slot_[static_cast<std::size_t>(id[at])] = to + k;
  }
  run.begin = to;
}

void HGridDynamic::layOut(Level& lv) {
  LargeVector<Slot> slots;
  LargeVector<Index> id;
  std::size_t total = 0;
  for (const Run& run : lv.run) total += static_cast<std::size_t>(roomFor(run.size));
  slots.resize(total);
  id.assign(total, -1);
  std::int32_t at = 0;
  for (std::size_t c = 0; c < lv.run.size(); ++c) {
    copyRun(lv, lv.run[c], slots.data(), id.data(), at);
    lv.room[c] = roomFor(lv.run[c].size);
    at += lv.room[c];
  }
  lv.slots.swap(slots);
  lv.id.swap(id);
  lv.laidOut = total;
}

void HGridDynamic::append(Level& lv, std::int32_t cell, Index i, const Slot& s) {
  const auto c = static_cast<std::size_t>(cell);
  if (lv.run[c].size == lv.room[c]) {
    // Full: move the cell's run to the end of the array with twice the room (compact first when the
    // abandoned runs have doubled the array).
    if (lv.slots.size() > 2 * lv.laidOut + 1024) layOut(lv);
    if (lv.run[c].size == lv.room[c]) {
      const std::int32_t room = 2 * lv.run[c].size + 2;
      const auto to = static_cast<std::int32_t>(lv.slots.size());
      lv.slots.resize(lv.slots.size() + static_cast<std::size_t>(room));
      lv.id.resize(lv.id.size() + static_cast<std::size_t>(room), -1);
      copyRun(lv, lv.run[c], lv.slots.data(), lv.id.data(), to);
      lv.room[c] = room;
    }
  }
  Run& run = lv.run[c];
  const std::int32_t at = run.begin + run.size++;
  lv.slots[static_cast<std::size_t>(at)] = s;
  lv.id[static_cast<std::size_t>(at)] = i;
  slot_[static_cast<std::size_t>(i)] = at;
  cell_[static_cast<std::size_t>(i)] = cell;
}

void HGridDynamic::remove(Level& lv, Index i) {
  const auto ui = static_cast<std::size_t>(i);
  Run& run = lv.run[static_cast<std::size_t>(cell_[ui])];
  const std::int32_t at = slot_[ui];
  const std::int32_t last = run.begin + --run.size;
  if (at != last) {
    const Index j = lv.id[static_cast<std::size_t>(last)];
    lv.slots[static_cast<std::size_t>(at)] = lv.slots[static_cast<std::size_t>(last)];
    lv.id[static_cast<std::size_t>(at)] = j;
    slot_[static_cast<std::size_t>(j)] = at;
  }
  lv.id[static_cast<std::size_t>(last)] = -1;
}

void HGridDynamic::move(Index i, const double x[3]) {
  const auto ui = static_cast<std::size_t>(i);
  Level& lv = levels_[level_[ui]];
  const std::int32_t cell = cellOf(lv, x);
  Slot& s = lv.slots[static_cast<std::size_t>(slot_[ui])];
  if (cell == cell_[ui]) {
    for (int k = 0; k < 3; ++k) s.c[k] = x[k];
    return;
  }
  const Slot moved{{x[0], x[1], x[2], s.c[3]}};
  remove(lv, i);
  append(lv, cell, i, moved);
}

void HGridDynamic::doUpdate(const SphereView& spheres, std::span<const Index> moved) {
  for (const Index i : moved) {
    const double x[3] = {spheres.centre(0, i), spheres.centre(1, i), spheres.centre(2, i)};
    move(i, x);
  }
}

template <bool kCount>
void HGridDynamic::query(Index i, double reach, std::vector<Index>& out) const {
  out.clear();
  const auto ui = static_cast<std::size_t>(i);
  const Slot& own = levels_[level_[ui]].slots[static_cast<std::size_t>(slot_[ui])];
  const double xi[3] = {own.c[0], own.c[1], own.c[2]};
  const double ri = own.c[3];
  // Two passes: the cells to visit on every level are gathered first, with their runs' headers prefetched,
  // so that those scattered loads overlap instead of each one stalling the scan (the query is bound by them).
  visit_.clear();
  std::array<std::size_t, 64> levelEnd{};
  for (std::size_t l = 0; l < levels_.size(); ++l) {
    const Level& lv = levels_[l];
    if (lv.spheres > 0) {
      std::int32_t lo[3], count[3];
      bool whole[3];
      const double range = ri + lv.rmax + reach;
      for (int k = 0; k < 3; ++k) {
        const auto a = static_cast<std::int64_t>(std::floor((xi[k] - range) * lv.inverseCell[k]));
        const auto b = static_cast<std::int64_t>(std::floor((xi[k] + range) * lv.inverseCell[k]));
        whole[k] = b - a + 1 >= lv.n[k];
        if (whole[k]) {
          lo[k] = 0;
          count[k] = lv.n[k];
        } else if (periodic_[k]) {
          lo[k] = static_cast<std::int32_t>(a);
          count[k] = static_cast<std::int32_t>(b - a + 1);
        } else {
          const std::int64_t a0 = std::max<std::int64_t>(a, 0), b0 = std::min<std::int64_t>(b, lv.n[k] - 1);
          lo[k] = static_cast<std::int32_t>(a0);
          count[k] = static_cast<std::int32_t>(std::max<std::int64_t>(b0 - a0 + 1, 0));
        }
      }
      // Distance along axis k from the centre to cell c (unwrapped index of the block), 0 on an axis the
      // block covers whole (its cells are visited once, whatever the image). Narrowed by a millionth of a
      // cell for the round-off of floor(x / cell) against c * cell: a cell is only skipped out of reach.
      auto gap = [&](int k, std::int32_t c) {
        if (whole[k]) return 0.0;
        const double below = c * lv.cell[k] - xi[k], above = xi[k] - (c + 1) * lv.cell[k];
        return std::max(0.0, std::max(below, above) - 1e-6 * lv.cell[k]);
      };
      const double range2 = range * range;
      auto wrap = [](std::int32_t c, std::int32_t m) { return c < 0 ? c + m : (c >= m ? c - m : c); };
      // Per axis, once per level: each column of the block's squared distance and wrapped cell index (the
      // inner loops read them instead of recomputing the x column for every y and z).
      double* g2[3];
      std::int32_t* wrapped[3];
      for (int k = 0; k < 3; ++k) {
        g2[k] = axisGap2_.data() + static_cast<std::size_t>(k) * axisStride_;
        wrapped[k] = axisCell_.data() + static_cast<std::size_t>(k) * axisStride_;
        for (std::int32_t c = 0; c < count[k]; ++c) {
          const double g = gap(k, lo[k] + c);
          g2[k][c] = g * g;
          wrapped[k][c] = wrap(lo[k] + c, lv.n[k]);
        }
      }
      const Run* runs = lv.run.data();
      for (std::int32_t z = 0; z < count[2]; ++z) {
        const double dz2 = g2[2][z];
        if (dz2 > range2) continue;
        const std::int64_t cz = wrapped[2][z];
        for (std::int32_t y = 0; y < count[1]; ++y) {
          const double dyz2 = dz2 + g2[1][y];
          if (dyz2 > range2) continue;
          const std::int64_t cyz = (cz * lv.n[1] + wrapped[1][y]) * lv.n[0];
          for (std::int32_t x = 0; x < count[0]; ++x) {
            if (dyz2 + g2[0][x] > range2) continue;
            const auto c = static_cast<std::int32_t>(cyz + wrapped[0][x]);
            __builtin_prefetch(runs + c);
            visit_.push_back(c);
          }
        }
      }
    }
    levelEnd[l] = visit_.size();
  }
  // The candidates of a cell are tested without branches and every one is written to `out`, the count
  // advancing only for those within reach: the pair predicate spheresWithinReach() term by term (the same
  // minimum image, d - L where d > L / 2 and d + L where d < -L / 2, with L / 2 = inf on walled axes; the same
  // sums in the same order), so the lists are bit for bit those of every other backend.
  double half[3], wrapBy[3];
  for (int k = 0; k < 3; ++k) {
    half[k] = periodic_[k] ? 0.5 * length_[k] : std::numeric_limits<double>::infinity();
    wrapBy[k] = periodic_[k] ? length_[k] : 0.0;
  }
  std::size_t found = 0;
  std::size_t v = 0;
  for (std::size_t l = 0; l < levels_.size(); ++l) {
    const Level& lv = levels_[l];
    const Slot* slots = lv.slots.data();
    const Index* ids = lv.id.data();
    const Run* runs = lv.run.data();
    const std::size_t end = levelEnd[l];
    for (; v < end; ++v) {
      if (v + 2 < end) __builtin_prefetch(slots + runs[visit_[v + 2]].begin);
      if constexpr (kCount) ++counters_.cellAccesses;
      const Run run = runs[visit_[v]];
      if constexpr (kCount) counters_.pairTests += static_cast<std::uint64_t>(run.size);
      if (found_.size() < found + static_cast<std::size_t>(run.size)) found_.resize(2 * (found + run.size));
      Index* o = found_.data();
      std::int32_t k = run.begin;
#if defined(__SSE2__)
      // Two candidates per pass: the same operations lane by lane as the scalar loop below (IEEE arithmetic
      // is the same in a vector lane), so the same pairs are found. The run's slots are x, y, z, r each.
      for (; k + 1 < run.begin + run.size; k += 2) {
        const __m128d xy0 = _mm_loadu_pd(slots[k].c), zr0 = _mm_loadu_pd(slots[k].c + 2);
        const __m128d xy1 = _mm_loadu_pd(slots[k + 1].c), zr1 = _mm_loadu_pd(slots[k + 1].c + 2);
        const __m128d cx = _mm_unpacklo_pd(xy0, xy1), cy = _mm_unpackhi_pd(xy0, xy1);
        const __m128d cz = _mm_unpacklo_pd(zr0, zr1), cr = _mm_unpackhi_pd(zr0, zr1);
        auto axis = [&](const __m128d& c, int a) {
          __m128d d = _mm_sub_pd(_mm_set1_pd(xi[a]), c);
          const __m128d up = _mm_and_pd(_mm_cmpgt_pd(d, _mm_set1_pd(half[a])), _mm_set1_pd(wrapBy[a]));
          const __m128d down = _mm_and_pd(_mm_cmplt_pd(d, _mm_set1_pd(-half[a])), _mm_set1_pd(wrapBy[a]));
          d = _mm_add_pd(_mm_sub_pd(d, up), down);
          return _mm_mul_pd(d, d);
        };
        const __m128d d2 = _mm_add_pd(_mm_add_pd(axis(cx, 0), axis(cy, 1)), axis(cz, 2));
        const __m128d limit = _mm_add_pd(_mm_add_pd(_mm_set1_pd(ri), cr), _mm_set1_pd(reach));
        const int within = _mm_movemask_pd(_mm_cmple_pd(d2, _mm_mul_pd(limit, limit)));
        o[found] = ids[k];
        found += static_cast<std::size_t>((within & 1) & (ids[k] != i));
        o[found] = ids[k + 1];
        found += static_cast<std::size_t>((within >> 1) & (ids[k + 1] != i));
      }
#endif
      for (; k < run.begin + run.size; ++k) {
        const double* xj = slots[k].c;
        double d2 = 0.0;
        for (int a = 0; a < 3; ++a) {
          double d = xi[a] - xj[a];
          d = (d - (d > half[a] ? wrapBy[a] : 0.0)) + (d < -half[a] ? wrapBy[a] : 0.0);
          d2 = a == 0 ? d * d : d2 + d * d;
        }
        const double limit = (ri + xj[3]) + reach;
        o[found] = ids[k];
        found += static_cast<std::size_t>((d2 <= limit * limit) & (ids[k] != i));
      }
    }
  }
  out.assign(found_.begin(), found_.begin() + static_cast<std::ptrdiff_t>(found));
  std::sort(out.begin(), out.end());
}

void HGridDynamic::findNeighbours(const SphereView& /*spheres*/, Index i, double reach, std::vector<Index>& out) const {
  query<false>(i, reach, out);
}

void HGridDynamic::findPairs(const SphereView& spheres, std::vector<Pair>& out) const {
  out.clear();
  const Index n = spheres.count();
  for (Index i = 0; i < n; ++i) {
    if (counting_) {
      query<true>(i, skin_, scratch_);
    } else {
      query<false>(i, skin_, scratch_);
    }
    for (const Index j : scratch_) {
      if (j > i) out.push_back({i, j});
    }
  }
}

std::size_t HGridDynamic::memoryBytes() const {
  std::size_t bytes = level_.capacity() + (cell_.capacity() + slot_.capacity()) * sizeof(std::int32_t);
  for (const Level& lv : levels_) {
    bytes += lv.run.capacity() * sizeof(Run) + lv.room.capacity() * sizeof(std::int32_t) +
             lv.slots.capacity() * sizeof(Slot) + lv.id.capacity() * sizeof(Index);
  }
  return bytes;
}

std::string HGridDynamic::describe() const {
  std::string s = fmt::format("hgrid-dynamic L={}", levels_.size());
  for (const Level& lv : levels_) {
    if (lv.spheres > 0) s += fmt::format(" {}x{}x{}", lv.n[0], lv.n[1], lv.n[2]);
  }
  return s;
}

}  // namespace polydem::broadphase
