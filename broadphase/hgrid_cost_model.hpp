#pragma once
// Expected work of the hierarchical grid (HGrid) and the optimiser that picks its levels and cell sizes.
//
// Model: seed 000 ch. 2.2.3, eqs. 2.14-2.35 (shared/seeds/000_3b5cd2443ded9063.txt:2096-2589; digest
// shared/spec/hgrid-and-polydispersity.md §2.3). Centres uniformly random (excluded volume ignored),
// radii i.i.d. from f(r); d = 3, n_c = 13 half-neighbour cells. Per particle, in units of one pair test,
//   T/N = sum_h P_h [ (1/2 + n_c) m_h + K (1 + n_c) + sum_{j in J(h)} (m_j + K) b(j, h) ]      (2.31-2.35)
// P_h = fraction of particles inserted at level h, m_h = particles per cell there (2.19), b(j, h) = mean
// number of level-j cells a level-h particle scans (2.24), J(h) = {1..h-1} top-down, {h+1..L} bottom-up.
// K = (time of one cell access) / (time of one pair test) (digest §2.3: the seed's wording at :2567 is
// inverted, eq. 2.35 and the time unit at :3311 need this reading). Empty levels are dropped before
// evaluating: the grid skips them.
//
// Skin: every radius here is the interaction radius r + skin / 2. A particle goes to the first level with
// 2 r + skin <= s_h (the HGrid insertion rule), and searches level j with half-width r + skin/2 + s_j/2,
// which is complete because every level-j particle has 2 r + skin <= s_j. The cell-size conventions become
// s_0 = 2 r_min + skin and s_L = 2 r_max + skin ("interaction diameters"). Number densities still come
// from the true radii: for an analytic PSD n = nu / V_p with V_p = (4 pi / 3) <r^3> (2.14).
//
// b(j, h) is a cubic polynomial in r (binomial expansion of (2 r / s_j + 2)^3, or the per-axis product for
// snapped cells), so every per-level quantity needs only the partial moments int r^k f(r) dr, k = 0..3,
// over the level's band: exact for an analytic SizeDistribution, O(log N) prefix sums for a sample.
//
// Cell-size rules (seed ch. 2.2.5, :2664-3040): linear (2.42), exponential (2.43-2.44), constant ratio q
// of particles per cell (2.45-2.47; q = 1 is the ch. 2.1 hypothesis, eq. 2.6 at :1167), the ch. 2.1
// appendix procedure on a sample (:1490-1535), and "optimal": a direct minimisation of eq. 2.35 over
// s_1..s_{L-1} (the seed used MATLAB fmincon, :3019-3040; here Nelder-Mead then a BFGS polish, both
// written out in hgrid_cost_model.cpp). Recommendations of the seed (:3319-3335): top-down, and either
// minimise eq. 2.35 for your own K or use constant m.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "broadphase/hgrid_config.hpp"
#include "core/box.hpp"
#include "core/particle_store.hpp"
#include "core/size_distribution.hpp"
#include "core/types.hpp"

namespace polydem::broadphase {

/// n_c: cells of the forward half neighbourhood in 3-D, (3^3 - 1) / 2.
inline constexpr int kHalfNeighbourCells = 13;
/// K used when nothing was measured: seed 000 ch. 2.2 (:2567-2573); calibrate_k.hpp measures it.
inline constexpr double kDefaultCellOverPairCost = 0.2;

/// The particle-size information the cost model needs, from an analytic distribution or a sample.
/// Cheap to copy (a sample's sorted radii and prefix sums are shared).
class CostModelPsd {
 public:
  /// Analytic f(r) at packing fraction nu (of the true radii). `distribution` must outlive this object.
  /// Throws ConfigError for nu <= 0, skin < 0, non-finite values, or an unbounded distribution (r_max =
  /// inf or r_min = 0: truncate a log-normal first). nu may exceed 1: centres are allowed to overlap.
  static CostModelPsd analytic(const SizeDistribution& distribution, double packingFraction, double skin = 0.0);
  /// A sample of radii (m, any order) in a box of volume `boxVolume` (m^3). O(N log N): sorts a copy and
  /// builds prefix sums of r^k. Throws ConfigError for an empty sample, a non-positive or non-finite
  /// radius, boxVolume <= 0 or skin < 0.
  static CostModelPsd sample(std::span<const double> radii, double boxVolume, double skin = 0.0);

