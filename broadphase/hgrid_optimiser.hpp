#pragma once
// The HGrid optimiser: the "optimal" cell-size rule (a direct minimisation of the cost model's eq. 2.35
// over s_1..s_{L-1}; the thesis used MATLAB fmincon, §2.2.5 "Optimal cell-size distribution") and the
// choice of the number of levels and the cross-level mode, plus the cache that keeps its answer while the
// spheres' radii, the box, the skin and K stay the same. The thesis recommends (§2.2.7) top-down, and
// either minimising eq. 2.35 for your own K or using a constant number of particles per cell.
//
// References (thesis numbering): V. Ogarko, PhD thesis on polydisperse smooth hard spheres (University of
// Twente), ch. 2; its ch. 2.1 is Ogarko & Luding, Comput. Phys. Commun. 183 (2012) 931 and its ch. 2.2 is
// Krijgsman, Ogarko & Luding, Comp. Part. Mech. 1 (2014) 357.
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "broadphase/hgrid_config.hpp"
#include "broadphase/hgrid_cost_evaluation.hpp"
#include "core/box.hpp"
#include "core/particle_store.hpp"

namespace polydem::broadphase {

/// "Optimal" rule: minimise T/N over s_1..s_{L-1} (s_L = maxDiameter() fixed) for one mode. Nelder-Mead
/// on u_h = log(s_h / s_{h-1}) = softmax(w)_h log(s_L / s_0) (monotone by construction), started from the
/// best of constant-m and `start` (if given, L sizes), then a BFGS polish with central-difference
/// gradients on the sorted log sizes (which lets surplus levels collapse onto s_L).
/// Returns L sizes (some may coincide: collapsed levels are empty and cost nothing).
std::vector<double> optimalCellSizes(const CostModelPsd& psd, int levels, CrossLevel mode,
                                     double K = kDefaultCellOverPairCost, std::span<const double> start = {});

struct OptimiserOptions {
  int maxLevels = 30;                   ///< L = 1..maxLevels are tried
  double K = kDefaultCellOverPairCost;  ///< cell access / pair test
  std::optional<CrossLevel> mode;       ///< restrict to one cross-level mode; nullopt = either
  double tolerance = 0.01;              ///< prefer the smallest L within this fraction of the minimum
};

/// Best sizes for one (L, mode); predicted = +inf when the mode was not evaluated.
struct LevelChoice {
  double predicted = std::numeric_limits<double>::infinity();  ///< T/N
  std::vector<double> cellSizes;                               ///< L sizes (may contain empty levels)
};

/// One row of the T/N(L) table (the data of the thesis's Figs. 2.5, 2.13-2.14).
struct LevelsRow {
  int levels = 0;
  LevelChoice topDown, bottomUp;                    ///< optimal rule
  LevelChoice constantMTopDown, constantMBottomUp;  ///< constant-m (q = 1) rule
};

/// A configuration the optimiser considered.
struct GridChoice {
  bool linkedCell = true;  ///< L = 1: a plain linked cell with cells of maxDiameter()
  HGridConfig config;      ///< occupied levels only, strictly increasing sizes
  int levels = 1;          ///< occupied levels
  double predicted = std::numeric_limits<double>::infinity();  ///< T/N
};

struct OptimiserResult {
  GridChoice chosen;
  /// The best configuration of the other kind: for an HGrid choice the better of the other mode and
  /// linked cell; for a linked-cell choice the best HGrid with at least two occupied levels (from the
  /// constant-m rule when every optimum collapsed to one level). Same L preference as `chosen`.
  GridChoice runnerUp;
  std::vector<LevelsRow> table;  ///< L = 1..maxLevels
  double seconds = 0.0;          ///< wall time of the optimisation
  /// One line: choice, prediction, runner-up.
  std::string summary() const;
};

/// For L = 1..maxLevels and each allowed mode, the optimal sizes; the minimum T/N wins, preferring the
/// fewest occupied levels within `tolerance` of it; one level is reported as linked cell. Well under 1 s for
/// maxLevels = 30 on any PSD (a sample costs O(N log N) once, in CostModelPsd::sample).
OptimiserResult optimiseHGrid(const CostModelPsd& psd, const OptimiserOptions& options = {});

/// The HGrid configurator: choose levels and sizes for these spheres (radii in m, any order) in a box
/// of `boxVolume` m^3 with pair distance `skin` (m). `mode` nullopt tries both modes. A linked-cell
/// choice comes back as one level of size 2 r_max + skin (an HGrid with L = 1 is a linked cell) whose
/// origin names "linked-cell"; origin always carries the prediction and the runner-up. An empty sample
/// gives empty cellSizes. Throws ConfigError like CostModelPsd::sample. O(N log N) + the optimiser.
HGridConfig optimiseForSpheres(std::span<const double> radii, double boxVolume, double skin,
                               std::optional<CrossLevel> mode = std::nullopt, double K = kDefaultCellOverPairCost);

/// optimiseForSpheres for the grid's own mode with the signature of HGrid::Configurator
/// (`grid.setConfigurator(configureHGrid)`), box volume from `box`, K = kDefaultCellOverPairCost (not
/// calibrated, not cached: for tests; the registry's grids use CachedGridOptimiser).
HGridConfig configureHGrid(const SphereView& spheres, const Box& box, double skin, CrossLevel mode);

/// The optimiser's result for a set of spheres, kept until an input changes: the radii (compared one by
/// one, O(N)), the box, the skin, the mode restriction or K. The one cache behind the registry's HGrid
/// configurator (CachedGridOptimiser) and `auto` (AutoSelect), so a DEM run that rebuilds every few
/// steps optimises once.
class OptimiserCache {
 public:
  /// optimiseHGrid() with default options but `mode` and `K` on the sample of the spheres' radii in
  /// box.volume(), or the stored result when every input equals the last call's. Throws ConfigError
  /// like CostModelPsd::sample (e.g. no spheres).
  const OptimiserResult& result(const SphereView& spheres, const Box& box, double skin, std::optional<CrossLevel> mode,
                                double K);
  /// The same for a sample of radii alone (e.g. the whole system's, when each build sees a part of it).
  const OptimiserResult& result(std::span<const double> radii, const Box& box, double skin,
                                std::optional<CrossLevel> mode, double K);
  /// Whether the last result() call ran the optimiser (false: the stored result was returned).
  bool recomputed() const { return recomputed_; }
  /// Forget the stored result: the next result() call optimises.
  void clear() { valid_ = false; }

 private:
  bool holds(std::span<const double> radii, const Box& box, double skin, std::optional<CrossLevel> mode,
             double K) const;

  std::vector<double> radii_;
  Box box_;
  double skin_ = -1.0;
  std::optional<CrossLevel> mode_;
  double K_ = -1.0;
  bool valid_ = false;
  bool recomputed_ = false;
  OptimiserResult result_;
};

/// The registry's HGrid configurator (HGrid::setConfigurator): the optimiser for the grid's own mode
/// with the calibrated K (modelCostRatio(), calibrate_k.hpp), through an OptimiserCache.
class CachedGridOptimiser {
 public:
  HGridConfig operator()(const SphereView& spheres, const Box& box, double skin, CrossLevel mode);

 private:
  OptimiserCache cache_;
};

}  // namespace polydem::broadphase
