#include "broadphase/hgrid_linked.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace polydem::broadphase {

void HGridLinked::doBuild(const SphereView& spheres) {
  const Index n = spheres.count();
  for (int k = 0; k < 3; ++k) {
    periodic_[k] = box_.periodic(k);
    length_[k] = box_.length(k);
  }
  levels_.clear();
  xyzr_.resize(4 * static_cast<std::size_t>(n));
  level_.resize(static_cast<std::size_t>(n));
  cell_.resize(static_cast<std::size_t>(n));
  next_.assign(static_cast<std::size_t>(n), -1);
  prev_.assign(static_cast<std::size_t>(n), -1);
  if (n == 0) return;
  const double rmin = minRadius_;
  for (Index i = 0; i < n; ++i) {
    const double r = spheres.radius[i];
    const int l = std::clamp(static_cast<int>(std::floor(std::log2(r / rmin))), 0, 60);
    level_[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(l);
    if (static_cast<std::size_t>(l) >= levels_.size()) levels_.resize(static_cast<std::size_t>(l) + 1);
    Level& lv = levels_[static_cast<std::size_t>(l)];
    lv.rmax = std::max(lv.rmax, r);
    for (int k = 0; k < 3; ++k) xyzr_[4 * static_cast<std::size_t>(i) + k] = spheres.centre(k, i);
    xyzr_[4 * static_cast<std::size_t>(i) + 3] = r;
  }
  // At most ~8 N cells per level: per axis min(L / (2 r_max + skin), (8 N)^(1/3)).
  const double perAxisCap = std::max(1.0, std::floor(std::cbrt(8.0 * static_cast<double>(n))));
  for (Level& lv : levels_) {
    std::int64_t cells = 1;
    for (int k = 0; k < 3; ++k) {
      const double fit = lv.rmax > 0.0 ? std::floor(length_[k] / (2.0 * lv.rmax + skin_)) : 1.0;
      lv.n[k] = static_cast<std::int32_t>(std::clamp(fit, 1.0, perAxisCap));
      lv.inverseCell[k] = 1.0 / (length_[k] / lv.n[k]);
      cells *= lv.n[k];
    }
    lv.head.assign(lv.rmax > 0.0 ? static_cast<std::size_t>(cells) : 0, -1);
  }
  for (Index i = 0; i < n; ++i) link(i);
}

std::int64_t HGridLinked::cellOf(const Level& lv, const double x[3]) const {
  std::int64_t key = 0;
  for (int k = 2; k >= 0; --k) {
    const auto c = static_cast<std::int64_t>(std::floor(x[k] * lv.inverseCell[k]));
    key = key * lv.n[k] + std::clamp<std::int64_t>(c, 0, lv.n[k] - 1);
  }
  return key;
}

void HGridLinked::link(Index i) {
  const auto ui = static_cast<std::size_t>(i);
  Level& lv = levels_[level_[ui]];
  const std::int64_t c = cellOf(lv, &xyzr_[4 * ui]);
  cell_[ui] = c;
  Index& head = lv.head[static_cast<std::size_t>(c)];
  prev_[ui] = -1;
  next_[ui] = head;
  if (head >= 0) prev_[static_cast<std::size_t>(head)] = i;
  head = i;
}

void HGridLinked::unlink(Index i) {
  const auto ui = static_cast<std::size_t>(i);
  Level& lv = levels_[level_[ui]];
  if (prev_[ui] >= 0) {
    next_[static_cast<std::size_t>(prev_[ui])] = next_[ui];
  } else {
    lv.head[static_cast<std::size_t>(cell_[ui])] = next_[ui];
  }
  if (next_[ui] >= 0) prev_[static_cast<std::size_t>(next_[ui])] = prev_[ui];
}

void HGridLinked::move(Index i, const double x[3]) {
  const auto ui = static_cast<std::size_t>(i);
  for (int k = 0; k < 3; ++k) xyzr_[4 * ui + k] = x[k];
  if (cellOf(levels_[level_[ui]], x) == cell_[ui]) return;
  unlink(i);
  link(i);
}

void HGridLinked::doUpdate(const SphereView& spheres, std::span<const Index> moved) {
  for (const Index i : moved) {
    const double x[3] = {spheres.centre(0, i), spheres.centre(1, i), spheres.centre(2, i)};
    move(i, x);
  }
}

template <bool kCount>
void HGridLinked::query(Index i, double reach, std::vector<Index>& out) const {
  out.clear();
  const auto ui = static_cast<std::size_t>(i);
  const double* xi = &xyzr_[4 * ui];
  const double ri = xi[3];
  const double* packed = xyzr_.data();
  for (const Level& lv : levels_) {
    if (lv.head.empty()) continue;
    std::int32_t lo[3], count[3];
    const double range = ri + lv.rmax + reach;
    for (int k = 0; k < 3; ++k) {
      const auto a = static_cast<std::int64_t>(std::floor((xi[k] - range) * lv.inverseCell[k]));
      const auto b = static_cast<std::int64_t>(std::floor((xi[k] + range) * lv.inverseCell[k]));
      if (b - a + 1 >= lv.n[k]) {
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
    auto wrap = [](std::int32_t c, std::int32_t m) { return c < 0 ? c + m : (c >= m ? c - m : c); };
    for (std::int32_t z = 0; z < count[2]; ++z) {
      const std::int64_t cz = wrap(lo[2] + z, lv.n[2]);
      for (std::int32_t y = 0; y < count[1]; ++y) {
        const std::int64_t cyz = (cz * lv.n[1] + wrap(lo[1] + y, lv.n[1])) * lv.n[0];
        for (std::int32_t x = 0; x < count[0]; ++x) {
          if constexpr (kCount) ++counters_.cellAccesses;
          for (Index j = lv.head[static_cast<std::size_t>(cyz + wrap(lo[0] + x, lv.n[0]))]; j >= 0;
               j = next_[static_cast<std::size_t>(j)]) {
            const double* xj = packed + 4 * static_cast<std::size_t>(j);
            if constexpr (kCount) ++counters_.pairTests;
            if (j != i && spheresWithinReach(box_, xi, ri, xj, xj[3], reach)) out.push_back(j);
          }
        }
      }
    }
  }
  std::sort(out.begin(), out.end());
}

void HGridLinked::findNeighbours(const SphereView& /*spheres*/, Index i, double reach, std::vector<Index>& out) const {
  query<false>(i, reach, out);
}

void HGridLinked::findPairs(const SphereView& spheres, std::vector<Pair>& out) const {
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

std::size_t HGridLinked::memoryBytes() const {
  std::size_t bytes = xyzr_.capacity() * sizeof(double) + level_.capacity() + cell_.capacity() * sizeof(std::int64_t) +
                      (next_.capacity() + prev_.capacity()) * sizeof(Index);
  for (const Level& lv : levels_) bytes += lv.head.capacity() * sizeof(Index);
  return bytes;
}

std::string HGridLinked::describe() const {
  std::string s = fmt::format("hgrid-linked L={}", levels_.size());
  for (const Level& lv : levels_) {
    if (!lv.head.empty()) s += fmt::format(" {}x{}x{}", lv.n[0], lv.n[1], lv.n[2]);
  }
  return s;
}

}  // namespace polydem::broadphase