  bool isSample() const { return sample_ != nullptr; }
  /// Sample size N (0 for an analytic PSD).
  Index sampleSize() const;
  double skin() const { return skin_; }
  /// Smallest interaction diameter 2 r_min + skin (m); the seed's s_0.
  double minDiameter() const { return minDiameter_; }
  /// Largest interaction diameter 2 r_max + skin (m); the top cell size s_L.
  double maxDiameter() const { return maxDiameter_; }
  /// Particles per unit volume (1/m^3): N / V_box, or nu / V_p.
  double numberDensity() const { return numberDensity_; }
  /// {P, <r; band>, <r^2; band>, <r^3; band>}: number fraction and partial moments sum r^k / N (or
  /// int r^k f dr) of the particles with interaction diameter 2 r + skin in (lo, hi] (m). Analytic: four
  /// partialMoment calls; sample: two binary searches.
  std::array<double, 4> band(double lo, double hi) const;
  /// Number fraction with interaction diameter in (lo, hi]: band(lo, hi)[0] at a quarter of the cost.
  double fraction(double lo, double hi) const;
  /// band() of the consecutive levels (0, s_1], (s_1, s_2], ..., (s_{L-1}, s_L] into `out` (resized to L).
  /// A sample needs one binary search per size; an analytic PSD differences cumulative moments, which a
  /// small per-thread cache keeps across calls (an optimiser moves one size at a time).
  void levelBands(std::span<const double> cellSizes, std::vector<std::array<double, 4>>& out) const;
  /// Number of sample particles with 2 r + skin <= diameter (O(log N)); samples only.
  Index countAtMost(double diameter) const;
  /// Ascending radii of a sample (empty for an analytic PSD).
  std::span<const double> sortedRadii() const;
  /// e.g. "sample N=125001 V=... skin=0" or "uniform-volume rmin=1 omega=100, nu=0.7, skin=0".
  std::string describe() const;

