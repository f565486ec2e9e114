// HGrid cost model (seed 000 ch. 2.2.3, eqs. 2.14-2.35), cell-size rules (ch. 2.2.5) and the optimiser.
//
// Seed: shared/seeds/000_3b5cd2443ded9063.txt. Equations by line: V_p 2.14 (:2152), N_h 2.17 (:2191),
// N^c_h 2.18 (:2215), m_h 2.19 (:2239), own cell 2.20-2.21 (:2298-2301), half neighbourhood 2.22-2.23
// (:2320-2326), b(j,h) 2.24 (:2388), cross-level TD 2.27-2.28 (:2429-2437), BU 2.29-2.30 (:2446-2454),
// totals 2.31-2.34 (:2491-2541), T 2.35 (:2589); linear 2.42 (:2796), exponential 2.43-2.44
// (:2891-2905), constant m 2.45-2.47 (:2937-2967), optimal (:3019-3040); ch. 2.1 appendix m(L, PSD)
// (:1490-1535) and ONL (:1198-1204). Digest: shared/spec/hgrid-and-polydispersity.md §2.
//
// Design notes.
// * Every per-level quantity is a linear combination of the partial moments int_band r^k f dr, k = 0..3,
//   because b(j, h) P_h = int_band prod_k ((2 r + skin + S_j) / e_jk + 1) f dr is a cubic in r. So one
//   evaluation is L band() calls plus O(L^2) dot products of length 4, for both PSD sources (a sample
//   uses prefix sums over sorted radii: O(log N) per level instead of O(N)).
// * The optimiser first runs Nelder-Mead (adaptive coefficients of Gao & Han, Comput. Optim. Appl. 51
//   (2012) 259, for dimensions up to 29) on softmax weights, u_h = log(s_h / s_{h-1}) =
//   softmax(w)_h log(s_L / s_0), w_L = 0: monotone by construction, unconstrained, end sizes fixed.
//   Then BFGS with central-difference gradients (the seed used SQP + BFGS via MATLAB fmincon,
//   :3023-3030) on x_h = log s_h, sorted and clamped into [s_0, s_L]. The polish does not use the
//   weights: their normaliser couples every level, and BFGS on them stalled about 1e-5 above the
//   optimum (11.57374 vs 11.57361 at alpha = -3, omega = 100, L = 8); on log sizes it reaches the
//   digest's sizes to 4 digits, and surplus levels can collapse onto s_L exactly (empty, free), which
//   the optimum does for L > 8 there (digest §2.8). Rejected: coordinate descent (slow on the chained
//   coupling of neighbouring sizes).
// * Warm start: the optimum for L - 1 with one level split (tried at every level) is a feasible L-level
//   configuration, so the tabulated optimum never increases with L; the constant-m sizes are the
//   other start, as the digest recommends (§2.9).
#include "broadphase/hgrid_cost_model.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <numeric>

#include "core/errors.hpp"

namespace polydem::broadphase {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNc = kHalfNeighbourCells;

void requireFiniteNonNegative(const char* key, double value) {
  if (!(value >= 0.0 && std::isfinite(value))) {
    throw ConfigError(fmt::format("{} must be >= 0 and finite, got {}", key, value));
  }
}

void requireFinitePositive(const char* key, double value) {
  if (!(value > 0.0 && std::isfinite(value))) {
    throw ConfigError(fmt::format("{} must be > 0 and finite, got {}", key, value));
  }
}

const char* modeName(CrossLevel mode) { return mode == CrossLevel::TopDown ? "td" : "bu"; }

}  // namespace

// ---- CostModelPsd -------------------------------------------------------------------------------------

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
  // eq. 2.14 (:2152) with d = 3; the density is that of the true radii, not the interaction radii.
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

// ---- geometry -----------------------------------------------------------------------------------------

std::vector<LevelGeometry> cubicGeometry(std::span<const double> cellSizes) {
  std::vector<LevelGeometry> out(cellSizes.size());
  for (std::size_t h = 0; h < cellSizes.size(); ++h) {
    const double s = cellSizes[h];
    out[h] = {s, {s, s, s}, {s, s, s}};
  }
  return out;
}

