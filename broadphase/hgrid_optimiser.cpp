// The HGrid optimiser; see hgrid_optimiser.hpp.
//
// * The optimal rule first runs Nelder-Mead (minimisers.hpp) on softmax weights, u_h = log(s_h / s_{h-1})
//   = softmax(w)_h log(s_L / s_0), w_L = 0: monotone by construction, unconstrained, end sizes fixed.
//   Then BFGS with central-difference gradients (the thesis used SQP + BFGS via MATLAB fmincon, §2.2.5)
//   on x_h = log s_h, sorted and clamped into [s_0, s_L]. The polish does not use the weights: their
//   normaliser couples every level, and BFGS on them stalled about 1e-5 above the optimum (11.57374 vs
//   11.57361 at alpha = -3, omega = 100, L = 8); on log sizes it reaches the optimal sizes to 4 digits,
//   and surplus levels can collapse onto s_L exactly (empty, free), which the optimum does for L > 8
//   there (thesis Fig. 2.15). Rejected: coordinate descent (slow on the chained coupling of neighbouring
//   sizes).
// * Warm start: the optimum for L - 1 with one level split (tried at every level) is a feasible L-level
//   configuration, so the tabulated optimum never increases with L; the constant-m sizes are the
//   other start.
#include "broadphase/hgrid_optimiser.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <functional>

#include "broadphase/calibrate_k.hpp"
#include "broadphase/hgrid_cell_sizes.hpp"
#include "broadphase/hgrid_cost_checks.hpp"
#include "broadphase/minimisers.hpp"

namespace polydem::broadphase {

using detail::degenerate;
using detail::requireFiniteNonNegative;
using detail::requireLevels;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

const char* modeName(CrossLevel mode) { return mode == CrossLevel::TopDown ? "td" : "bu"; }

// ---- the optimal rule ---------------------------------------------------------------------------------

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

/// Cost model T/N as a function of the free parameters, softmax weights or sorted log sizes.
struct SizeObjective {
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
  SizeObjective soft{psd, map, mode, K, false, {}};
  std::vector<double> x;
  map.toWeights(best, x);
  nelderMead(std::ref(soft), x, 0.3, search.nelderMeadBase + search.nelderMeadPerDimension * map.dimension(), 1e-9);
  std::vector<double> sizes;
  map.toSizes(x.data(), sizes);
  keep(sizes);
  // BFGS polish on log sizes (better conditioned than the weights, whose normaliser couples all
  // levels). Central differences: a sample's objective is a fine staircase (a particle changing level
  // moves T/N by O(1/N)), so its step must span many particles.
  SizeObjective logs{psd, map, mode, K, true, {}};
  map.sizesToLog(best, x);
  // Gains below a tenth of one particle changing level are noise for a sample.
  const double N = psd.sampleSize();
  const double h = psd.isSample() ? std::clamp(3.0 / std::sqrt(N), 1e-5, 0.05) : 1e-6;
  const double minGain = psd.isSample() ? std::max(1e-12, 0.1 / N) : 1e-12;
  bfgs(std::ref(logs), x, logs(x.data()), h, search.bfgsIterations, minGain);
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

// ---- the level/mode optimiser ------------------------------------------------------------------------

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
  thread_local std::vector<std::array<double, 4>> bands;
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

  // Selection: the fewest occupied levels within the tolerance of the minimum
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

// ---- the cache ----------------------------------------------------------------------------------------

bool OptimiserCache::holds(std::span<const double> radii, const Box& box, double skin, std::optional<CrossLevel> mode,
                           double K) const {
  return valid_ && box == box_ && skin == skin_ && mode == mode_ && K == K_ &&
         std::equal(radii.begin(), radii.end(), radii_.begin(), radii_.end());
}

const OptimiserResult& OptimiserCache::result(const SphereView& spheres, const Box& box, double skin,
                                              std::optional<CrossLevel> mode, double K) {
  return result(std::span<const double>(spheres.radius.data(), static_cast<std::size_t>(spheres.count())), box, skin,
                mode, K);
}

const OptimiserResult& OptimiserCache::result(std::span<const double> radii, const Box& box, double skin,
                                              std::optional<CrossLevel> mode, double K) {
  recomputed_ = !holds(radii, box, skin, mode, K);
  if (recomputed_) {
    valid_ = false;  // until the optimiser has succeeded
    radii_.assign(radii.begin(), radii.end());
    OptimiserOptions options;
    options.K = K;
    options.mode = mode;
    result_ = optimiseHGrid(CostModelPsd::sample(radii_, box.volume(), skin), options);
    box_ = box;
    skin_ = skin;
    mode_ = mode;
    K_ = K;
    valid_ = true;
  }
  return result_;
}

HGridConfig CachedGridOptimiser::operator()(const SphereView& spheres, const Box& box, double skin, CrossLevel mode) {
  return cache_.result(spheres, box, skin, mode, modelCostRatio()).chosen.config;
}

}  // namespace polydem::broadphase