 private:
  struct Sample;
  CostModelPsd() = default;
  const SizeDistribution* distribution_ = nullptr;
  std::shared_ptr<const Sample> sample_;
  double skin_ = 0.0;
  double minDiameter_ = 0.0;
  double maxDiameter_ = 0.0;
  double numberDensity_ = 0.0;
  double packingFraction_ = 0.0;
  std::array<double, 4> totalMoments_{};  // <r^k>, analytic
  std::uint64_t id_ = 0;                  // cache key of the analytic cumulative moments
};

/// One level as the grid realises it. For the plain model all lengths equal s_h; a periodic box snaps
/// the cell edge up to L_k / floor(L_k / s_h) per axis while insertion may keep the nominal s_h.
/// A level-h particle then scans (2 r + skin + searchSize_k) / cellEdge_k + 1 cells along axis k on
/// average (seed appendix of ch. 2.2, eqs. 2.55-2.64 at :3579-3921: the mean of the per-axis count over
/// a uniform centre is the box width over the cell edge plus one), i.e. 2 r / s + 2 + skin / s for plain
/// cells.
struct LevelGeometry {
  double insertionSize = 0.0;          ///< s_h (m): holds particles with s_{h-1} < 2 r + skin <= s_h
  std::array<double, 3> cellEdge{};    ///< actual cell edge per axis (m); cell volume = product
  std::array<double, 3> searchSize{};  ///< the s_j in the search half-width r + skin/2 + s_j/2 (m)
};

/// Plain cubic cells: edge = insertion size = search size (the seed's model).
std::vector<LevelGeometry> cubicGeometry(std::span<const double> cellSizes);

/// Cells of a rectangular box with edges `boxLengths` (m): n_hk = floor(L_k / (s_h (1 + snapMargin))),
/// clamped to [1, 2^20], cells per axis of edge s'_hk = L_k / n_hk, so N^c_h = prod_k n_hk. The default
/// margin is the HGrid's (hgrid::kSnapMargin: a size dividing the box exactly is rounded down by one
/// cell), so model and counters see the same cells. Insertion uses the nominal s_h. The search
/// half-width uses the nominal s_h (complete, since level-h particles have 2 r + skin <= s_h, and
/// tighter), or s'_hk per axis when `searchWithCellEdge` (a grid that computes beta from its cell edge).
/// A grid that also inserts by the snapped edge of a cubic box is cubicGeometry(snapped sizes).
/// Not modelled: clamping of a search box that wraps a whole periodic axis, the aliasing of neighbour
/// cells when n_hk < 3, and walls (cells behind a wall do not exist, so walled boxes need less work,
/// seed :3199-3215). With periodic boxes and n_hk >= 3 the model matches the HGrid's counters to 0.1%
/// (hgrid_cost_model_test.cpp).
std::vector<LevelGeometry> snappedGeometry(std::span<const double> cellSizes, const Eigen::Vector3d& boxLengths,
                                           bool searchWithCellEdge = false, double snapMargin = 1e-9);

/// One occupied level of a cost evaluation; work is per particle of the whole system.
struct LevelCost {
  double insertionSize = 0.0;        ///< s_h (m)
  std::array<double, 3> cellEdge{};  ///< s'_hk (m)
  double fraction = 0.0;             ///< P_h = N_h / N
  double perCell = 0.0;              ///< m_h = N_h / N^c_h
  double pairTests = 0.0;            ///< T^cd_h / N (eqs. 2.31/2.33)
  double cellAccesses = 0.0;         ///< T^ca_h / N (eqs. 2.32/2.34)
};

struct CostBreakdown {
  std::vector<LevelCost> levels;  ///< occupied levels only (empty ones are dropped), ascending s_h
  double pairTests = 0.0;         ///< T^cd / N
  double cellAccesses = 0.0;      ///< T^ca / N
  double total = 0.0;             ///< T / N = T^cd / N + K T^ca / N (eq. 2.35)
};

/// T/N of eq. 2.35 for nominal cubic cells s_1 <= ... <= s_L (m; s_L >= maxDiameter()), cross-level
/// mode and K. O(L^2) arithmetic plus one levelBands() call; no allocation after the first call on a
/// thread.
/// Particles larger than s_L are not modelled (precondition).
double costPerParticle(const CostModelPsd& psd, std::span<const double> cellSizes, CrossLevel mode,
                       double K = kDefaultCellOverPairCost);

/// The same with the per-level breakdown, for any geometry (cubicGeometry, snappedGeometry).
/// `exactOwnCell` uses 1/2 m_h (N_h - 1) / N_h own-cell pairs (eq. 2.20 before the N_h >> 1 step;
/// samples only): the right choice when comparing with counted work on small samples.
CostBreakdown costBreakdown(const CostModelPsd& psd, std::span<const LevelGeometry> levels, CrossLevel mode,
                            double K = kDefaultCellOverPairCost, bool exactOwnCell = false);
CostBreakdown costBreakdown(const CostModelPsd& psd, std::span<const double> cellSizes, CrossLevel mode,
                            double K = kDefaultCellOverPairCost);

// ---- cell-size rules: each returns L non-decreasing sizes s_1..s_L with s_L = maxDiameter() ----------

/// Linear rule, eq. 2.42: s_h = s_0 + h (s_L - s_0) / L.
std::vector<double> linearCellSizes(const CostModelPsd& psd, int levels);
/// Exponential rule, eqs. 2.43-2.44: s_h = s_0 (s_L / s_0)^(h / L).
std::vector<double> exponentialCellSizes(const CostModelPsd& psd, int levels);
/// Constant ratio q of particles per cell, m_{h+1} = q m_h (eqs. 2.45-2.47): bisection on m_1, each
/// trial sweeping the levels upward and solving m_h(s_h) = q^(h-1) m_1 for s_h; the smallest admissible
/// m_1 is kept (the top level holds at most its share). q = 1 is the seed's ch. 2.1 hypothesis.
/// A PSD that cannot fill L levels (e.g. monodisperse) gets trailing sizes equal to s_L (empty levels).
std::vector<double> constantRatioCellSizes(const CostModelPsd& psd, int levels, double q = 1.0);

/// Result of the ch. 2.1 appendix procedure (:1490-1535) for one number of levels.
struct AppendixLevels {
  int levels = 0;                 ///< L
  double perCell = 0.0;           ///< m(L, PSD): the smallest m with L(m) = L
  double cost = 0.0;              ///< L (m + K), eq. 2.7 up to the factor N
  std::vector<double> cellSizes;  ///< s_h = 2 (largest radius on level h) + skin
};
struct AppendixResult {
  std::vector<AppendixLevels> table;  ///< every attainable L in 1..maxLevels, ascending
  int optimalLevels = 1;              ///< ONL = argmin L (m(L) + K) (:1198-1204)
  const AppendixLevels& optimal() const;
};
/// Number of levels L(m) of the appendix procedure for particles-per-cell limit m, on a sample sorted
/// ascending, with N^c = V_box / (2 r_i + skin)^3 (the seed's [S / (2 r_i)]^d taken as a real number,
/// digest §2.2). O(L log N).
int appendixLevelCount(std::span<const double> sortedRadii, double boxVolume, double skin, double m);
/// m(L) for L = 1..maxLevels by bisection on m (L(m) is non-increasing), and the ONL for this K.
/// The seed found K = 0.3 adequate for ch. 2.1 (:1192-1196). O(maxLevels * 60 * L log N).
AppendixResult appendixProcedure(std::span<const double> radii, double boxVolume, double skin, double K = 0.3,
                                 int maxLevels = 30);

/// "Optimal" rule: minimise T/N over s_1..s_{L-1} (s_L = maxDiameter() fixed) for one mode. Nelder-Mead
/// on u_h = log(s_h / s_{h-1}) = softmax(w)_h log(s_L / s_0) (monotone by construction), started from the
/// best of constant-m and `start` (if given, L sizes), then a BFGS polish with central-difference
/// gradients on the sorted log sizes (which lets surplus levels collapse onto s_L).
/// Returns L sizes (some may coincide: collapsed levels are empty and cost nothing).
std::vector<double> optimalCellSizes(const CostModelPsd& psd, int levels, CrossLevel mode,
                                     double K = kDefaultCellOverPairCost, std::span<const double> start = {});

// ---- the optimiser -----------------------------------------------------------------------------------

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

/// One row of the T/N(L) table (the data of the seed's Figs. 2.5, 2.13-2.14).
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
/// (`grid.setConfigurator(configureHGrid)`), box volume from `box`, K = 0.2.
HGridConfig configureHGrid(const SphereView& spheres, const Box& box, double skin, CrossLevel mode);

}  // namespace polydem::broadphase
