#include "broadphase/linked_cell.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "broadphase/half_shell.hpp"
#include "broadphase/pair_chunks.hpp"
#include "broadphase/parallel.hpp"
#include "core/errors.hpp"

namespace polydem::broadphase {

void LinkedCell::doBuild(const SphereView& spheres) {
  const Index n = spheres.count();
  // The small relative margin keeps a cell at least one cutoff wide even when x / s rounds a centre
  // into the neighbouring cell.
  const double cutoff = std::max((2.0 * maxRadius_ + skin_) * (1.0 + 1e-10), minimumCellSize_);
  // Cap the cell count at max(64, 4 N): larger cells stay correct, and memory stays O(N).
  const double maxCells = std::max(64.0, 4.0 * static_cast<double>(n));
  double edge = cutoff > 0.0 ? cutoff : box_.lengths().maxCoeff();
  for (;;) {
    double total = 1.0;
    for (int k = 0; k < 3; ++k) total *= std::max(1.0, std::floor(box_.length(k) / edge));
    if (total <= maxCells) break;
    edge *= std::cbrt(total / maxCells) * 1.0001;
  }
  aliased_ = false;
  for (int k = 0; k < 3; ++k) {
    cells_[k] = std::max(1, static_cast<int>(std::floor(box_.length(k) / edge)));
    cellSize_[k] = box_.length(k) / cells_[k];
    // Snapped cells must still hold the cutoff after rounding in L / n.
    if (cellSize_[k] < edge && cells_[k] > 1) {
      --cells_[k];
      cellSize_[k] = box_.length(k) / cells_[k];
    }
    inverseCellSize_[k] = 1.0 / cellSize_[k];
    if (box_.periodic(k) && cells_[k] == 2) aliased_ = true;
  }
  shellDelta_ = halfShellOffsets<int>(cells_[0], cells_[0] * cells_[1]);

  const int totalCells = cells_[0] * cells_[1] * cells_[2];
  cellStart_.resize(static_cast<std::size_t>(totalCells) + 1);
  cellOf_.resize(static_cast<std::size_t>(n));
  sorted_.resize(static_cast<std::size_t>(n));
  slotOf_.resize(static_cast<std::size_t>(n));
  packed_.resize(4, n);
  // Counting sort by cell (stable: ascending particle index within a cell), threaded over contiguous
  // parts of the particles with one histogram each (parallel.hpp): the same slots for any thread count.
  const int threads = threads_;
  const std::size_t parts = parallel::chunkCount(threads, static_cast<std::size_t>(n));
  parallel::forEachRange(threads, static_cast<std::size_t>(n), parts, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) cellOf_[i] = cellIndexOf(spheres.centre.col(static_cast<Index>(i)).data());
  });
  parallel::stableCountingSort(
      threads, static_cast<std::size_t>(n), static_cast<std::size_t>(totalCells), 0,
      [&](std::size_t i) { return cellOf_[i]; }, cellStart_.data(), fill_,
      [&](std::size_t i, Index slot) {
        sorted_[static_cast<std::size_t>(slot)] = static_cast<Index>(i);
        slotOf_[i] = slot;
      });
  // The packed copy in slot order, read sequentially by the search.
  parallel::forEachRange(threads, static_cast<std::size_t>(n), parts, [&](std::size_t b, std::size_t e) {
    for (std::size_t slot = b; slot < e; ++slot) {
      const Index i = sorted_[slot];
      double* p = packed_.data() + 4 * slot;
      p[0] = spheres.centre(0, i);
      p[1] = spheres.centre(1, i);
      p[2] = spheres.centre(2, i);
      p[3] = spheres.radius[i];
    }
  });
}

void LinkedCell::doUpdate(const SphereView& spheres, std::span<const Index> moved) {
  for (Index i : moved) {
    if (cellIndexOf(spheres.centre.col(i).data()) != cellOf_[i]) {
      doBuild(spheres);
      return;
    }
  }
  for (Index i : moved) packed_.col(slotOf_[i]).head<3>() = spheres.centre.col(i);
}

int LinkedCell::cellIndexOf(const double* x) const {
  int c[3];
  for (int k = 0; k < 3; ++k) {
    // x in [0, L] (walls may put a centre exactly on L): clamp the index into range.
    c[k] = std::min(cells_[k] - 1, std::max(0, static_cast<int>(x[k] * inverseCellSize_[k])));
  }
  return c[0] + cells_[0] * (c[1] + cells_[1] * c[2]);
}

std::array<int, 3> LinkedCell::cellCoordinates(int cell) const {
  return {cell % cells_[0], (cell / cells_[0]) % cells_[1], cell / (cells_[0] * cells_[1])};
}