std::vector<LevelGeometry> snappedGeometry(std::span<const double> cellSizes, const Eigen::Vector3d& boxLengths,
                                           bool searchWithCellEdge, double snapMargin) {
  std::vector<LevelGeometry> out(cellSizes.size());
  for (std::size_t h = 0; h < cellSizes.size(); ++h) {
    const double s = cellSizes[h];
    out[h].insertionSize = s;
    for (int k = 0; k < 3; ++k) {
      const double n = std::clamp(std::floor(boxLengths[k] / (s * (1.0 + snapMargin))), 1.0, 1048576.0);
      out[h].cellEdge[k] = boxLengths[k] / n;
      out[h].searchSize[k] = searchWithCellEdge ? out[h].cellEdge[k] : s;
    }
  }
  return out;
}

// ---- evaluation ---------------------------------------------------------------------------------------

namespace {

struct Scratch {
  std::vector<double> sizes;
  std::vector<std::array<double, 4>> bands;
  std::vector<int> kept;
  std::vector<std::array<double, 4>> poly;
  std::vector<double> perCell;
  std::vector<LevelGeometry> geometry;
};

Scratch& scratch() {
  thread_local Scratch s;
  return s;
}

/// Coefficients (r^0..r^3) of the expected number of cells a particle of radius r scans on level g:
/// prod_k ((2 r + skin + S_k) / e_k + 1), the per-axis mean of the seed's appendix (eqs. 2.55-2.64).
std::array<double, 4> scanPolynomial(const LevelGeometry& g, double skin) {
  std::array<double, 4> p{1.0, 0.0, 0.0, 0.0};
  for (int k = 0; k < 3; ++k) {
    const double a = 2.0 / g.cellEdge[k];
    const double c = (skin + g.searchSize[k]) / g.cellEdge[k] + 1.0;
    for (int i = 3; i >= 1; --i) p[i] = p[i] * c + p[i - 1] * a;
    p[0] *= c;
  }
  return p;
}

/// Eqs. 2.31-2.35 per particle. `out` (optional) receives the per-level breakdown.
double evaluate(const CostModelPsd& psd, std::span<const LevelGeometry> geometry, CrossLevel mode, double K,
                bool exactOwnCell, CostBreakdown* out) {
  Scratch& sc = scratch();
  const int L = static_cast<int>(geometry.size());
  sc.sizes.resize(geometry.size());
  for (int h = 0; h < L; ++h) sc.sizes[h] = geometry[h].insertionSize;
  psd.levelBands(sc.sizes, sc.bands);
  sc.kept.clear();
  for (int h = 0; h < L; ++h) {
    if (sc.bands[h][0] > 0.0) sc.kept.push_back(h);  // empty levels are skipped by the grid
  }
  const int kept = static_cast<int>(sc.kept.size());
  sc.poly.resize(sc.kept.size());
  sc.perCell.resize(sc.kept.size());
  for (int a = 0; a < kept; ++a) {
    const LevelGeometry& g = geometry[sc.kept[a]];
    // eq. 2.19: m_h = N_h / N^c_h = n P_h (cell volume).
    sc.perCell[a] = psd.numberDensity() * sc.bands[sc.kept[a]][0] * (g.cellEdge[0] * g.cellEdge[1] * g.cellEdge[2]);
    sc.poly[a] = scanPolynomial(g, psd.skin());
  }
  const double ownCellDeficit = exactOwnCell && psd.isSample() ? 1.0 / psd.sampleSize() : 0.0;
  if (out) out->levels.clear();
  double sumCd = 0.0, sumCa = 0.0;
  for (int a = 0; a < kept; ++a) {
    const auto& moments = sc.bands[sc.kept[a]];
    const double P = moments[0], m = sc.perCell[a];
    // eqs. 2.20-2.23: own cell (1/2 m_h per particle) and n_c forward neighbour cells.
    double cd = 0.5 * m * (P - ownCellDeficit) + kNc * m * P;
    double ca = (1.0 + kNc) * P;
    // eqs. 2.27-2.30: P_h b(j, h) = int_band poly_j(r) f(r) dr.
    const int b0 = mode == CrossLevel::TopDown ? 0 : a + 1;
    const int b1 = mode == CrossLevel::TopDown ? a : kept;
    for (int b = b0; b < b1; ++b) {
      const auto& p = sc.poly[b];
      const double B = p[0] * moments[0] + p[1] * moments[1] + p[2] * moments[2] + p[3] * moments[3];
      cd += sc.perCell[b] * B;
      ca += B;
    }
    sumCd += cd;
    sumCa += ca;
    if (out) {
      const LevelGeometry& g = geometry[sc.kept[a]];
      out->levels.push_back({g.insertionSize, g.cellEdge, P, m, cd, ca});
    }
  }
  const double total = sumCd + K * sumCa;  // eq. 2.35
  if (out) {
    out->pairTests = sumCd;
    out->cellAccesses = sumCa;
    out->total = total;
  }
  return total;
}

std::span<const LevelGeometry> cubicScratchGeometry(std::span<const double> cellSizes) {
  auto& g = scratch().geometry;
  g.resize(cellSizes.size());
  for (std::size_t h = 0; h < cellSizes.size(); ++h) {
    const double s = cellSizes[h];
    g[h] = {s, {s, s, s}, {s, s, s}};
  }
  return g;
}

}  // namespace

