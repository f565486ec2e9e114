#pragma once
// The load LP of the random-load jamming tests (jamming/load_protocols.hpp) and what both protocols share:
// its constraints for the spheres' current centres, its two solvers, the local rattler LP, the scaling
// to the first true collision, and LoadProblem (one test's spheres, loads, pins and solver). Internal to
// polydem_jamming.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <chrono>
#include <random>
#include <string>
#include <vector>

#include "core/box.hpp"
#include "jamming/load_protocols.hpp"

namespace polydem::jamming::detail {

// The load LP in displacement form: max beta.x s.t. A^T x >= -h, |x_c| <= X,
// pinned coordinates fixed at 0. Columns of A (contacts) as triplets (coordinate, row, value).
struct LoadLp {
  int cols = 0;  // coordinates 3 x movable
  int rows = 0;  // constraints
  std::vector<Eigen::Triplet<double>> entries;
  std::vector<double> gap;
  std::vector<char> pinned;  // per coordinate
  double bound = 10.0;
  std::vector<double> columnBound;          // per coordinate if not empty (overrides bound)
  std::vector<std::array<Index, 2>> pairs;  // per constraint: spheres i, j (j = -1 - wall for a wall)
  std::vector<Eigen::Vector3d> normal;      // per constraint: u with u . (dR_i - dR_j) >= -h (walls: dR_j = 0)
};

/// GLPK's simplex on `lp` with objective beta; the optimal x. Throws SimulationError if GLPK fails.
std::vector<double> solveLoadSimplex(const LoadLp& lp, const std::vector<double>& beta);

/// The interior point on the force form of `lp`; the optimal x; adds its iterations to `iterations`.
std::vector<double> solveLoadInteriorPoint(const LoadLp& lp, const std::vector<double>& beta, int& iterations);

/// Constraints of the load LP for the spheres' current centres: every pair of movable spheres (slot >= 0)
/// with gap <= gapTolerance (r_i + r_j), and the walls; lengths in units of `diameter`. strict: six strain
/// columns after the coordinates and the volume row.
LoadLp buildLoadLp(const SphereView& spheres, const Box& box, const std::vector<int>& slot, double gapTolerance,
                   double diameter, bool strict = false);

/// Unloads (loaded[m] = 0) the loaded spheres that move further than `limit` alone; their number.
Index markLocalRattlers(const LoadLp& lp, const std::vector<int>& slot, std::vector<char>& loaded, double limit,
                        std::mt19937_64& rng);

/// Largest t such that moving every sphere i by t dr_i from `centre` keeps the pairs and walls of `lp`
/// disjoint, capped where pairs outside `lp` could meet.
double largestScaling(const LoadLp& lp, const Eigen::Matrix3Xd& centre, const Eigen::VectorXd& radius, const Box& box,
                      const Eigen::Matrix3Xd& dr, double gapTolerance);

/// One load test's shared state: the movable and loaded spheres, the first load LP, the random loads
/// (zero net force), the pinned sphere and the LP solver with its counts.
class LoadProblem {
 public:
  LoadProblem(const SphereView& spheres, const Box& box, const ContactNetwork& network, const LoadTestOptions& options,
              LoadProtocol protocol);
  /// Validates the options and builds the first LP and the local rattlers; false if that decided the test
  /// (no spheres, no backbone, nothing locally jammed: `out` says so). Throws ConfigError for bad options.
  bool prepare(LoadTestSummary& out);
  /// A random load on the loaded spheres with zero net force (no drift of the whole packing).
  std::vector<double> randomLoad();
  /// Pin the first loaded sphere on the periodic axes (the trivial translations).
  void pin(LoadLp& lp) const;
  /// Solve with the chosen solver (GLPK failures fall back to the interior point).
  std::vector<double> solve(const LoadLp& lp, const std::vector<double>& beta);
  std::string solverName() const;
  double elapsed() const;

  const SphereView& spheres;
  const Box& box;
  const LoadTestOptions& options;
  Index n = 0;
  std::vector<int> slot;       ///< per sphere: movable index, -1 if removed
  std::vector<Index> movable;  ///< the spheres that are variables
  std::vector<char> loaded;    ///< per movable sphere: carries load (backbone, not set aside)
  std::int64_t backboneCount = 0;
  double diameter = 0.0;  ///< the mean diameter, the LP's length unit
  LoadLp lp;              ///< the first LP
  int cols = 0;

 private:
  const ContactNetwork& network_;
  LoadProtocol protocol_;
  std::chrono::steady_clock::time_point start_;
  bool useSimplex_ = false;
  int ipIterations_ = 0, lps_ = 0, fallbacks_ = 0;
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_;
};

/// ConfigError unless options.loads >= 1.
void requireLoads(const LoadTestOptions& options);

}  // namespace polydem::jamming::detail