int LinkedCell::neighbourhood(int cell, std::array<int, 27>& out) const {
  const auto c = cellCoordinates(cell);
  int count = 0;
  for (int dz = -1; dz <= 1; ++dz) {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const int d[3] = {dx, dy, dz};
        int q[3];
        bool inside = true;
        for (int k = 0; k < 3; ++k) {
          q[k] = c[k] + d[k];
          if (q[k] < 0 || q[k] >= cells_[k]) {
            if (box_.periodic(k)) {
              q[k] = (q[k] + cells_[k]) % cells_[k];
            } else {
              inside = false;
            }
          }
        }
        if (inside) out[count++] = q[0] + cells_[0] * (q[1] + cells_[1] * q[2]);
      }
    }
  }
  std::sort(out.begin(), out.begin() + count);
  return static_cast<int>(std::unique(out.begin(), out.begin() + count) - out.begin());
}

namespace {
inline void emit(std::vector<Pair>& out, Index a, Index b) { out.push_back(a < b ? Pair{a, b} : Pair{b, a}); }
}  // namespace

template <bool kCount>
void LinkedCell::pairsImpl(int cellBegin, int cellEnd, std::vector<Pair>& out) const {
  const double* p = packed_.data();
  std::uint64_t tests = 0, accesses = 0;

  // All pairs between slots [a0, a1) and [b0, b1).
  auto crossCells = [&](Index a0, Index a1, Index b0, Index b1) {
    for (Index s = a0; s < a1; ++s) {
      const double* ps = p + 4 * s;
      for (Index t = b0; t < b1; ++t) {
        const double* pt = p + 4 * t;
        if (spheresWithinReach(box_, ps, ps[3], pt, pt[3], skin_)) emit(out, sorted_[s], sorted_[t]);
      }
    }
    if constexpr (kCount) tests += static_cast<std::uint64_t>(a1 - a0) * static_cast<std::uint64_t>(b1 - b0);
  };

  std::array<int, 27> block{};
  for (int c = cellBegin; c < cellEnd; ++c) {
    const Index a0 = cellStart_[c], a1 = cellStart_[c + 1];
    if constexpr (kCount) ++accesses;
    if (a0 == a1) continue;
    // Own cell: each pair once.
    for (Index s = a0; s < a1; ++s) {
      const double* ps = p + 4 * s;
      for (Index t = s + 1; t < a1; ++t) {
        const double* pt = p + 4 * t;
        if (spheresWithinReach(box_, ps, ps[3], pt, pt[3], skin_)) emit(out, sorted_[s], sorted_[t]);
      }
    }
    if constexpr (kCount) tests += static_cast<std::uint64_t>(a1 - a0) * static_cast<std::uint64_t>(a1 - a0 - 1) / 2;

    if (aliased_) {
      // Some periodic axis has two cells, so forward and backward neighbours coincide: visit each
      // distinct neighbour cell with a higher index once.
      const int count = neighbourhood(c, block);
      for (int k = 0; k < count; ++k) {
        const int q = block[k];
        if (q <= c) continue;
        if constexpr (kCount) ++accesses;
        crossCells(a0, a1, cellStart_[q], cellStart_[q + 1]);
      }
      continue;
    }
    const auto cc = cellCoordinates(c);
    if (cc[0] >= 1 && cc[0] <= cells_[0] - 2 && cc[1] >= 1 && cc[1] <= cells_[1] - 2 && cc[2] >= 1 &&
        cc[2] <= cells_[2] - 2) {
      // Interior cell: every forward neighbour exists unwrapped, at a fixed index offset, and the 13 cells are
      // 5 runs along x (kHalfShellRuns), each one slot range: the cells of the general path below, pairs in
      // another order.
      if constexpr (kCount) accesses += 13;
      for (const auto& run : kHalfShellRuns) {
        const int first = c + shellDelta_[static_cast<std::size_t>(run[0])];
        const Index b0 = cellStart_[first], b1 = cellStart_[first + run[1]];
        if (b0 < b1) crossCells(a0, a1, b0, b1);
      }
      continue;
    }
    for (const auto& o : kHalfShell) {
      int q[3];
      bool inside = true;
      for (int k = 0; k < 3; ++k) {
        q[k] = cc[k] + o[k];
        if (q[k] < 0 || q[k] >= cells_[k]) {
          if (!box_.periodic(k) || cells_[k] == 1) {
            inside = false;  // wall, or a single periodic cell (its only neighbour is itself)
          } else {
            q[k] = q[k] < 0 ? q[k] + cells_[k] : q[k] - cells_[k];
          }
        }
      }
      if (!inside) continue;
      const int qc = q[0] + cells_[0] * (q[1] + cells_[1] * q[2]);
      if constexpr (kCount) ++accesses;
      crossCells(a0, a1, cellStart_[qc], cellStart_[qc + 1]);
    }
  }
  if constexpr (kCount) {
    counters_.pairTests += tests;
    counters_.cellAccesses += accesses;
  }
}