double costPerParticle(const CostModelPsd& psd, std::span<const double> cellSizes, CrossLevel mode, double K) {
  // The cubic geometry lives in per-thread scratch: the optimiser's inner loop does not allocate.
  return evaluate(psd, cubicScratchGeometry(cellSizes), mode, K, false, nullptr);
}

CostBreakdown costBreakdown(const CostModelPsd& psd, std::span<const LevelGeometry> levels, CrossLevel mode, double K,
                            bool exactOwnCell) {
  CostBreakdown out;
  evaluate(psd, levels, mode, K, exactOwnCell, &out);
  return out;
}

CostBreakdown costBreakdown(const CostModelPsd& psd, std::span<const double> cellSizes, CrossLevel mode, double K) {
  const auto geometry = cubicGeometry(cellSizes);
  return costBreakdown(psd, geometry, mode, K, false);
}

// ---- cell-size rules ----------------------------------------------------------------------------------

namespace {

void requireLevels(int levels) {
  if (levels < 1) throw ConfigError(fmt::format("number of levels must be >= 1, got {}", levels));
}

bool degenerate(const CostModelPsd& psd) { return !(psd.maxDiameter() > psd.minDiameter() * (1.0 + 1e-12)); }

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
  // level overfull (-1). Bisection in log m_1 (the digest's recommendation, §2.7).
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

// ---- appendix procedure (ch. 2.1) ---------------------------------------------------------------------

namespace {

/// L(m), stopping early once more than `cap` levels are open.
int appendixCount(std::span<const double> r, double boxVolume, double skin, double m, int cap) {
  const std::size_t n = r.size();
  const double limit = m * boxVolume;
  std::size_t i0 = 0;
  int levels = 0;
  while (i0 < n && levels <= cap) {
    ++levels;
    // Particle i0 opened this level (it is not re-tested: the seed resets the count to 1). The level
    // keeps every further particle i while N_h(i) (2 r_i + skin)^3 <= m V (eq. 2.8, :1510), a
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
    // Smallest m with L(m) <= L; L(m) is non-increasing in m (digest §2.2).
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
    row.cost = L * (hi + K);  // eq. 2.7 (:1177)
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

// ---- the optimal rule ---------------------------------------------------------------------------------

namespace {

/// Softmax parametrisation of the L - 1 free sizes.
class SizeMap {
 public:
  SizeMap(const CostModelPsd& psd, int levels)
      : levels_(levels), s0_(psd.minDiameter()), sL_(psd.maxDiameter()), logRange_(std::log(sL_ / s0_)) {}
  int dimension() const { return levels_ - 1; }

  void toSizes(const double* w, std::vector<double>& s) const {
    s.resize(static_cast<std::size_t>(levels_));
    double wmax = 0.0;  // the fixed weight w_L = 0
    for (int h = 0; h + 1 < levels_; ++h) wmax = std::max(wmax, w[h]);
    double total = std::exp(-wmax);
    for (int h = 0; h + 1 < levels_; ++h) total += std::exp(w[h] - wmax);
    double cumulative = 0.0;
    for (int h = 0; h + 1 < levels_; ++h) {
      cumulative += std::exp(w[h] - wmax);
      s[h] = std::min(sL_, s0_ * std::exp(logRange_ * cumulative / total));
    }
    s.back() = sL_;
  }

  void toWeights(std::span<const double> s, std::vector<double>& w) const {
    w.resize(static_cast<std::size_t>(dimension()));
    const double floor = 1e-9 * logRange_;
    auto u = [&](int h) {
      const double below = h == 0 ? s0_ : s[h - 1];
      return std::max(floor, std::log(s[h] / below));
    };
    const double uTop = u(levels_ - 1);
    for (int h = 0; h + 1 < levels_; ++h) w[h] = std::log(u(h)) - std::log(uTop);
  }

  /// The polish works on x_h = log s_h, sorted and clamped into [s_0, s_L]: continuous, and levels may
  /// collapse (an empty level costs nothing), which the softmax weights can only approach.
  void logToSizes(const double* x, std::vector<double>& s) const {
    s.resize(static_cast<std::size_t>(levels_));
    for (int h = 0; h + 1 < levels_; ++h) s[h] = std::clamp(std::exp(x[h]), s0_, sL_);
    std::sort(s.begin(), s.end() - 1);
    s.back() = sL_;
  }
  void sizesToLog(std::span<const double> s, std::vector<double>& x) const {
    x.resize(static_cast<std::size_t>(dimension()));
    for (int h = 0; h + 1 < levels_; ++h) x[h] = std::log(std::clamp(s[h], s0_, sL_));
  }

 private:
  int levels_;
  double s0_, sL_, logRange_;
};

struct Objective {
  const CostModelPsd& psd;
  const SizeMap& map;
  CrossLevel mode;
  double K;
  bool logSizes = false;  // x = sorted log sizes, else softmax weights
  std::vector<double> sizes;
  long evaluations = 0;
  double operator()(const double* x) {
    ++evaluations;
    if (logSizes) {
      map.logToSizes(x, sizes);
    } else {
      map.toSizes(x, sizes);
    }
    return costPerParticle(psd, sizes, mode, K);
  }
};

/// Nelder-Mead with the adaptive coefficients of Gao & Han (2012). Minimises in place; returns f(x).
double nelderMead(Objective& f, std::vector<double>& x, double step, long maxEvaluations, double tolerance) {
  const int n = static_cast<int>(x.size());
  const double alpha = 1.0, gamma = 1.0 + 2.0 / n, rho = 0.75 - 0.5 / n, sigma = 1.0 - 1.0 / n;
  std::vector<std::vector<double>> simplex(static_cast<std::size_t>(n + 1), x);
  std::vector<double> value(static_cast<std::size_t>(n + 1));
  for (int i = 0; i < n; ++i) simplex[i + 1][i] += step;
  const long start = f.evaluations;
  for (int i = 0; i <= n; ++i) value[i] = f(simplex[i].data());
  std::vector<int> order(static_cast<std::size_t>(n + 1));
  std::vector<double> centroid(x.size()), trial(x.size()), trial2(x.size());
  auto point = [&](double t, std::vector<double>& out) {  // centroid + t (centroid - worst)
    const auto& worst = simplex[order[n]];
    for (int k = 0; k < n; ++k) out[k] = centroid[k] + t * (centroid[k] - worst[k]);
  };
  for (;;) {
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](int a, int b) { return value[a] < value[b]; });
    const double best = value[order[0]], worst = value[order[n]];
    if (worst - best <= tolerance * std::abs(best) || f.evaluations - start >= maxEvaluations) break;
    std::fill(centroid.begin(), centroid.end(), 0.0);
    for (int i = 0; i < n; ++i) {
      for (int k = 0; k < n; ++k) centroid[k] += simplex[order[i]][k] / n;
    }
    point(alpha, trial);
    const double fr = f(trial.data());
    const double secondWorst = value[order[n - 1]];
    if (fr < best) {
      point(alpha * gamma, trial2);
      const double fe = f(trial2.data());
      if (fe < fr) {
        simplex[order[n]] = trial2;
        value[order[n]] = fe;
      } else {
        simplex[order[n]] = trial;
        value[order[n]] = fr;
      }
      continue;
    }
    if (fr < secondWorst) {
      simplex[order[n]] = trial;
      value[order[n]] = fr;
      continue;
    }
    const bool outside = fr < worst;
    point(outside ? alpha * rho : -rho, trial2);
    const double fc = f(trial2.data());
    if (fc < (outside ? fr : worst)) {
      simplex[order[n]] = trial2;
      value[order[n]] = fc;
      continue;
    }
    // Shrink towards the best vertex.
    const auto& b = simplex[order[0]];
    for (int i = 1; i <= n; ++i) {
      auto& v = simplex[order[i]];
      for (int k = 0; k < n; ++k) v[k] = b[k] + sigma * (v[k] - b[k]);
      value[order[i]] = f(v.data());
    }
  }
  const int bestIndex = static_cast<int>(std::min_element(value.begin(), value.end()) - value.begin());
  x = simplex[bestIndex];
  return value[bestIndex];
}

/// BFGS with central-difference gradients and Armijo backtracking; stops when an iteration gains less
/// than `minGain` relative. Minimises in place; returns f(x).
double bfgs(Objective& f, std::vector<double>& x, double fx, double h, int maxIterations, double minGain) {
  const int n = static_cast<int>(x.size());
  std::vector<double> g(x.size()), gNew(x.size()), p(x.size()), xNew(x.size()), s(x.size()), y(x.size()), Hy(x.size());
  std::vector<double> H(static_cast<std::size_t>(n) * n, 0.0);
  auto resetH = [&](double scale) {
    std::fill(H.begin(), H.end(), 0.0);
    for (int i = 0; i < n; ++i) H[i * n + i] = scale;
  };
  auto gradient = [&](std::vector<double>& at, std::vector<double>& out) {
    for (int i = 0; i < n; ++i) {
      const double keep = at[i];
      at[i] = keep + h;
      const double fp = f(at.data());
      at[i] = keep - h;
      const double fm = f(at.data());
      at[i] = keep;
      out[i] = (fp - fm) / (2.0 * h);
    }
  };
  resetH(1.0);
  gradient(x, g);
  for (int iter = 0; iter < maxIterations; ++iter) {
    for (int i = 0; i < n; ++i) {
      p[i] = 0.0;
      for (int j = 0; j < n; ++j) p[i] -= H[i * n + j] * g[j];
    }
    double slope = std::inner_product(p.begin(), p.end(), g.begin(), 0.0);
    if (!(slope < 0.0)) {
      resetH(1.0);
      for (int i = 0; i < n; ++i) p[i] = -g[i];
      slope = std::inner_product(p.begin(), p.end(), g.begin(), 0.0);
      if (!(slope < 0.0)) break;
    }
    // Cap the step: a weight change of 2 already changes a level's share by e^2.
    const double largest =
        std::abs(*std::max_element(p.begin(), p.end(), [](double a, double b) { return std::abs(a) < std::abs(b); }));
    double t = largest > 2.0 ? 2.0 / largest : 1.0;
    double fNew = kInf;
    for (; t > 1e-10; t *= 0.5) {
      for (int i = 0; i < n; ++i) xNew[i] = x[i] + t * p[i];
      fNew = f(xNew.data());
      if (fNew <= fx + 1e-4 * t * slope) break;
    }
    if (!(fNew < fx)) break;
    const double gain = fx - fNew;
    gradient(xNew, gNew);
    for (int i = 0; i < n; ++i) {
      s[i] = xNew[i] - x[i];
      y[i] = gNew[i] - g[i];
    }
    x.swap(xNew);
    g.swap(gNew);
    fx = fNew;
    const double sy = std::inner_product(s.begin(), s.end(), y.begin(), 0.0);
    if (sy > 1e-300) {
      if (iter == 0) resetH(sy / std::inner_product(y.begin(), y.end(), y.begin(), 0.0));
      // H <- (I - rho s y^T) H (I - rho y s^T) + rho s s^T
      const double rho = 1.0 / sy;
      for (int i = 0; i < n; ++i) {
        Hy[i] = 0.0;
        for (int j = 0; j < n; ++j) Hy[i] += H[i * n + j] * y[j];
      }
      const double yHy = std::inner_product(y.begin(), y.end(), Hy.begin(), 0.0);
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
          H[i * n + j] += -rho * (s[i] * Hy[j] + Hy[i] * s[j]) + (rho * rho * yHy + rho) * s[i] * s[j];
        }
      }
    }
    if (gain <= minGain * std::abs(fx)) break;
  }
  return fx;
}

struct SizeSearch {
  long nelderMeadBase = 60;  // evaluations: base + perDimension * (L - 1)
  long nelderMeadPerDimension = 6;
  int bfgsIterations = 150;  // stops earlier once an iteration gains < 1e-12 relative
};

/// Minimise T/N over s_1..s_{L-1} from `start` (L sizes). Returns sizes and fills `value`.
std::vector<double> minimiseSizes(const CostModelPsd& psd, int levels, CrossLevel mode, double K,
                                  std::span<const double> start, double& value, const SizeSearch& search = {}) {
  const SizeMap map(psd, levels);
  const double startValue = costPerParticle(psd, start, mode, K);
  std::vector<double> best(start.begin(), start.end());
  value = startValue;
  auto keep = [&](const std::vector<double>& sizes) {
    const double v = costPerParticle(psd, sizes, mode, K);
    if (v < value) {
      value = v;
      best = sizes;
    }
  };
  // Nelder-Mead on softmax weights: robust first moves from the start.
  Objective soft{psd, map, mode, K, false, {}};
  std::vector<double> x;
  map.toWeights(best, x);
  nelderMead(soft, x, 0.3, search.nelderMeadBase + search.nelderMeadPerDimension * map.dimension(), 1e-9);
  std::vector<double> sizes;
  map.toSizes(x.data(), sizes);
  keep(sizes);
  // BFGS polish on log sizes (better conditioned than the weights, whose normaliser couples all
  // levels). Central differences: a sample's objective is a fine staircase (a particle changing level
  // moves T/N by O(1/N)), so its step must span many particles.
  Objective logs{psd, map, mode, K, true, {}};
  map.sizesToLog(best, x);
  // Gains below a tenth of one particle changing level are noise for a sample.
  const double N = psd.sampleSize();
  const double h = psd.isSample() ? std::clamp(3.0 / std::sqrt(N), 1e-5, 0.05) : 1e-6;
  const double minGain = psd.isSample() ? std::max(1e-12, 0.1 / N) : 1e-12;
  bfgs(logs, x, logs(x.data()), h, search.bfgsIterations, minGain);
  map.logToSizes(x.data(), sizes);
  keep(sizes);
  return best;
}

/// The best L-level configuration obtained from an (L-1)-level one by splitting one level at the
/// geometric mean of its bounds, or by repeating the top size (an empty level: the same cost).
std::vector<double> bestSplit(const CostModelPsd& psd, std::span<const double> previous, CrossLevel mode, double K,
                              double& value) {
  std::vector<double> best(previous.begin(), previous.end()), trial;
  best.push_back(psd.maxDiameter());
  value = costPerParticle(psd, best, mode, K);
  double below = psd.minDiameter();
  for (std::size_t h = 0; h < previous.size(); ++h) {
    if (previous[h] > below) {
      trial.assign(previous.begin(), previous.end());
      trial.insert(trial.begin() + static_cast<std::ptrdiff_t>(h), std::sqrt(below * previous[h]));
      const double v = costPerParticle(psd, trial, mode, K);
      if (v < value) {
        value = v;
        best = trial;
      }
    }
    below = std::max(below, previous[h]);
  }
  return best;
}

}  // namespace

