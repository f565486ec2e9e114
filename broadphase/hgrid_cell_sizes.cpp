// Cell-size rules of thesis §2.2.5 and the appendix procedure of ch. 2.1; see hgrid_cell_sizes.hpp.
// Equations: linear 2.42, exponential 2.43-2.44, constant m 2.45-2.47; ch. 2.1: m(L, PSD) in its appendix
// (eq. 2.8), cost L (m + K) eq. 2.7 and the optimal number of levels (ONL) of §2.1.3.
#include "broadphase/hgrid_cell_sizes.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "broadphase/hgrid_cost_checks.hpp"
#include "core/errors.hpp"

namespace polydem::broadphase {

using detail::degenerate;
using detail::requireFiniteNonNegative;
using detail::requireFinitePositive;
using detail::requireLevels;

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

namespace {

/// Smallest s in (lower, upper] with g(s) >= target, given g(upper) >= target > g(lower) and g
/// non-decreasing (continuous for an analytic PSD, a staircase for a sample). Illinois steps in log s,
/// with a bisection step whenever the bracket fails to halve.
template <class G>
double solveIncreasing(G&& g, double lower, double upper, double target) {
  double xa = std::log(lower), xb = std::log(upper);
  double fa = g(lower) - target, fb = g(upper) - target;
  int side = 0;
  for (int iter = 0; iter < 200 && xb - xa > 1e-15 * std::max(1.0, std::abs(xb)); ++iter) {
    const double width = xb - xa;
    double x = (fb - fa) > 0.0 ? xb - fb * (xb - xa) / (fb - fa) : 0.5 * (xa + xb);
    if (!(x > xa && x < xb) || iter % 3 == 2) x = 0.5 * (xa + xb);
    const double f = g(std::exp(x)) - target;
    if (f >= 0.0) {
      xb = x;
      fb = f;
      if (side == 1) fa *= 0.5;
      side = 1;
    } else {
      xa = x;
      fa = f;
      if (side == -1) fb *= 0.5;
      side = -1;
    }
    if (fb == 0.0 || xb - xa > 0.75 * width) side = 0;  // stalled: let the next bisection act
  }
  return std::exp(xb);
}

/// One constant-ratio sweep for a trial m_1; returns +1 when m_1 is admissible or too large (the sweep
/// ran out of particles before level L, or the top level holds at most its share), -1 when too small.
int constantRatioSweep(const CostModelPsd& psd, int levels, double q, double m1, std::vector<double>& sizes) {
  const double n = psd.numberDensity(), top = psd.maxDiameter();
  sizes.assign(static_cast<std::size_t>(levels), top);
  double lower = 0.0;  // band lower bound of the current level (level 1 takes everything below s_1)
  double previous = psd.minDiameter();
  double target = m1;
  for (int h = 0; h + 1 < levels; ++h) {
    auto g = [&](double s) { return n * s * s * s * psd.fraction(lower, s); };  // eq. 2.19
    if (g(top) < target) return +1;                                             // ran out before level L
    const double lo = std::max(previous, 1e-300);
    const double s = g(lo) >= target ? lo : solveIncreasing(g, lo, top, target);
    sizes[h] = s;
    lower = previous = s;
    target *= q;
  }
  const double mTop = n * top * top * top * psd.fraction(lower, top);
  return mTop > target ? -1 : +1;
}

}  // namespace

std::vector<double> linearCellSizes(const CostModelPsd& psd, int levels) {
  requireLevels(levels);
  const double s0 = psd.minDiameter(), sL = psd.maxDiameter();
  std::vector<double> s(static_cast<std::size_t>(levels));
  for (int h = 1; h <= levels; ++h) s[h - 1] = s0 + h * (sL - s0) / levels;  // eq. 2.42
  s.back() = sL;
  return s;
}

std::vector<double> exponentialCellSizes(const CostModelPsd& psd, int levels) {
  requireLevels(levels);
  const double s0 = psd.minDiameter(), sL = psd.maxDiameter();
  std::vector<double> s(static_cast<std::size_t>(levels));
  for (int h = 1; h <= levels; ++h) s[h - 1] = s0 * std::pow(sL / s0, static_cast<double>(h) / levels);  // eq. 2.44
  s.back() = sL;
  return s;
}

std::vector<double> constantRatioCellSizes(const CostModelPsd& psd, int levels, double q) {
  requireLevels(levels);
  requireFinitePositive("particles-per-cell ratio q", q);
  const double top = psd.maxDiameter();
  if (levels == 1 || degenerate(psd)) return std::vector<double>(static_cast<std::size_t>(levels), top);
  // Bracket: m_1 = m of the linked cell fills level 1 at once (+1); a vanishing m_1 leaves the top
  // level overfull (-1). Bisection in log m_1 (our choice; the rule is thesis §2.2.5).
  const double mAll = psd.numberDensity() * top * top * top;
  double lo = 1e-12 * mAll, hi = mAll;
  std::vector<double> sizes, best;
  constantRatioSweep(psd, levels, q, hi, best);
  for (int iter = 0; iter < 100 && hi > lo * (1.0 + 1e-13); ++iter) {
    const double mid = std::sqrt(lo * hi);
    if (constantRatioSweep(psd, levels, q, mid, sizes) > 0) {
      hi = mid;
      best.swap(sizes);
    } else {
      lo = mid;
    }
  }
  return best;  // sizes of the smallest admissible m_1 found
}

// ---- appendix procedure of ch. 2.1 -------------------------------------------------------------------

namespace {

/// L(m), stopping early once more than `cap` levels are open.
int appendixCount(std::span<const double> r, double boxVolume, double skin, double m, int cap) {
  const std::size_t n = r.size();
  const double limit = m * boxVolume;
  std::size_t i0 = 0;
  int levels = 0;
  while (i0 < n && levels <= cap) {
    ++levels;
    // Particle i0 opened this level (it is not re-tested: the thesis resets the count to 1). The level
    // keeps every further particle i while N_h(i) (2 r_i + skin)^3 <= m V (thesis eq. 2.8), a
    // condition monotone in i for ascending radii.
    const auto first = r.begin() + static_cast<std::ptrdiff_t>(i0) + 1;
    const auto it = std::partition_point(first, r.end(), [&](const double& x) {
      const double d = 2.0 * x + skin;
      const double count = static_cast<double>(&x - r.data() - static_cast<std::ptrdiff_t>(i0) + 1);
      return count * d * d * d <= limit;
    });
    i0 = static_cast<std::size_t>(it - r.begin());
  }
  return levels;
}

}  // namespace

int appendixLevelCount(std::span<const double> sortedRadii, double boxVolume, double skin, double m) {
  return appendixCount(sortedRadii, boxVolume, skin, m, std::numeric_limits<int>::max() - 1);
}

const AppendixLevels& AppendixResult::optimal() const {
  for (const auto& row : table) {
    if (row.levels == optimalLevels) return row;
  }
  throw ConfigError("appendix result has no row for its optimal number of levels");
}

AppendixResult appendixProcedure(std::span<const double> radii, double boxVolume, double skin, double K,
                                 int maxLevels) {
  requireLevels(maxLevels);
  requireFiniteNonNegative("K", K);
  // Validates and sorts.
  const CostModelPsd psd = CostModelPsd::sample(radii, boxVolume, skin);
  const auto r = psd.sortedRadii();
  const double top = psd.maxDiameter();
  const double mOne = static_cast<double>(r.size()) * top * top * top / boxVolume;  // L(mOne) = 1
  AppendixResult result;
  double bestCost = kInf;
  for (int L = 1; L <= maxLevels; ++L) {
    // Smallest m with L(m) <= L; L(m) is non-increasing in m (thesis ch. 2.1 appendix).
    double lo = mOne * 1e-15, hi = mOne * (1.0 + 1e-12);
    if (appendixCount(r, boxVolume, skin, lo, L) <= L) continue;  // every m gives <= L levels
    for (int iter = 0; iter < 200 && hi > lo * (1.0 + 1e-12); ++iter) {
      const double mid = std::sqrt(lo * hi);
      (appendixCount(r, boxVolume, skin, mid, L) <= L ? hi : lo) = mid;
    }
    if (appendixCount(r, boxVolume, skin, hi, L) != L) continue;  // L is skipped by this sample
    AppendixLevels row;
    row.levels = L;
    row.perCell = hi;
    row.cost = L * (hi + K);  // thesis eq. 2.7
    // Replay the allocation for the cell sizes: s_h = 2 (largest radius on level h) + skin.
    std::size_t i0 = 0;
    const double limit = hi * boxVolume;
    while (i0 < r.size()) {
      const auto first = r.begin() + static_cast<std::ptrdiff_t>(i0) + 1;
      const auto it = std::partition_point(first, r.end(), [&](const double& x) {
        const double d = 2.0 * x + skin;
        return static_cast<double>(&x - r.data() - static_cast<std::ptrdiff_t>(i0) + 1) * d * d * d <= limit;
      });
      const std::size_t last = static_cast<std::size_t>(it - r.begin()) - 1;
      row.cellSizes.push_back(2.0 * r[last] + skin);
      i0 = last + 1;
    }
    if (row.cost < bestCost) {
      bestCost = row.cost;
      result.optimalLevels = L;
    }
    result.table.push_back(std::move(row));
  }
  if (result.table.empty()) {
    // A sample that cannot be split (all radii equal): one level.
    result.table.push_back({1, mOne, mOne + K, {top}});
    result.optimalLevels = 1;
  }
  return result;
}

}  // namespace polydem::broadphase
