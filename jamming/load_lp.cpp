#include "jamming/load_lp.hpp"

#include <fmt/format.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "core/errors.hpp"
#include "jamming/glpk_simplex.hpp"
#include "jamming/interior_point.hpp"

namespace polydem::jamming::detail {

#if POLYDEM_JAMMING_WITH_GLPK
std::vector<double> solveLoadSimplex(const LoadLp& lp, const std::vector<double>& beta) {
  glpk::Lp glpk;
  glp_set_obj_dir(glpk.p, GLP_MAX);
  if (lp.rows > 0) glp_add_rows(glpk.p, lp.rows);
  glp_add_cols(glpk.p, lp.cols);
  for (int r = 1; r <= lp.rows; ++r) glp_set_row_bnds(glpk.p, r, GLP_LO, -lp.gap[static_cast<std::size_t>(r - 1)], 0.0);
  for (int c = 1; c <= lp.cols; ++c) {
    if (lp.pinned[static_cast<std::size_t>(c - 1)]) {
      glp_set_col_bnds(glpk.p, c, GLP_FX, 0.0, 0.0);
    } else {
      const double x = lp.columnBound.empty() ? lp.bound : lp.columnBound[static_cast<std::size_t>(c - 1)];
      glp_set_col_bnds(glpk.p, c, GLP_DB, -x, x);
    }
    glp_set_obj_coef(glpk.p, c, beta[static_cast<std::size_t>(c - 1)]);
  }
  std::vector<int> ia{0}, ja{0};
  std::vector<double> ar{0.0};
  for (const auto& t : lp.entries) {
    ia.push_back(t.col() + 1);
    ja.push_back(t.row() + 1);
    ar.push_back(t.value());
  }
  if (lp.rows > 0) glp_load_matrix(glpk.p, static_cast<int>(ar.size()) - 1, ia.data(), ja.data(), ar.data());
  const int status = glpk::solve(glpk.p);
  if (status != GLP_OPT) throw SimulationError(fmt::format("jamming test: load LP status {}", status));
  std::vector<double> x(static_cast<std::size_t>(lp.cols));
  for (int c = 1; c <= lp.cols; ++c) x[static_cast<std::size_t>(c - 1)] = glp_get_col_prim(glpk.p, c);
  return x;
}
#endif

// Force form (Donev 2006, eq. 4.12, with the box): min h.f + X 1.(g + k) s.t. A f - g + k = -beta, f, g, k >= 0,
// over the free coordinates; the displacements are x = -y.
std::vector<double> solveLoadInteriorPoint(const LoadLp& lp, const std::vector<double>& beta, int& iterations) {
  std::vector<int> freeIndex(static_cast<std::size_t>(lp.cols), -1);
  int m = 0;
  for (int c = 0; c < lp.cols; ++c) {
    if (!lp.pinned[static_cast<std::size_t>(c)]) freeIndex[static_cast<std::size_t>(c)] = m++;
  }
  const int n = lp.rows + 2 * m;
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(lp.entries.size() + 2 * static_cast<std::size_t>(m));
  for (const auto& e : lp.entries) {
    const int f = freeIndex[static_cast<std::size_t>(e.row())];
    if (f >= 0) t.emplace_back(f, e.col(), e.value());
  }
  for (int f = 0; f < m; ++f) {
    t.emplace_back(f, lp.rows + f, -1.0);
    t.emplace_back(f, lp.rows + m + f, 1.0);
  }
  Eigen::SparseMatrix<double> e(m, n);
  e.setFromTriplets(t.begin(), t.end());
  Eigen::VectorXd r(m), cost(n);
  for (int c = 0; c < lp.cols; ++c) {
    const int f = freeIndex[static_cast<std::size_t>(c)];
    if (f >= 0) r[f] = -beta[static_cast<std::size_t>(c)];
  }
  for (int k = 0; k < lp.rows; ++k) cost[k] = lp.gap[static_cast<std::size_t>(k)];
  cost.tail(2 * m).setConstant(lp.bound);
  if (!lp.columnBound.empty()) {
    for (int c = 0; c < lp.cols; ++c) {
      const int f = freeIndex[static_cast<std::size_t>(c)];
      if (f < 0) continue;
      cost[lp.rows + f] = cost[lp.rows + m + f] = lp.columnBound[static_cast<std::size_t>(c)];
    }
  }
  InteriorPointOptions ipOptions;
  ipOptions.trace = std::getenv("POLYDEM_IP_TRACE") != nullptr;
  const InteriorPointResult ip = solveStandardFormLp(e, r, cost, ipOptions);
  // The displacements are the dual iterate: usable when it is feasible (small dual residual) and its value
  // is close to the primal bound, even if the force balance (primal residual) stalled above tolerance.
  const double gap = std::abs(ip.primalObjective - ip.dualObjective) / (1.0 + std::abs(ip.primalObjective));
  if (!ip.converged && !(ip.dualResidual < 1e-8 && gap < 1e-6)) {
    throw SimulationError(fmt::format("jamming test: interior-point load LP: {}", ip.message));
  }
  iterations += ip.iterations;
  std::vector<double> x(static_cast<std::size_t>(lp.cols), 0.0);
  for (int c = 0; c < lp.cols; ++c) {
    const int f = freeIndex[static_cast<std::size_t>(c)];
    if (f >= 0) x[static_cast<std::size_t>(c)] = -ip.y[f];
  }
  return x;
}

// Constraints of the load LP for the spheres' current centres: every pair of movable spheres (slot >= 0)
// with gap <= gapTolerance (r_i + r_j), and the walls; lengths in units of `diameter`.
LoadLp buildLoadLp(const SphereView& spheres, const Box& box, const std::vector<int>& slot, double gapTolerance,
                   double diameter, bool strict) {
  ContactOptions near;
  near.relativeGap = gapTolerance;
  const ContactNetwork wide = analyseContacts(spheres, box, near);
  LoadLp lp;
  lp.cols = 0;
  for (int s : slot) lp.cols = std::max(lp.cols, 3 * (s + 1));
  const int strain = lp.cols;  // strict: six Voigt strain columns after the coordinates
  if (strict) lp.cols += 6;
  for (const auto& c : wide.contacts) {
    const int bi = slot[static_cast<std::size_t>(c.i)], bj = slot[static_cast<std::size_t>(c.j)];
    if (bi < 0 || bj < 0) continue;
    const Eigen::Vector3d d = box.minimumImage(spheres.centre.col(c.i) - spheres.centre.col(c.j));
    const double dist = d.norm();
    const Eigen::Vector3d u = d / dist;
    for (int k = 0; k < 3; ++k) {
      lp.entries.emplace_back(3 * bi + k, lp.rows, u[k]);
      lp.entries.emplace_back(3 * bj + k, lp.rows, -u[k]);
    }
    if (strict) {
      // Deforming lattice (Donev 2006, §4.4.5.2, eq. 4.20-4.21): a contact through the boundary also changes
      // by u^T eps (Lambda n), Lambda n the image shift; eps symmetric, Voigt (11, 22, 33, 2x23, 2x13, 2x12).
      const Eigen::Vector3d shift = (d - (spheres.centre.col(c.i) - spheres.centre.col(c.j))) / diameter;
      if (shift.squaredNorm() > 0.0) {
        const double a[6] = {u[0] * shift[0],
                             u[1] * shift[1],
                             u[2] * shift[2],
                             0.5 * (u[1] * shift[2] + u[2] * shift[1]),
                             0.5 * (u[0] * shift[2] + u[2] * shift[0]),
                             0.5 * (u[0] * shift[1] + u[1] * shift[0])};
        for (int v = 0; v < 6; ++v) {
          if (a[v] != 0.0) lp.entries.emplace_back(strain + v, lp.rows, a[v]);
        }
      }
    }
    lp.gap.push_back(std::max(0.0, dist - (spheres.radius[c.i] + spheres.radius[c.j])) / diameter);
    lp.pairs.push_back({c.i, c.j});
    lp.normal.push_back(u);
    ++lp.rows;
  }
  for (const WallContact& w : wide.wallContacts) {
    const int bi = slot[static_cast<std::size_t>(w.i)];
    if (bi < 0) continue;
    const int k = w.wall / 2;
    const double x = spheres.centre(k, w.i), r = spheres.radius[w.i];
    lp.entries.emplace_back(3 * bi + k, lp.rows, w.wall % 2 ? -1.0 : 1.0);
    lp.gap.push_back(std::max(0.0, w.wall % 2 ? box.length(k) - x - r : x - r) / diameter);
    lp.pairs.push_back({w.i, -1 - w.wall});
    lp.normal.push_back((w.wall % 2 ? -1.0 : 1.0) * Eigen::Vector3d::Unit(k));
    ++lp.rows;
  }
  if (strict) {
    // The cell volume must not grow: -Tr eps >= 0 (Donev 2006, eq. 4.17, 4.19).
    for (int v = 0; v < 3; ++v) lp.entries.emplace_back(strain + v, lp.rows, -1.0);
    lp.gap.push_back(0.0);
    lp.pairs.push_back({-1, -1});
    lp.normal.push_back(Eigen::Vector3d::Zero());
    ++lp.rows;
  }
  return lp;
}

namespace {

// Local jamming LP of one sphere with its neighbours held fixed (Donev 2006, §4.4.3.1, eq. 4.15): max b . x over
// x in R^3 with a_k . x >= -h_k and |x_c| <= box. Three unknowns: the optimum is a vertex, found by trying
// every triple of constraints (the box faces included). Returns the optimal x.
Eigen::Vector3d localLoadOptimum(const std::vector<Eigen::Vector3d>& a, const std::vector<double>& h,
                                 const Eigen::Vector3d& b, double box) {
  std::vector<Eigen::Vector3d> rows = a;
  std::vector<double> rhs;
  for (double g : h) rhs.push_back(-g);
  for (int k = 0; k < 3; ++k) {
    rows.push_back(Eigen::Vector3d::Unit(k));
    rhs.push_back(-box);
    rows.push_back(-Eigen::Vector3d::Unit(k));
    rhs.push_back(-box);
  }
  const std::size_t m = rows.size();
  Eigen::Vector3d best = Eigen::Vector3d::Zero();
  double bestValue = -std::numeric_limits<double>::infinity();
  const double tolerance = 1e-12 * (1.0 + box);
  for (std::size_t p = 0; p < m; ++p) {
    for (std::size_t q = p + 1; q < m; ++q) {
      for (std::size_t r = q + 1; r < m; ++r) {
        Eigen::Matrix3d mat;
        mat.row(0) = rows[p].transpose();
        mat.row(1) = rows[q].transpose();
        mat.row(2) = rows[r].transpose();
        const double det = mat.determinant();
        if (std::abs(det) < 1e-10) continue;
        const Eigen::Vector3d x = mat.inverse() * Eigen::Vector3d(rhs[p], rhs[q], rhs[r]);
        if (b.dot(x) <= bestValue) continue;
        bool feasible = true;
        for (std::size_t k = 0; k < m && feasible; ++k) feasible = rows[k].dot(x) >= rhs[k] - tolerance;
        if (feasible) {
          bestValue = b.dot(x);
          best = x;
        }
      }
    }
  }
  return best;
}

}  // namespace

// Rattlers by the local LP (Donev 2006, Algorithm 14 step 3; Algorithm 13 step 4): a loaded sphere
// that moves further than `limit` (mean diameters) under a random load or its opposite with every
// neighbour held fixed is unloaded (it keeps its constraints, §4.6.2.2). Catches spheres with four or
// more contacts in a degenerate arrangement (e.g. three coplanar, Donev 2006 §9.3.1), which the contact
// count misses. Only constraints with gap below sqrt(3) x 2 limit can bind inside the box |x_c| <= 2 limit.
Index markLocalRattlers(const LoadLp& lp, const std::vector<int>& slot, std::vector<char>& loaded, double limit,
                        std::mt19937_64& rng) {
  const std::size_t movable = loaded.size();
  std::vector<std::vector<int>> rowsOf(movable);
  const double reach = 2.0 * std::sqrt(3.0) * limit;
  for (int r = 0; r < lp.rows; ++r) {
    if (lp.gap[static_cast<std::size_t>(r)] > reach) continue;
    const auto& [i, j] = lp.pairs[static_cast<std::size_t>(r)];
    if (i < 0) continue;  // the trace row of the strict test
    rowsOf[static_cast<std::size_t>(slot[static_cast<std::size_t>(i)])].push_back(r + 1);
    if (j >= 0) rowsOf[static_cast<std::size_t>(slot[static_cast<std::size_t>(j)])].push_back(-(r + 1));
  }
  std::normal_distribution<double> normal;
  Index marked = 0;
  std::vector<Eigen::Vector3d> a;
  std::vector<double> h;
  for (std::size_t m = 0; m < movable; ++m) {
    if (!loaded[m]) continue;
    a.clear();
    h.clear();
    for (int signedRow : rowsOf[m]) {
      const std::size_t r = static_cast<std::size_t>(std::abs(signedRow) - 1);
      a.push_back(signedRow > 0 ? lp.normal[r] : Eigen::Vector3d(-lp.normal[r]));
      h.push_back(lp.gap[r]);
    }
    Eigen::Vector3d b(normal(rng), normal(rng), normal(rng));
    b.normalize();
    const double largest =
        std::max(localLoadOptimum(a, h, b, 2.0 * limit).norm(), localLoadOptimum(a, h, -b, 2.0 * limit).norm());
    if (largest > limit) {
      loaded[m] = 0;
      ++marked;
    }
  }
  return marked;
}

// Largest t such that moving every sphere i by t dr_i (length units) from `centre` keeps the pairs and
// walls of `lp` disjoint: the first root of |d + t v| = r_i + r_j along the straight line, in the
// cancellation-free form. Pairs not in `lp` are farther apart than gapTolerance (r_i + r_j) and close by at
// most 2 t max|dr|, which caps t (Donev 2006, §4.6.2.3, where the EDMD predictor plays this role).
double largestScaling(const LoadLp& lp, const Eigen::Matrix3Xd& centre, const Eigen::VectorXd& radius, const Box& box,
                      const Eigen::Matrix3Xd& dr, double gapTolerance) {
  const double largest = dr.colwise().norm().maxCoeff();
  if (largest <= 0.0) return 0.0;
  double t = gapTolerance * radius.minCoeff() / largest;
  for (const auto& [i, j] : lp.pairs) {
    if (j >= 0) {
      const Eigen::Vector3d d = box.minimumImage(centre.col(i) - centre.col(j));
      const Eigen::Vector3d v = dr.col(i) - dr.col(j);
      const double b = d.dot(v);
      if (b >= 0.0) continue;  // separating
      const double sigma = radius[i] + radius[j];
      const double c = std::max(0.0, d.squaredNorm() - sigma * sigma);
      const double disc = b * b - v.squaredNorm() * c;
      if (disc < 0.0) continue;  // passes by
      t = std::min(t, c / (-b + std::sqrt(disc)));
    } else {
      const int wall = -1 - j, k = wall / 2;
      const double toward = wall % 2 ? dr(k, i) : -dr(k, i);
      if (toward <= 0.0) continue;
      const double room = wall % 2 ? box.length(k) - centre(k, i) - radius[i] : centre(k, i) - radius[i];
      t = std::min(t, std::max(0.0, room) / toward);
    }
  }
  return t;
}
void requireLoads(const LoadTestOptions& options) {
  if (options.loads < 1) {
    throw ConfigError(
        fmt::format("jamming test: loads must be >= 1, got {} (a test without loads proves nothing)", options.loads));
  }
}

LoadProblem::LoadProblem(const SphereView& s, const Box& b, const ContactNetwork& network, const LoadTestOptions& o,
                         LoadProtocol protocol)
    : spheres(s),
      box(b),
      options(o),
      n(s.count()),
      network_(network),
      protocol_(protocol),
      start_(std::chrono::steady_clock::now()) {
  if (network.particles != n) {
    throw ConfigError(
        fmt::format("jamming test: the contact network has {} particles, the packing {}", network.particles, n));
  }
}

bool LoadProblem::prepare(LoadTestSummary& result) {
  result.motion = Eigen::Matrix3Xd::Zero(3, n);
  // Every sphere but the removed ones is a variable; rattlers carry no load but keep their constraints
  // (Donev 2006, §4.6.2.2), so the backbone cannot move through them.
  std::vector<char> removed(static_cast<std::size_t>(n), 0);
  for (Index i : options.removed) {
    if (i < 0 || i >= n) throw ConfigError(fmt::format("jamming test: removed sphere {} out of range", i));
    removed[static_cast<std::size_t>(i)] = 1;
  }
  slot.assign(static_cast<std::size_t>(n), -1);
  for (Index i = 0; i < n; ++i) {
    if (removed[static_cast<std::size_t>(i)]) continue;
    slot[static_cast<std::size_t>(i)] = static_cast<int>(movable.size());
    const bool backbone = !network_.rattler[static_cast<std::size_t>(i)];
    movable.push_back(i);
    loaded.push_back(backbone ? 1 : 0);
  }
  backboneCount = std::count(loaded.begin(), loaded.end(), 1);
  if (n == 0) {
    result.verdict = "not tested: no spheres";
    return false;
  }
  if (backboneCount < 2) {
    result.outcome = JammingVerdict::Unjammed;
    result.verdict = "unjammed: no backbone";
    return false;
  }
  diameter = 2.0 * spheres.radius.mean();
  if (!(options.beta > 0.0) || !(options.maxLimit > 0.0) || !(options.meanLimit > 0.0) || options.maxSteps < 1 ||
      !(options.displacementLimit > 0.0) || !(options.gapTolerance > 0.0) || !(options.maxDisplacement > 0.0)) {
    throw ConfigError(fmt::format(
        "jamming test: beta ({}), max limit ({}), mean limit ({}), displacement limit ({}), gap tolerance ({}) and "
        "displacement box ({}) must be positive and max steps ({}) at least 1",
        options.beta, options.maxLimit, options.meanLimit, options.displacementLimit, options.gapTolerance,
        options.maxDisplacement, options.maxSteps));
  }
  if (options.strict && !box.fullyPeriodic()) {
    throw ConfigError("jamming test: the strict test (deforming lattice) needs a fully periodic box");
  }
  if (options.strict && protocol_ == LoadProtocol::Sequential) {
    throw ConfigError("jamming test: the strict test (deforming lattice) runs with the single-LP test only");
  }
  lp = buildLoadLp(spheres, box, slot, options.gapTolerance, diameter, options.strict);
  lp.bound = options.maxDisplacement;
  if (options.strict) {
    // Strain bounded so that the cell boundary moves at most maxDisplacement mean diameters.
    lp.columnBound.assign(static_cast<std::size_t>(lp.cols), options.maxDisplacement);
    for (int v = 0; v < 6; ++v) {
      lp.columnBound[static_cast<std::size_t>(lp.cols - 6 + v)] =
          options.maxDisplacement * diameter / box.lengths().maxCoeff();
    }
  }
  result.constraints = lp.rows;
  cols = lp.cols;
  useSimplex_ =
      options.solver == LpSolver::Simplex || (options.solver == LpSolver::Automatic && jammingTestAvailable() &&
                                              static_cast<Index>(movable.size()) <= kSimplexLimit);
#if !POLYDEM_JAMMING_WITH_GLPK
  if (useSimplex_) {
    throw ConfigError("the simplex jamming test needs GLPK (libglpk-dev), which this build did not find");
  }
#endif
  rng_.seed(options.seed);
  if (options.localRattlers) {
    result.localRattlers = markLocalRattlers(lp, slot, loaded, options.displacementLimit, rng_);
    if (options.progress) {
      options.progress(
          fmt::format("local LP (neighbours fixed, loads +-b): {} more spheres move alone by more "
                      "than {:.1e} D and carry no load",
                      result.localRattlers, options.displacementLimit));
    }
    if (std::count(loaded.begin(), loaded.end(), 1) < 2) {
      result.outcome = JammingVerdict::Unjammed;
      result.verdict = "unjammed: no sphere is locally jammed";
      return false;
    }
  }
  return true;
}

std::vector<double> LoadProblem::randomLoad() {
  const std::int64_t loadedCount = std::count(loaded.begin(), loaded.end(), 1);
  std::vector<double> b(static_cast<std::size_t>(cols), 0.0);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  const int coordinates = 3 * static_cast<int>(loaded.size());  // strain columns carry no load
  for (int c = 0; c < coordinates; ++c) {
    if (!loaded[static_cast<std::size_t>(c / 3)]) continue;
    b[static_cast<std::size_t>(c)] = normal_(rng_);
    mean[c % 3] += b[static_cast<std::size_t>(c)];
  }
  mean /= static_cast<double>(loadedCount);
  for (int c = 0; c < coordinates; ++c) {
    if (loaded[static_cast<std::size_t>(c / 3)]) b[static_cast<std::size_t>(c)] -= mean[c % 3];
  }
  return b;
}

void LoadProblem::pin(LoadLp& l) const {
  int pinnedSphere = -1;
  for (std::size_t m = 0; m < movable.size() && pinnedSphere < 0; ++m) {
    if (loaded[m]) pinnedSphere = static_cast<int>(m);
  }
  l.pinned.assign(static_cast<std::size_t>(cols), 0);
  for (int k = 0; k < 3; ++k) {
    if (box.periodic(k)) l.pinned[static_cast<std::size_t>(3 * pinnedSphere + k)] = 1;
  }
}

std::vector<double> LoadProblem::solve(const LoadLp& l, const std::vector<double>& beta) {
  ++lps_;
#if POLYDEM_JAMMING_WITH_GLPK
  if (useSimplex_) {
    // x = 0 is always feasible and the box bounds the optimum, so a simplex failure or a "no feasible
    // solution" status is GLPK's round-off (seen with hard walls): the interior point solves the same LP.
    try {
      return solveLoadSimplex(l, beta);
    } catch (const SimulationError&) {
      ++fallbacks_;
    }
  }
#endif
  return solveLoadInteriorPoint(l, beta, ipIterations_);
}

std::string LoadProblem::solverName() const {
  return useSimplex_
             ? (fallbacks_ == 0 ? std::string("GLPK simplex")
                                : fmt::format("GLPK simplex; {} of {} LPs by the interior point after a "
                                              "simplex failure ({} iterations)",
                                              fallbacks_, lps_, ipIterations_))
             : fmt::format("interior point ({}, {} iterations over {} LPs)",
                           interiorPointUsesCholmod() ? "CHOLMOD" : "Eigen simplicial Cholesky", ipIterations_, lps_);
}

double LoadProblem::elapsed() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

}  // namespace polydem::jamming::detail