std::vector<double> optimalCellSizes(const CostModelPsd& psd, int levels, CrossLevel mode, double K,
                                     std::span<const double> start) {
  requireLevels(levels);
  requireFiniteNonNegative("K", K);
  if (levels == 1 || degenerate(psd)) return std::vector<double>(static_cast<std::size_t>(levels), psd.maxDiameter());
  std::vector<double> initial = constantRatioCellSizes(psd, levels, 1.0);
  double initialValue = costPerParticle(psd, initial, mode, K);
  if (start.size() == static_cast<std::size_t>(levels)) {
    const double v = costPerParticle(psd, start, mode, K);
    if (v < initialValue) {
      initial.assign(start.begin(), start.end());
      initialValue = v;
    }
  }
  double value = 0.0;
  return minimiseSizes(psd, levels, mode, K, initial, value);
}

// ---- the optimiser ------------------------------------------------------------------------------------

namespace {

GridChoice makeChoice(const CostModelPsd& psd, std::span<const double> sizes, CrossLevel mode, double K,
                      double predicted) {
  GridChoice c;
  const CostBreakdown breakdown = costBreakdown(psd, sizes, mode, K);
  for (const LevelCost& level : breakdown.levels) c.config.cellSizes.push_back(level.insertionSize);
  if (c.config.cellSizes.empty()) c.config.cellSizes.push_back(psd.maxDiameter());
  // The top level must hold the largest particle whatever rounding the grid uses for 2 r + skin.
  c.config.cellSizes.back() = psd.maxDiameter() * (1.0 + 1e-12);
  c.levels = static_cast<int>(c.config.cellSizes.size());
  c.linkedCell = c.levels == 1;
  c.config.mode = mode;
  c.predicted = predicted;
  return c;
}

int occupiedLevels(const CostModelPsd& psd, std::span<const double> sizes) {
  auto& bands = scratch().bands;
  psd.levelBands(sizes, bands);
  return static_cast<int>(std::count_if(bands.begin(), bands.end(), [](const auto& b) { return b[0] > 0.0; }));
}

std::string describeChoice(const GridChoice& c) {
  if (c.linkedCell) return fmt::format("linked-cell T/N={:.4g}", c.predicted);
  return fmt::format("hgrid-{} L={} T/N={:.4g}", modeName(c.config.mode), c.levels, c.predicted);
}

/// Among (L, T) pairs, the smallest L with T <= (1 + tolerance) min T; ties in L go to the lower T.
template <class Entry>
const Entry* preferFewLevels(const std::vector<Entry>& entries, double tolerance) {
  double best = kInf;
  for (const auto& e : entries) best = std::min(best, e.predicted);
  const Entry* pick = nullptr;
  for (const auto& e : entries) {
    if (!(e.predicted <= (1.0 + tolerance) * best)) continue;
    if (!pick || e.levels < pick->levels || (e.levels == pick->levels && e.predicted < pick->predicted)) pick = &e;
  }
  return pick;
}

struct Entry {
  int levels;
  CrossLevel mode;
  double predicted;
  const std::vector<double>* sizes;
};

}  // namespace

