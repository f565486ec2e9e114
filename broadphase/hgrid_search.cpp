// Hierarchical grid: the search (cells of a search box on a level, same-level and cross-level pairs, the
// overflow of update(), findNeighbours); design notes in hgrid.hpp. The levels, the build and update()
// are in hgrid.cpp, the cell storage in hgrid_storage.cpp. References (V. Ogarko, PhD thesis, University
// of Twente): same-level half shell and AABB pre-check §2.1.2 (= Ogarko & Luding, Comput. Phys. Commun.
// 183 (2012) 931), search box eqs. 2.12-2.13 §2.2.2, cost quantities eqs. 2.20-2.30 §2.2.3 (= Krijgsman,
// Ogarko & Luding, Comp. Part. Mech. 1 (2014) 357).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "broadphase/hgrid.hpp"
#include "broadphase/parallel.hpp"
#include "core/errors.hpp"

namespace polydem::broadphase {

namespace {

using hgrid::kEmptyKey;
using hgrid::kGolden;

inline void emit(std::vector<Pair>& out, Index a, Index b) { out.push_back(a < b ? Pair{a, b} : Pair{b, a}); }

}  // namespace

// ---------------------------------------------------------------------------------------------------
// Look-ups

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
  const std::uint64_t walkCost = lv.contiguous() ? 2 * box.rows + cells / 16 : 4 * cells;
  if (occupiedCells < walkCost) {
    const std::vector<hgrid::OccupiedCell>& occupied = store_.cells();
    for (std::size_t c = lv.cellBegin; c < lv.cellEnd; ++c) {
      const hgrid::OccupiedCell& cell = occupied[c];
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
        if (lv.contiguous()) {
          // Cells are sorted by key, so a run of cells along x is a contiguous run of slots. The
          // slot ranges are gathered first and their spheres prefetched: the look-ups of different
          // rows are independent, so their cache misses overlap instead of queueing behind the tests.
          const Index b = store_.startOf(lv, k0), e = store_.startOf(lv, k1 + 1);
          if (b < e) {
            __builtin_prefetch(packed_.data() + 4 * static_cast<std::size_t>(b));
            pending[pendingCount][0] = b;
            pending[pendingCount][1] = e;
            if (++pendingCount == kPending) flush();
          }
        } else {
          for (std::uint64_t key = k0; key <= k1; ++key) {
            const auto [b, e] = store_.rangeOf(lv, key);
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
void HGrid<kMode>::sameLevel(int h, std::size_t cellBegin, std::size_t cellEnd, std::vector<Pair>& out) const {
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
  const std::vector<hgrid::OccupiedCell>& cells = store_.cells();
  for (std::size_t c = cellBegin; c < cellEnd; ++c) {
    const hgrid::OccupiedCell& cell = cells[c];
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
        const auto [b0, b1] = store_.rangeOf(lv, key);
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
    if (interior && lv.contiguous()) {
      // The 13 cells as 5 runs along x, each one slot range: the same candidates (pairs in another order).
      if constexpr (kCount) accesses += 13 * m;  // the model's T_ca2 counts every stencil cell
      for (const auto& run : hgrid::kHalfShellRuns) {
        const std::uint64_t first = cell.key + static_cast<std::uint64_t>(lv.shellDelta[run[0]]);
        const Index b0 = store_.startOf(lv, first);
        const Index b1 = store_.startOf(lv, first + static_cast<std::uint64_t>(run[1]));
        if constexpr (kCount) tests += m * static_cast<std::uint64_t>(b1 - b0);
        if (b0 < b1) crossCells(a0, a1, b0, b1);
      }
      continue;
    }
    for (int o = 0; o < 13; ++o) {
      std::uint64_t key;
      if (interior) {
        key = cell.key + static_cast<std::uint64_t>(lv.shellDelta[o]);
      } else {
        std::int64_t q[3];
        bool inside = true;
        for (int k = 0; k < 3; ++k) {
          q[k] = cell.c[k] + hgrid::kHalfShell[o][k];
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
      const auto [b0, b1] = store_.rangeOf(lv, key);
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
void HGrid<kMode>::crossLevel(int h, int j, Index slotBegin, Index slotEnd, std::vector<Pair>& out) const {
  const Level& to = levels_[static_cast<std::size_t>(j)];
  const double* p = packed_.data();
  const Index* sorted = sorted_.data();
  const double halfBase = 0.5 * skin_ + 0.5 * to.nominal;  // beta = r_p + skin/2 + s_j/2
  const double skin = skin_;
  std::uint64_t tests = 0, accesses = 0;
  for (Index s = slotBegin; s < slotEnd; ++s) {
    const Index ip = sorted[s];
    if (ip < 0) continue;  // tombstone: the sphere is in the overflow
    const double* ps = p + 4 * s;
    const double rp = ps[3];
    const std::uint64_t cells = forEachBoxRange(to, ps, rp + halfBase, [&](Index b0, Index b1) {
      if constexpr (kCount) tests += static_cast<std::uint64_t>(b1 - b0);
      for (Index t = b0; t < b1; ++t) {
        const double* pt = p + 4 * t;
        if constexpr (kAabb) {
          // AABB pre-check (thesis §2.1.2), made conservative by 1e-12 so that it never rejects a
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
  for (int h : occupied_) {
    const Level& lv = levels_[static_cast<std::size_t>(h)];
    sameLevel<kCount>(h, lv.cellBegin, lv.cellEnd, out);
  }
  for (int h : occupied_) {
    const Level& from = levels_[static_cast<std::size_t>(h)];
    for (int j : occupied_) {
      const bool searched = kMode == CrossLevel::TopDown ? j < h : j > h;
      if (!searched) continue;
      if (aabbPrecheck_) {
        crossLevel<kCount, true>(h, j, from.begin, from.end, out);
      } else {
        crossLevel<kCount, false>(h, j, from.begin, from.end, out);
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
void HGrid<kMode>::findPairs(const SphereView& spheres, std::vector<Pair>& out) const {
  out.clear();
  if (counting_) {
    pairsImpl<true>(out);
  } else if (parallel::chunkCount(threads_, sorted_.size()) == 1 || !overflow_.empty()) {
    pairsImpl<false>(out);
  } else {
    findPairChunks(spheres, chunks_);
    chunks_.concatenate(out);
  }
}

template <CrossLevel kMode>
void HGrid<kMode>::findPairChunks(const SphereView& spheres, PairChunks& out) const {
  const std::size_t n = sorted_.size();
  if (counting_ || !overflow_.empty() || parallel::chunkCount(threads_, n) == 1) {
    out.reset(1);
    findPairs(spheres, out[0]);
    return;
  }
  // Pieces of about `grain` spheres each, in the order pairsImpl() searches: every same-level search, then
  // every cross-level search. Each piece fills its own chunk, so the chunks in order are the serial output.
  const std::size_t grain = std::max<std::size_t>(1024, n / (8 * static_cast<std::size_t>(parallel::usable(threads_))));
  tasks_.clear();
  const std::vector<hgrid::OccupiedCell>& cells = store_.cells();
  for (int h : occupied_) {
    const Level& lv = levels_[static_cast<std::size_t>(h)];
    const std::size_t m = static_cast<std::size_t>(lv.end - lv.begin);
    const std::size_t pieces = std::max<std::size_t>(1, m / grain);
    std::size_t from = lv.cellBegin;
    for (std::size_t q = 1; q <= pieces; ++q) {
      std::size_t to = lv.cellEnd;
      if (q < pieces) {
        // First cell starting at or after the slot that ends piece q.
        const Index slot = lv.begin + static_cast<Index>(m * q / pieces);
        to = static_cast<std::size_t>(
            std::lower_bound(cells.begin() + static_cast<std::ptrdiff_t>(from),
                             cells.begin() + static_cast<std::ptrdiff_t>(lv.cellEnd), slot,
                             [](const hgrid::OccupiedCell& c, Index s) { return c.begin < s; }) -
            cells.begin());
      }
      if (to > from) tasks_.push_back({h, h, from, to});
      from = to;
    }
  }
  for (int h : occupied_) {
    const Level& lv = levels_[static_cast<std::size_t>(h)];
    const std::size_t m = static_cast<std::size_t>(lv.end - lv.begin);
    for (int j : occupied_) {
      const bool searched = kMode == CrossLevel::TopDown ? j < h : j > h;
      if (!searched) continue;
      // A sphere of level h searches about (s_h / s_j + 2)^3 cells of level j, against 27 for the same-level
      // stencil: a few large spheres searching a fine level are as much work as many small ones.
      const double cellsPerSphere = std::pow(lv.nominal / levels_[static_cast<std::size_t>(j)].nominal + 2.0, 3.0);
      const double work = static_cast<double>(m) * cellsPerSphere / 27.0;
      const std::size_t pieces = std::clamp<std::size_t>(static_cast<std::size_t>(work / static_cast<double>(grain)), 1,
                                                         std::max<std::size_t>(1, m / 16));
      for (std::size_t q = 0; q < pieces; ++q) {
        tasks_.push_back({h, j, static_cast<std::size_t>(lv.begin) + m * q / pieces,
                          static_cast<std::size_t>(lv.begin) + m * (q + 1) / pieces});
      }
    }
  }
  out.reset(tasks_.size());
  parallel::forEachTask(threads_, tasks_.size(), [&](std::size_t k) {
    const SearchTask& t = tasks_[k];
    if (t.h == t.j) {
      sameLevel<false>(t.h, t.begin, t.end, out[k]);
    } else if (aabbPrecheck_) {
      crossLevel<false, true>(t.h, t.j, static_cast<Index>(t.begin), static_cast<Index>(t.end), out[k]);
    } else {
      crossLevel<false, false>(t.h, t.j, static_cast<Index>(t.begin), static_cast<Index>(t.end), out[k]);
    }
    out.keepHeadroom(k);
  });
}

template <CrossLevel kMode>
void HGrid<kMode>::findNeighbours(const SphereView& spheres, Index i, double reach, std::vector<Index>& out) const {
  out.clear();
  if (!(reach >= 0.0 && reach <= skin_)) {
    throw ConfigError(fmt::format("findNeighbours: reach {} must lie in [0, skin = {}]", reach, skin_));
  }
  if (i < 0 || i >= static_cast<Index>(level_.size())) {
    throw ConfigError(fmt::format("findNeighbours: particle {} out of range [0, {})", i, level_.size()));
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

// The class is instantiated in hgrid.cpp; the members defined here are instantiated here.
#define POLYDEM_HGRID_SEARCH_MEMBERS(kMode)                                                                \
  template void HGrid<kMode>::findPairs(const SphereView&, std::vector<Pair>&) const;                      \
  template void HGrid<kMode>::findPairChunks(const SphereView&, PairChunks&) const;                        \
  template void HGrid<kMode>::findNeighbours(const SphereView&, Index, double, std::vector<Index>&) const; \
  template HGrid<kMode>::BoxCells HGrid<kMode>::boxOn(const Level&, const double*, double) const;          \
  template bool HGrid<kMode>::inBox(const BoxCells&, const Level&, const std::int32_t*);                   \
  template Index HGrid<kMode>::overflowHead(const Level&, std::uint64_t) const;
POLYDEM_HGRID_SEARCH_MEMBERS(CrossLevel::TopDown)
POLYDEM_HGRID_SEARCH_MEMBERS(CrossLevel::BottomUp)
#undef POLYDEM_HGRID_SEARCH_MEMBERS

}  // namespace polydem::broadphase
