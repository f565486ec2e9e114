// Partial moments of the particle-size distribution for the HGrid cost model; see hgrid_cost_psd.hpp.
#include "broadphase/hgrid_cost_psd.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <limits>

#include "broadphase/hgrid_cost_checks.hpp"
#include "core/errors.hpp"

namespace polydem::broadphase {

using detail::requireFiniteNonNegative;
using detail::requireFinitePositive;

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

struct CostModelPsd::Sample {
  std::vector<double> radii;                       // ascending
  std::vector<std::array<long double, 3>> prefix;  // prefix[i][k - 1] = sum_{p < i} r_p^k, k = 1..3
  double boxVolume = 0.0;
};

CostModelPsd CostModelPsd::analytic(const SizeDistribution& distribution, double packingFraction, double skin) {
  requireFinitePositive("packing fraction", packingFraction);
  requireFiniteNonNegative("skin", skin);
  const double rmin = distribution.minRadius(), rmax = distribution.maxRadius();
  if (!(rmin > 0.0 && std::isfinite(rmax) && rmax >= rmin)) {
    throw ConfigError(
        fmt::format("cost model needs radii in a bounded range 0 < rmin <= rmax < inf, got [{}, {}] "
                    "for {} (truncate the distribution)",
                    rmin, rmax, distribution.describe()));
  }
  CostModelPsd psd;
  psd.distribution_ = &distribution;
  psd.skin_ = skin;
  psd.minDiameter_ = 2.0 * rmin + skin;
  psd.maxDiameter_ = 2.0 * rmax + skin;
  psd.packingFraction_ = packingFraction;
  // thesis eq. 2.14 with d = 3; the density is that of the true radii, not the interaction radii.
  for (int k = 0; k < 4; ++k) psd.totalMoments_[k] = distribution.moment(k);
  static std::atomic<std::uint64_t> nextId{1};
  psd.id_ = nextId.fetch_add(1);
  const double particleVolume = 4.0 / 3.0 * kPi * psd.totalMoments_[3];
  psd.numberDensity_ = packingFraction / particleVolume;
  return psd;
}

CostModelPsd CostModelPsd::sample(std::span<const double> radii, double boxVolume, double skin) {
  requireFinitePositive("box volume", boxVolume);
  requireFiniteNonNegative("skin", skin);
  if (radii.empty()) throw ConfigError("cost model needs at least one radius, got an empty sample");
  auto data = std::make_shared<Sample>();
  data->radii.assign(radii.begin(), radii.end());
  for (std::size_t i = 0; i < data->radii.size(); ++i) {
    const double r = data->radii[i];
    if (!(r > 0.0 && std::isfinite(r))) {
      throw ConfigError(fmt::format("radius of particle {} must be > 0 and finite, got {}", i, r));
    }
  }
  std::sort(data->radii.begin(), data->radii.end());
  data->prefix.resize(data->radii.size() + 1);
  data->prefix[0] = {0.0L, 0.0L, 0.0L};
  for (std::size_t i = 0; i < data->radii.size(); ++i) {
    const long double r = data->radii[i];
    data->prefix[i + 1] = {data->prefix[i][0] + r, data->prefix[i][1] + r * r, data->prefix[i][2] + r * r * r};
  }
  data->boxVolume = boxVolume;
  CostModelPsd psd;
  psd.skin_ = skin;
  psd.minDiameter_ = 2.0 * data->radii.front() + skin;
  psd.maxDiameter_ = 2.0 * data->radii.back() + skin;
  psd.numberDensity_ = static_cast<double>(data->radii.size()) / boxVolume;
  psd.sample_ = std::move(data);
  return psd;
}

Index CostModelPsd::sampleSize() const { return sample_ ? static_cast<Index>(sample_->radii.size()) : 0; }

std::span<const double> CostModelPsd::sortedRadii() const {
  return sample_ ? std::span<const double>(sample_->radii) : std::span<const double>();
}

Index CostModelPsd::countAtMost(double diameter) const {
  POLYDEM_ASSERT(sample_, "countAtMost needs a sample");
  const auto& r = sample_->radii;
  // The HGrid insertion predicate, evaluated with the same rounding.
  const auto it = std::partition_point(r.begin(), r.end(), [&](double x) { return 2.0 * x + skin_ <= diameter; });
  return static_cast<Index>(it - r.begin());
}

std::array<double, 4> CostModelPsd::band(double lo, double hi) const {
  if (sample_) {
    const Index i0 = countAtMost(lo), i1 = countAtMost(hi);
    if (i1 <= i0) return {0.0, 0.0, 0.0, 0.0};
    const long double inverseN = 1.0L / static_cast<long double>(sample_->radii.size());
    const auto& a = sample_->prefix[static_cast<std::size_t>(i0)];
    const auto& b = sample_->prefix[static_cast<std::size_t>(i1)];
    return {static_cast<double>((i1 - i0) * inverseN), static_cast<double>((b[0] - a[0]) * inverseN),
            static_cast<double>((b[1] - a[1]) * inverseN), static_cast<double>((b[2] - a[2]) * inverseN)};
  }
  // Radius band of the interaction-diameter band. The top is open-ended at s_L so that rounding in
  // (s_L - skin) / 2 cannot drop an atom sitting exactly at r_max.
  const double a = std::max(0.0, 0.5 * (lo - skin_));
  const double b = hi >= maxDiameter_ ? kInf : 0.5 * (hi - skin_);
  if (!(b > a)) return {0.0, 0.0, 0.0, 0.0};
  return {distribution_->partialMoment(0, a, b), distribution_->partialMoment(1, a, b),
          distribution_->partialMoment(2, a, b), distribution_->partialMoment(3, a, b)};
}

double CostModelPsd::fraction(double lo, double hi) const {
  if (sample_) {
    const Index i0 = countAtMost(lo), i1 = countAtMost(hi);
    return i1 > i0 ? static_cast<double>(i1 - i0) / static_cast<double>(sample_->radii.size()) : 0.0;
  }
  const double a = std::max(0.0, 0.5 * (lo - skin_));
  const double b = hi >= maxDiameter_ ? kInf : 0.5 * (hi - skin_);
  return b > a ? distribution_->partialMoment(0, a, b) : 0.0;
}

namespace {

/// Per-thread direct-mapped cache of an analytic PSD's cumulative moments C_k(d) = band(0, d)[k].
struct CumulativeCache {
  struct Entry {
    std::uint64_t id = 0;
    double diameter = 0.0;
    std::array<double, 4> moments{};
  };
  std::array<Entry, 256> entries;
};

CumulativeCache& cumulativeCache() {
  thread_local CumulativeCache cache;
  return cache;
}

}  // namespace

void CostModelPsd::levelBands(std::span<const double> cellSizes, std::vector<std::array<double, 4>>& out) const {
  out.resize(cellSizes.size());
  if (!sample_) {
    // Differences of cumulative moments: each size costs four partialMoment calls once, and bands of
    // neighbouring levels share them. The absolute rounding of the difference (1e-16 of the total) is
    // far below anything the model resolves.
    CumulativeCache& cache = cumulativeCache();
    auto cumulative = [&](double d) -> std::array<double, 4> {
      if (d >= maxDiameter_) return totalMoments_;
      if (!(d > 0.0)) return {0.0, 0.0, 0.0, 0.0};
      const std::uint64_t bits = std::bit_cast<std::uint64_t>(d);
      CumulativeCache::Entry& e = cache.entries[((bits ^ (bits >> 29)) * 0x9E3779B97F4A7C15ull) >> 56];
      if (e.id != id_ || e.diameter != d) {
        const double b = std::max(0.0, 0.5 * (d - skin_));
        e.id = id_;
        e.diameter = d;
        for (int k = 0; k < 4; ++k) e.moments[k] = distribution_->partialMoment(k, 0.0, b);
      }
      return e.moments;
    };
    std::array<double, 4> below{0.0, 0.0, 0.0, 0.0};
    double lo = 0.0;
    for (std::size_t h = 0; h < cellSizes.size(); ++h) {
      if (!(cellSizes[h] > lo)) {
        out[h] = {0.0, 0.0, 0.0, 0.0};
        continue;
      }
      const std::array<double, 4> above = cumulative(cellSizes[h]);
      for (int k = 0; k < 4; ++k) out[h][k] = std::max(0.0, above[k] - below[k]);
      below = above;
      lo = cellSizes[h];
    }
    return;
  }
  const long double inverseN = 1.0L / static_cast<long double>(sample_->radii.size());
  Index i0 = 0;
  for (std::size_t h = 0; h < cellSizes.size(); ++h) {
    const Index i1 = std::max(i0, countAtMost(cellSizes[h]));
    const auto& a = sample_->prefix[static_cast<std::size_t>(i0)];
    const auto& b = sample_->prefix[static_cast<std::size_t>(i1)];
    out[h] = {static_cast<double>((i1 - i0) * inverseN), static_cast<double>((b[0] - a[0]) * inverseN),
              static_cast<double>((b[1] - a[1]) * inverseN), static_cast<double>((b[2] - a[2]) * inverseN)};
    i0 = i1;
  }
}

std::string CostModelPsd::describe() const {
  if (sample_) {
    return fmt::format("sample N={} V={:g} skin={:g} (2r+skin in [{:g}, {:g}])", sample_->radii.size(),
                       sample_->boxVolume, skin_, minDiameter_, maxDiameter_);
  }
  return fmt::format("{}, nu={:g}, skin={:g}", distribution_->describe(), packingFraction_, skin_);
}

}  // namespace polydem::broadphase