std::string OptimiserResult::summary() const {
  return fmt::format("{} (runner-up {})", describeChoice(chosen), describeChoice(runnerUp));
}

OptimiserResult optimiseHGrid(const CostModelPsd& psd, const OptimiserOptions& options) {
  requireLevels(options.maxLevels);
  requireFiniteNonNegative("K", options.K);
  requireFiniteNonNegative("optimiser tolerance", options.tolerance);
  const auto t0 = std::chrono::steady_clock::now();
  const double K = options.K;
  std::vector<CrossLevel> modes;
  if (!options.mode || *options.mode == CrossLevel::TopDown) modes.push_back(CrossLevel::TopDown);
  if (!options.mode || *options.mode == CrossLevel::BottomUp) modes.push_back(CrossLevel::BottomUp);

  OptimiserResult result;
  const double top = psd.maxDiameter();
  const std::vector<double> single{top};
  const double linked = costPerParticle(psd, single, CrossLevel::TopDown, K);
  std::vector<double> previous[2] = {single, single};
  for (int L = 1; L <= options.maxLevels; ++L) {
    LevelsRow row;
    row.levels = L;
    if (L == 1 || degenerate(psd)) {
      for (CrossLevel mode : modes) {
        LevelChoice& c = mode == CrossLevel::TopDown ? row.topDown : row.bottomUp;
        c = {linked, std::vector<double>(static_cast<std::size_t>(L), top)};
        (mode == CrossLevel::TopDown ? row.constantMTopDown : row.constantMBottomUp) = c;
      }
      result.table.push_back(std::move(row));
      continue;
    }
    const std::vector<double> constantM = constantRatioCellSizes(psd, L, 1.0);
    for (CrossLevel mode : modes) {
      const int m = mode == CrossLevel::TopDown ? 0 : 1;
      const double cmValue = costPerParticle(psd, constantM, mode, K);
      (m == 0 ? row.constantMTopDown : row.constantMBottomUp) = {cmValue, constantM};
      double splitValue = kInf;
      std::vector<double> split = bestSplit(psd, previous[m], mode, K, splitValue);
      std::span<const double> start = splitValue < cmValue ? std::span<const double>(split) : constantM;
      double value = 0.0;
      std::vector<double> sizes = minimiseSizes(psd, L, mode, K, start, value);
      LevelChoice& c = m == 0 ? row.topDown : row.bottomUp;
      c = {value, sizes};
      previous[m] = std::move(sizes);
    }
    result.table.push_back(std::move(row));
  }

  // Selection (digest §2.9 step 5): the fewest occupied levels within the tolerance of the minimum
  // over both modes. Runner-up: the same rule within the other kind.
  std::vector<Entry> all, perMode[2], constantMPerMode[2];
  for (const LevelsRow& row : result.table) {
    for (CrossLevel mode : modes) {
      const int m = mode == CrossLevel::TopDown ? 0 : 1;
      const LevelChoice& c = m == 0 ? row.topDown : row.bottomUp;
      const Entry e{occupiedLevels(psd, c.cellSizes), mode, c.predicted, &c.cellSizes};
      all.push_back(e);
      if (e.levels > 1) perMode[m].push_back(e);
      const LevelChoice& cm = m == 0 ? row.constantMTopDown : row.constantMBottomUp;
      const Entry f{occupiedLevels(psd, cm.cellSizes), mode, cm.predicted, &cm.cellSizes};
      if (f.levels > 1) constantMPerMode[m].push_back(f);
    }
  }
  auto choiceOf = [&](const Entry& e) { return makeChoice(psd, *e.sizes, e.mode, K, e.predicted); };
  result.chosen = choiceOf(*preferFewLevels(all, options.tolerance));
  const GridChoice linkedChoice = makeChoice(psd, single, modes.front(), K, linked);
  std::vector<GridChoice> others;
  for (int m = 0; m < 2; ++m) {
    const CrossLevel mode = m == 0 ? CrossLevel::TopDown : CrossLevel::BottomUp;
    if (!result.chosen.linkedCell && mode == result.chosen.config.mode) continue;
    const std::vector<Entry>& entries = perMode[m].empty() ? constantMPerMode[m] : perMode[m];
    if (!entries.empty()) others.push_back(choiceOf(*preferFewLevels(entries, options.tolerance)));
  }
  if (!result.chosen.linkedCell) others.push_back(linkedChoice);
  if (!others.empty()) {
    result.runnerUp = *std::min_element(others.begin(), others.end(), [](const GridChoice& a, const GridChoice& b) {
      return a.predicted < b.predicted;
    });
  } else {
    result.runnerUp = linkedChoice;  // nothing else exists (monodisperse): report the same grid
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const std::string origin = fmt::format("optimiser (K={:g}, {}): {}", K, psd.describe(), result.summary());
  result.chosen.config.origin = origin;
  result.runnerUp.config.origin = origin;
  return result;
}

HGridConfig optimiseForSpheres(std::span<const double> radii, double boxVolume, double skin,
                               std::optional<CrossLevel> mode, double K) {
  if (radii.empty()) {
    HGridConfig config;
    config.mode = mode.value_or(CrossLevel::TopDown);
    config.origin = "optimiser: no particles";
    return config;
  }
  const CostModelPsd psd = CostModelPsd::sample(radii, boxVolume, skin);
  OptimiserOptions options;
  options.K = K;
  options.mode = mode;
  return optimiseHGrid(psd, options).chosen.config;
}

HGridConfig configureHGrid(const SphereView& spheres, const Box& box, double skin, CrossLevel mode) {
  const std::vector<double> radii(spheres.radius.data(), spheres.radius.data() + spheres.radius.size());
  return optimiseForSpheres(radii, box.volume(), skin, mode);
}

}  // namespace polydem::broadphase