void LinkedCell::findPairs(const SphereView& spheres, std::vector<Pair>& out) const {
  out.clear();
  const int totalCells = cells_[0] * cells_[1] * cells_[2];
  if (counting_) {
    pairsImpl<true>(0, totalCells, out);
  } else if (parallel::chunkCount(threads_, sorted_.size()) == 1) {
    pairsImpl<false>(0, totalCells, out);
  } else {
    findPairChunks(spheres, chunks_);
    chunks_.concatenate(out);
  }
}

void LinkedCell::findPairChunks(const SphereView& spheres, PairChunks& out) const {
  const std::size_t count = counting_ ? 1 : parallel::chunkCount(threads_, sorted_.size());
  if (count == 1) {
    out.reset(1);
    findPairs(spheres, out[0]);
    return;
  }
  // Chunks of consecutive cells holding about equal numbers of spheres, searched in parallel: each pair
  // lands in the chunk of the cell the serial loop finds it from, so the chunks in order are its output.
  const int totalCells = cells_[0] * cells_[1] * cells_[2];
  const Index n = static_cast<Index>(sorted_.size());
  out.reset(count);
  parallel::forEachTask(threads_, count, [&](std::size_t k) {
    auto firstCell = [&](std::size_t part) {
      if (part == count) return totalCells;
      const Index slot = static_cast<Index>(static_cast<std::size_t>(n) * part / count);
      // First cell whose range starts at or after `slot`.
      return static_cast<int>(std::lower_bound(cellStart_.begin(), cellStart_.end() - 1, slot) - cellStart_.begin());
    };
    pairsImpl<false>(firstCell(k), firstCell(k + 1), out[k]);
    out.keepHeadroom(k);
  });
}

void LinkedCell::findNeighbours(const SphereView& spheres, Index i, double reach, std::vector<Index>& out) const {
  out.clear();
  if (!(reach >= 0.0 && reach <= skin_)) {
    throw ConfigError(fmt::format("findNeighbours: reach {} must lie in [0, skin = {}]", reach, skin_));
  }
  std::array<int, 27> block{};
  const int count = neighbourhood(cellIndexOf(spheres.centre.col(i).data()), block);
  const double* xi = spheres.centre.col(i).data();
  const double ri = spheres.radius[i];
  for (int k = 0; k < count; ++k) {
    const int q = block[k];
    for (Index t = cellStart_[q]; t < cellStart_[q + 1]; ++t) {
      const Index j = sorted_[t];
      if (j == i) continue;
      if (spheresWithinReach(box_, xi, ri, spheres.centre.col(j).data(), spheres.radius[j], reach)) out.push_back(j);
    }
  }
  std::sort(out.begin(), out.end());
}

std::size_t LinkedCell::memoryBytes() const {
  return cellStart_.capacity() * sizeof(Index) + fill_.capacity() * sizeof(Index) + chunks_.memoryBytes() +
         sorted_.capacity() * sizeof(Index) + slotOf_.capacity() * sizeof(Index) + cellOf_.capacity() * sizeof(int) +
         static_cast<std::size_t>(packed_.size()) * sizeof(double);
}

std::string LinkedCell::describe() const {
  return fmt::format("linked-cell {}x{}x{} cells of {:.4g} x {:.4g} x {:.4g}", cells_[0], cells_[1], cells_[2],
                     cellSize_[0], cellSize_[1], cellSize_[2]);
}

void LinkedCell::validate(const SphereView& spheres) const {
  const Index n = spheres.count();
  if (static_cast<Index>(sorted_.size()) != n) throw std::logic_error("linked-cell: slot count differs from N");
  for (Index i = 0; i < n; ++i) {
    const Index slot = slotOf_[i];
    if (sorted_[slot] != i) throw std::logic_error(fmt::format("linked-cell: slot of particle {} is stale", i));
    const int c = cellOf_[i];
    if (slot < cellStart_[c] || slot >= cellStart_[c + 1]) {
      throw std::logic_error(fmt::format("linked-cell: particle {} outside its cell range", i));
    }
    if (cellIndexOf(spheres.centre.col(i).data()) != c) {
      throw std::logic_error(fmt::format("linked-cell: particle {} stored in the wrong cell", i));
    }
  }
}

}  // namespace polydem::broadphase
