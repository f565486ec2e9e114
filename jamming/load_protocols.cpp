#include "jamming/load_protocols.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <limits>
#include <cmath>
#include <random>
#include <cstdlib>

#include <Eigen/LU>
#include <Eigen/SparseCore>

#include "core/errors.hpp"
#include "jamming/interior_point.hpp"

#if POLYDEM_JAMMING_WITH_GLPK
#include <glpk.h>
#endif

namespace polydem::jamming {

bool jammingTestAvailable() { return POLYDEM_JAMMING_WITH_GLPK != 0; }

#if POLYDEM_JAMMING_WITH_GLPK

namespace {

struct Lp {
  glp_prob* p = glp_create_prob();
  ~Lp() { glp_delete_prob(p); }
  Lp() = default;
  Lp(const Lp&) = delete;
  Lp& operator=(const Lp&) = delete;
};

// Rigidity matrix of the backbone: one row per contact (u . (dR_i - dR_j)), columns 3 b(i) + k.
struct Rigidity {
  std::vector<int> ia{0}, ja{0};  // GLPK arrays are 1-based
  std::vector<double> ar{0.0};
  int rows = 0, cols = 0;
  std::vector<std::array<Index, 2>> pairs;  // backbone indices per row
};

int solve(glp_prob* p) {
  glp_smcp parm;
  glp_init_smcp(&parm);
  parm.msg_lev = GLP_MSG_OFF;
  parm.presolve = GLP_ON;
  int rc = glp_simplex(p, &parm);
  if (rc != 0) {
    // Presolve plus the default scaling can end in a numerical failure (GLP_EFAIL, seen on load LPs with
    // hard walls); retry on the scaled problem from an advanced basis without presolve.
    glp_scale_prob(p, GLP_SF_AUTO);
    glp_adv_basis(p, 0);
    parm.presolve = GLP_OFF;
    rc = glp_simplex(p, &parm);
  }
  if (rc != 0) throw SimulationError(fmt::format("jamming test: GLPK simplex failed (return code {})", rc));
  return glp_get_status(p);
}

// LP-free certificate for isostatic or hyperstatic backbones (digest §3.4 [R]; seed eq. 9.5, :11339-11351,
// and :7079-7104): with one sphere pinned, the rigidity matrix A (free coordinates x contacts) has full
// row rank iff K = A A^T is positive definite (no floppy modes), and then f = 1 - A^T K^-1 A 1 is the
// projection of the all-ones vector onto the self-stresses (A f = 0). f > 0 everywhere is a strict
// self-stress, which with full rank proves collective first-order jamming, i.e. jamming for spheres
// (:7291-7311). For an isostatic backbone the self-stress is unique up to scale, so a sign change in f
// proves an opening motion exists; for a hyperstatic one it leaves the question open.
void augmentedCertificate(const Rigidity& a, const Box& box, const std::vector<Index>& backbone,
                          JammingTestResult& result) {
  std::vector<int> freeCol(static_cast<std::size_t>(a.cols), -1);
  int nf = 0;
  for (int c = 0; c < a.cols; ++c) {
    if (!(c < 3 && box.periodic(c))) freeCol[static_cast<std::size_t>(c)] = nf++;
  }
  std::vector<Eigen::Triplet<double>> t;
  for (std::size_t e = 1; e < a.ar.size(); ++e) {
    const int f = freeCol[static_cast<std::size_t>(a.ja[e] - 1)];
    if (f >= 0) t.emplace_back(f, a.ia[e] - 1, a.ar[e]);
  }
  Eigen::SparseMatrix<double> am(nf, a.rows);
  am.setFromTriplets(t.begin(), t.end());
  const Eigen::SparseMatrix<double> k = am * am.transpose();
  SpdSolver solver;
  const std::string method = fmt::format("augmented-system certificate, {} backbone spheres, {} contacts",
                                         backbone.size(), a.rows);
  if (!solver.factor(k)) {
    result.outcome = JammingVerdict::Unjammed;
    result.verdict = fmt::format("unjammed: rigidity matrix rank deficient (floppy modes; {})", method);
    return;
  }
  // Conditioning: smallest and largest eigenvalues of K by inverse and direct power iteration.
  std::mt19937_64 rng(12345);
  std::normal_distribution<double> normal;
  Eigen::VectorXd v(nf), w(nf);
  for (int i = 0; i < nf; ++i) v[i] = normal(rng);
  double lambdaMin = 0.0, lambdaMax = 0.0;
  w = v.normalized();
  for (int it = 0; it < 40; ++it) {
    const Eigen::VectorXd u = solver.solve(w);
    lambdaMin = 1.0 / u.norm();
    w = u.normalized();
  }
  const Eigen::VectorXd floppy = w;
  w = v.normalized();
  for (int it = 0; it < 40; ++it) {
    const Eigen::VectorXd u = k * w;
    lambdaMax = u.norm();
    w = u.normalized();
  }
  if (lambdaMin < 1e-12 * lambdaMax) {
    result.outcome = JammingVerdict::Unjammed;
    result.verdict = fmt::format("unjammed: rigidity matrix numerically rank deficient (lambda_min / lambda_max = "
                                 "{:.1e}; {})",
                                 lambdaMin / lambdaMax, method);
    for (std::size_t b = 0; b < backbone.size(); ++b) {
      for (int c = 0; c < 3; ++c) {
        const int f = freeCol[3 * b + static_cast<std::size_t>(c)];
        if (f >= 0) result.motion(c, backbone[b]) = floppy[f];
      }
    }
    return;
  }
  const Eigen::VectorXd ones = Eigen::VectorXd::Ones(a.rows);
  const Eigen::VectorXd f = ones - am.transpose() * solver.solve(am * ones);
  const double residual = (am * f).norm() / (f.norm() * std::sqrt(lambdaMax));
  const Index negative = static_cast<Index>((f.array() <= 1e-9 * f.maxCoeff()).count());
  const std::int64_t needed = static_cast<std::int64_t>(nf) + 1;
  if (negative == 0) {
    result.outcome = JammingVerdict::Jammed;
    result.jammed = true;
    result.verdict = fmt::format(
        "jammed (collectively, first order; {}: full rank, lambda_min / lambda_max = {:.1e}, strictly positive "
        "self-stress, smallest / largest force {:.2e}, |A f| / |A| |f| = {:.1e})",
        method, lambdaMin / lambdaMax, f.minCoeff() / f.maxCoeff(), residual);
  } else if (a.rows == needed) {
    result.outcome = JammingVerdict::Unjammed;
    result.verdict = fmt::format(
        "unjammed: the isostatic backbone's only self-stress has {} non-positive forces, so a motion opens "
        "contacts ({})",
        negative, method);
  } else {
    result.outcome = JammingVerdict::Undecided;
    result.verdict = fmt::format(
        "inconclusive: hyperstatic backbone ({} contacts > {}) and the projected self-stress has {} "
        "non-positive forces ({}); use the load test",
        a.rows, needed, negative, method);
  }
}

}  // namespace

JammingTestResult testCollectiveJamming(const SphereView& spheres, const Box& box, const ContactNetwork& network,
                                        double tolerance, std::uint64_t seed, int simplexLimit) {
  const auto start = std::chrono::steady_clock::now();
  const Index n = spheres.count();
  if (network.particles != n) {
    throw ConfigError(
        fmt::format("jamming test: the contact network has {} particles, the packing {}", network.particles, n));
  }
  std::vector<int> slot(static_cast<std::size_t>(n), -1);
  std::vector<Index> backbone;
  for (Index i = 0; i < n; ++i) {
    if (!network.rattler[static_cast<std::size_t>(i)]) {
      slot[static_cast<std::size_t>(i)] = static_cast<int>(backbone.size());
      backbone.push_back(i);
    }
  }
  JammingTestResult result;
  result.motion = Eigen::Matrix3Xd::Zero(3, n);
  if (n == 0) {
    result.verdict = "not tested: no spheres";
    return result;
  }
  if (backbone.empty()) {
    result.outcome = JammingVerdict::Unjammed;
    result.verdict = "unjammed: every sphere is a rattler";
    return result;
  }
  Rigidity a;
  a.cols = 3 * static_cast<int>(backbone.size());
  for (const auto& c : network.contacts) {
    const int bi = slot[static_cast<std::size_t>(c.i)], bj = slot[static_cast<std::size_t>(c.j)];
    if (bi < 0 || bj < 0) continue;
    const Eigen::Vector3d d = box.minimumImage(spheres.centre.col(c.i) - spheres.centre.col(c.j));
    const Eigen::Vector3d u = d / d.norm();
    ++a.rows;
    for (int k = 0; k < 3; ++k) {
      a.ia.push_back(a.rows);
      a.ja.push_back(3 * bi + k + 1);
      a.ar.push_back(u[k]);
      a.ia.push_back(a.rows);
      a.ja.push_back(3 * bj + k + 1);
      a.ar.push_back(-u[k]);
    }
    a.pairs.push_back({bi, bj});
  }
  for (const WallContact& w : network.wallContacts) {
    const int bi = slot[static_cast<std::size_t>(w.i)];
    if (bi < 0) continue;
    ++a.rows;  // opening rate of a wall contact: +dR_k at the lower wall, -dR_k at the upper one
    a.ia.push_back(a.rows);
    a.ja.push_back(3 * bi + w.wall / 2 + 1);
    a.ar.push_back(w.wall % 2 ? -1.0 : 1.0);
  }
  if (a.rows == 0) {
    result.outcome = JammingVerdict::Unjammed;
    result.verdict = "unjammed: no contacts";
    return result;
  }
  // Large backbones: GLPK's simplex does not finish at N' = 10,000 (>30 min), so decide by counting where
  // counting suffices: fewer than N_f + 1 contacts leave floppy modes, and a hypostatic sphere packing
  // cannot be jammed (seed :7291-7311, :4473-4476).
  const std::int64_t periodicAxes = box.periodic(0) + box.periodic(1) + box.periodic(2);
  const std::int64_t needed = 3 * static_cast<std::int64_t>(backbone.size()) - periodicAxes + 1;
  if (static_cast<Index>(backbone.size()) > simplexLimit) {
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (a.rows < needed) {
      result.outcome = JammingVerdict::Unjammed;
      result.verdict = fmt::format(
          "unjammed: hypostatic backbone ({} contacts < 3N' - {} + 1 = {}, the least that allows full rank and a "
          "self-stress; by counting, no LP above {} spheres)",
          a.rows, periodicAxes, needed, simplexLimit);
    } else {
      augmentedCertificate(a, box, backbone, result);
    }
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
  }
  const int ne = static_cast<int>(a.ar.size()) - 1;
  auto motionFrom = [&](glp_prob* p) {
    for (std::size_t b = 0; b < backbone.size(); ++b)
      for (int k = 0; k < 3; ++k) result.motion(k, backbone[b]) = glp_get_col_prim(p, static_cast<int>(3 * b) + k + 1);
  };

  // LP 1: open contacts. Objective = sum of rows = column sums of A.
  {
    Lp lp;
    glp_set_obj_dir(lp.p, GLP_MAX);
    glp_add_rows(lp.p, a.rows);
    glp_add_cols(lp.p, a.cols);
    for (int r = 1; r <= a.rows; ++r) glp_set_row_bnds(lp.p, r, GLP_DB, 0.0, 1.0);
    std::vector<double> objective(static_cast<std::size_t>(a.cols) + 1, 0.0);
    for (int e = 1; e <= ne; ++e)
      objective[static_cast<std::size_t>(a.ja[static_cast<std::size_t>(e)])] += a.ar[static_cast<std::size_t>(e)];
    for (int c = 1; c <= a.cols; ++c) {
      glp_set_col_bnds(lp.p, c, c <= 3 && box.periodic(c - 1) ? GLP_FX : GLP_FR, 0.0, 0.0);  // pin sphere 1
      glp_set_obj_coef(lp.p, c, objective[static_cast<std::size_t>(c)]);
    }
    glp_load_matrix(lp.p, ne, a.ia.data(), a.ja.data(), a.ar.data());
    const int status = solve(lp.p);
    if (status != GLP_OPT) throw SimulationError(fmt::format("jamming test: opening LP status {}", status));
    ++result.lps;
    result.openingObjective = glp_get_obj_val(lp.p);
    // Any opening motion can be scaled until some contact opens at rate 1, so a non-zero optimum is >= 1.
    if (result.openingObjective > 0.5) {
      for (int r = 1; r <= a.rows; ++r) result.contactsOpened += glp_get_row_prim(lp.p, r) > 1e-6 ? 1 : 0;
      motionFrom(lp.p);
      result.outcome = JammingVerdict::Unjammed;
      result.verdict =
          fmt::format("unjammed: a motion opens {} of {} backbone contacts", result.contactsOpened, a.rows);
    }
  }
  // LP 2: floppy modes, keeping every contact.
  if (result.verdict.empty()) {
    Lp lp;
    glp_set_obj_dir(lp.p, GLP_MAX);
    glp_add_rows(lp.p, a.rows);
    glp_add_cols(lp.p, a.cols);
    for (int r = 1; r <= a.rows; ++r) glp_set_row_bnds(lp.p, r, GLP_FX, 0.0, 0.0);
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    for (int c = 1; c <= a.cols; ++c) {
      if (c <= 3 && box.periodic(c - 1)) {
        glp_set_col_bnds(lp.p, c, GLP_FX, 0.0, 0.0);
      } else {
        glp_set_col_bnds(lp.p, c, GLP_DB, -1.0, 1.0);
      }
      glp_set_obj_coef(lp.p, c, uniform(rng));
    }
    glp_load_matrix(lp.p, ne, a.ia.data(), a.ja.data(), a.ar.data());
    const int status = solve(lp.p);
    if (status != GLP_OPT) throw SimulationError(fmt::format("jamming test: floppy-mode LP status {}", status));
    ++result.lps;
    result.floppyObjective = glp_get_obj_val(lp.p);
    if (result.floppyObjective > tolerance * a.cols) {
      motionFrom(lp.p);
      result.outcome = JammingVerdict::Unjammed;
      result.verdict = "unjammed: floppy modes (a motion keeps every contact)";
    }
  }
  if (result.verdict.empty()) {
    result.outcome = JammingVerdict::Jammed;
    result.jammed = true;
    result.verdict =
        fmt::format("jammed (collectively, first order: {} backbone spheres, {} contacts)", backbone.size(), a.rows);
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

#else

JammingTestResult testCollectiveJamming(const SphereView&, const Box&, const ContactNetwork&, double, std::uint64_t,
                                        int) {
  throw ConfigError("the jamming test needs GLPK (libglpk-dev), which this build did not find");
}

#endif

namespace {

// The load LP of testJammingUnderLoad in displacement form: max beta.x s.t. A^T x >= -h, |x_c| <= X,
// pinned coordinates fixed at 0. Columns of A (contacts) as triplets (coordinate, row, value).
struct LoadLp {
  int cols = 0;  // coordinates 3 x movable
  int rows = 0;  // constraints
  std::vector<Eigen::Triplet<double>> entries;
  std::vector<double> gap;
  std::vector<char> pinned;  // per coordinate
  double bound = 10.0;
  std::vector<double> columnBound;  // per coordinate if not empty (overrides bound)
  std::vector<std::array<Index, 2>> pairs;  // per constraint: spheres i, j (j = -1 - wall for a wall)
  std::vector<Eigen::Vector3d> normal;      // per constraint: u with u . (dR_i - dR_j) >= -h (walls: dR_j = 0)
};

#if POLYDEM_JAMMING_WITH_GLPK
std::vector<double> solveLoadSimplex(const LoadLp& lp, const std::vector<double>& beta) {
  Lp glpk;
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
  const int status = solve(glpk.p);
  if (status != GLP_OPT) throw SimulationError(fmt::format("jamming test: load LP status {}", status));
  std::vector<double> x(static_cast<std::size_t>(lp.cols));
  for (int c = 1; c <= lp.cols; ++c) x[static_cast<std::size_t>(c - 1)] = glp_get_col_prim(glpk.p, c);
  return x;
}
#endif

// Force form (seed eq. 4.12 with the box): min h.f + X 1.(g + k) s.t. A f - g + k = -beta, f, g, k >= 0,
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
                   double diameter, bool strict = false) {
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
      // Deforming lattice (seed eq. 4.20-4.21, :5070-5098): a contact through the boundary also changes
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
    // The cell volume must not grow: -Tr eps >= 0 (seed eq. 4.17, 4.19).
    for (int v = 0; v < 3; ++v) lp.entries.emplace_back(strain + v, lp.rows, -1.0);
    lp.gap.push_back(0.0);
    lp.pairs.push_back({-1, -1});
    lp.normal.push_back(Eigen::Vector3d::Zero());
    ++lp.rows;
  }
  return lp;
}

// Local jamming LP of one sphere with its neighbours held fixed (seed eq. 4.15, :4886-4893): max b . x over
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

// Rattlers by the local LP (seed Algorithm 14 step 3, :5690-5692; Algorithm 13 step 4): a loaded sphere
// that moves further than `limit` (mean diameters) under a random load or its opposite with every
// neighbour held fixed is unloaded (it keeps its constraints, :5713-5725). Catches spheres with four or
// more contacts in a degenerate arrangement (e.g. three coplanar, seed :11212-11216), which the contact
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
    const double largest = std::max(localLoadOptimum(a, h, b, 2.0 * limit).norm(),
                                    localLoadOptimum(a, h, -b, 2.0 * limit).norm());
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
// most 2 t max|dr|, which caps t (seed :5726-5746, where the EDMD predictor plays this role).
double largestScaling(const LoadLp& lp, const Eigen::Matrix3Xd& centre, const Eigen::VectorXd& radius,
                      const Box& box, const Eigen::Matrix3Xd& dr, double gapTolerance) {
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

// The seed's Algorithm 14 (sequential random loading, :5684-5702, :5726-5760) for packings with gaps: for
// each random load B and then -B, solve the load LP, scale its motion dR by the largest tau that keeps every
// sphere disjoint along 0..tau dR (the linearised solution is feasible for tau <= 1, :4319-4388; the
// true constraints often allow more), move the spheres, rebuild the constraints and repeat while some sphere
// still moves more than beta D_i in a step. The spheres stay where the loads took them (no reset between
// loads). Displacements are measured against each sphere's own diameter D_i (seed Table 4.2). Not jammed
// as soon as the accumulated motion of a loaded sphere exceeds maxLimit D_i or the mean exceeds meanLimit.
template <class RandomLoad, class Pin, class Solve>
void sequentialLoading(const SphereView& spheres, const Box& box, const std::vector<Index>& movable,
                       const std::vector<int>& slot, const std::vector<char>& loaded, double diameter,
                       const LoadLp& first, const LoadTestOptions& options, RandomLoad&& randomLoad, Pin&& pin,
                       Solve&& solveLp, std::chrono::steady_clock::time_point start, LoadTestResult& result) {
  const Index n = spheres.count();
  const Eigen::VectorXd radius = spheres.radius;
  Eigen::Matrix3Xd centre = spheres.centre;
  Eigen::Matrix3Xd moved = Eigen::Matrix3Xd::Zero(3, n);  // accumulated, unwrapped, length units
  const double loadedCount = static_cast<double>(std::count(loaded.begin(), loaded.end(), 1));
  // Unloaded spheres (rattlers) only make room; an LP may still send them anywhere within the box (:5719-5722),
  // which is meaningless beyond the gap tolerance. Their coordinates are bounded so that they move by less
  // than gapTolerance r_min, the range in which every pair that could collide is a constraint.
  std::vector<double> columnBound(3 * movable.size(), options.maxDisplacement);
  for (std::size_t m = 0; m < movable.size(); ++m) {
    if (loaded[m]) continue;
    for (int k = 0; k < 3; ++k) {
      columnBound[3 * m + static_cast<std::size_t>(k)] =
          0.99 * options.gapTolerance * radius.minCoeff() / (std::sqrt(3.0) * diameter);
    }
  }
  bool configurationMoved = false;
  bool stopped = false;    // a threshold was exceeded: unjammed
  bool unsettled = false;  // a load still moved spheres by more than beta after maxSteps LPs
  double totalMax = 0.0, totalMean = 0.0;  // accumulated displacement now
  double peakMax = 0.0, peakMean = 0.0;    // the largest they have been
  for (int load = 0; load < options.loads && !stopped; ++load) {
    const std::vector<double> b = randomLoad();
    for (double sign : {1.0, -1.0}) {
      if (stopped) break;
      std::vector<double> beta(b.size());
      for (std::size_t c = 0; c < b.size(); ++c) beta[c] = sign * b[c];
      bool settled = false;
      for (int step = 1; step <= options.maxSteps && !stopped; ++step) {
        LoadLp lp = configurationMoved
                        ? buildLoadLp(SphereView{centre, radius}, box, slot, options.gapTolerance, diameter)
                        : first;
        lp.bound = options.maxDisplacement;
        lp.columnBound = columnBound;
        pin(lp);
        const std::vector<double> x = solveLp(lp, beta);
        ++result.steps;
        Eigen::Matrix3Xd dr = Eigen::Matrix3Xd::Zero(3, n);
        double linearLargest = 0.0;  // the LP's own motion, in mean diameters (the ideal test's measure)
        Index linearBeyond = 0;
        for (std::size_t m = 0; m < movable.size(); ++m) {
          for (int k = 0; k < 3; ++k) dr(k, movable[m]) = x[3 * m + static_cast<std::size_t>(k)] * diameter;
          if (!loaded[m]) continue;
          const double d = dr.col(movable[m]).norm() / diameter;
          linearLargest = std::max(linearLargest, d);
          if (d > options.displacementLimit) ++linearBeyond;
        }
        if (step == 1 && linearLargest > result.linearLargest) {
          result.linearLargest = linearLargest;
          result.linearDisplaced = linearBeyond;
        }
        const double largestMove = dr.colwise().norm().maxCoeff();
        if (largestMove <= 0.0) {
          settled = true;
          break;
        }
        const double cap = options.gapTolerance * radius.minCoeff() / largestMove;
        const double tau = std::max(largestScaling(lp, centre, radius, box, dr, options.gapTolerance),
                                    std::min(1.0, cap));
        double stepMax = 0.0;
        totalMax = 0.0;
        double sum = 0.0;
        Index beyond = 0;
        for (std::size_t m = 0; m < movable.size(); ++m) {
          const Index i = movable[m];
          centre.col(i) = box.wrap(centre.col(i) + tau * dr.col(i));
          moved.col(i) += tau * dr.col(i);
          if (!loaded[m]) continue;  // rattlers may wander in their cages
          const double di = 2.0 * radius[i];
          stepMax = std::max(stepMax, tau * dr.col(i).norm() / di);
          const double total = moved.col(i).norm() / di;
          totalMax = std::max(totalMax, total);
          sum += total;
          if (total > options.maxLimit) ++beyond;
        }
        configurationMoved = true;
        totalMean = sum / loadedCount;
        peakMax = std::max(peakMax, totalMax);
        peakMean = std::max(peakMean, totalMean);
        result.displaced = beyond;
        if (options.progress) {
          options.progress(fmt::format(
              "load {}{} step {}: LP motion up to {:.3g} D ({} spheres beyond {:.1e} D), scaled by {:.3g}: step up "
              "to {:.3g} D_i; accumulated max {:.3g} D_i, mean {:.3g} D_i ({:.1f} s so far)",
              load + 1, sign > 0 ? "+" : "-", step, linearLargest, linearBeyond, options.displacementLimit, tau,
              stepMax, totalMax, totalMean,
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()));
        }
        if (totalMax > options.maxLimit || totalMean > options.meanLimit) stopped = true;
        if (stepMax <= options.beta) {
          settled = true;
          break;
        }
      }
      if (!settled && !stopped) unsettled = true;
    }
  }
  result.largestDisplacement = peakMax;
  result.meanDisplacement = peakMean;
  result.motion = moved;
  result.jammed = !stopped && !unsettled && result.steps > 0;
  result.outcome = result.steps == 0 ? JammingVerdict::NotTested
                   : result.jammed   ? JammingVerdict::Jammed
                   : stopped         ? JammingVerdict::Unjammed
                                     : JammingVerdict::Undecided;
  const std::string loads = fmt::format("{} random loads and their opposites, {} LPs", options.loads, result.steps);
  const std::string linear =
      fmt::format("the LPs' own motions reach {:.3g} D ({} loaded spheres beyond the ideal limit {:.1e} D)",
                  result.linearLargest, result.linearDisplaced, options.displacementLimit);
  if (result.steps == 0) {
    result.verdict = "not tested: no LP was solved";
  } else if (result.jammed) {
    result.verdict = fmt::format(
        "jammed (sequential random loading, seed Algorithm 14): {}; largest accumulated displacement of a loaded "
        "sphere {:.3g} D_i (limit {:.3g}), largest mean {:.3g} D_i (limit {:.3g}); {}",
        loads, peakMax, options.maxLimit, peakMean, options.meanLimit, linear);
  } else if (stopped) {
    result.verdict = fmt::format(
        "unjammed (sequential random loading, seed Algorithm 14): after {} LPs the loaded spheres moved by up to "
        "{:.3g} D_i ({} beyond the limit {:.3g}), mean {:.3g} D_i (limit {:.3g}); {}",
        result.steps, peakMax, result.displaced, options.maxLimit, peakMean, options.meanLimit, linear);
  } else {
    result.verdict = fmt::format(
        "undecided (sequential random loading, seed Algorithm 14): a load still moved spheres by more than {:.3g} "
        "D_i per step after {} steps; accumulated max {:.3g} D_i, mean {:.3g} D_i; {}",
        options.beta, options.maxSteps, peakMax, peakMean, linear);
  }
}

}  // namespace

LoadTestResult testJammingUnderLoad(const SphereView& spheres, const Box& box, const ContactNetwork& network,
                                    const LoadTestOptions& options) {
  if (options.loads < 1) {
    throw ConfigError(fmt::format("jamming test: loads must be >= 1, got {} (a test without loads proves nothing)",
                                  options.loads));
  }
  if (options.sequential && options.subpackingRounds > 1) {
    // Rounds of the seed's Algorithm 13 (:5621-5648) around the sequential test: the loaded spheres that
    // moved beyond maxLimit are removed from the packing (no variables, no constraints: stricter than
    // unloading them) and the rest is tested again from the original configuration, until a round
    // passes; that remainder is a jammed subpacking, which by the seed's definition makes the packing
    // jammed (:4242-4256). A round stopped by the mean alone names nobody to remove and ends the search.
    const auto start = std::chrono::steady_clock::now();
    LoadTestOptions round = options;
    round.subpackingRounds = 1;
    LoadTestResult first;
    Index removedTotal = 0;
    for (int r = 1; r <= options.subpackingRounds; ++r) {
      if (options.progress) options.progress(fmt::format("subpacking round {}", r));
      LoadTestResult now = testJammingUnderLoad(spheres, box, network, round);
      if (r == 1) {
        first = now;
      } else {
        first.steps += now.steps;
        first.solver += fmt::format(" + round {}: {}", r, now.solver);
      }
      first.rounds = r;
      if (now.jammed) {
        first.subpackingJammed = true;
        first.setAsidePerRound.push_back(0);
        Index tested = 0;
        for (Index i = 0; i < spheres.count(); ++i) tested += network.rattler[static_cast<std::size_t>(i)] ? 0 : 1;
        first.subpacking = tested - static_cast<Index>(options.removed.size()) - removedTotal - now.localRattlers;
        break;
      }
      std::vector<char> gone(static_cast<std::size_t>(spheres.count()), 0);
      for (Index i : round.removed) gone[static_cast<std::size_t>(i)] = 1;
      Index added = 0;
      for (Index i = 0; i < spheres.count(); ++i) {
        if (gone[static_cast<std::size_t>(i)] || network.rattler[static_cast<std::size_t>(i)]) continue;
        if (now.motion.col(i).norm() / (2.0 * spheres.radius[i]) > options.maxLimit) {
          round.removed.push_back(i);
          ++added;
        }
      }
      first.setAsidePerRound.push_back(added);
      removedTotal += added;
      if (added == 0) break;
    }
    first.loose = removedTotal;
    std::string perRound;
    for (Index k : first.setAsidePerRound) perRound += fmt::format("{}{}", perRound.empty() ? "" : ", ", k);
    if (!first.jammed) {
      first.verdict +=
          first.subpackingJammed
              ? fmt::format("; jammed subpacking of {} spheres after {} rounds (loaded spheres beyond {:.3g} D_i "
                            "removed per round: {})",
                            first.subpacking, first.rounds, options.maxLimit, perRound)
              : fmt::format("; no jammed subpacking in {} rounds (removed per round: {})", first.rounds, perRound);
    }
    first.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return first;
  }
  const auto start = std::chrono::steady_clock::now();
  const Index n = spheres.count();
  if (network.particles != n) {
    throw ConfigError(
        fmt::format("jamming test: the contact network has {} particles, the packing {}", network.particles, n));
  }
  LoadTestResult result;
  result.motion = Eigen::Matrix3Xd::Zero(3, n);
  // Every sphere but the removed ones is a variable; rattlers carry no load but keep their constraints
  // (seed :5713-5725), so the backbone cannot move through them.
  std::vector<char> removed(static_cast<std::size_t>(n), 0);
  for (Index i : options.removed) {
    if (i < 0 || i >= n) throw ConfigError(fmt::format("jamming test: removed sphere {} out of range", i));
    removed[static_cast<std::size_t>(i)] = 1;
  }
  std::vector<int> slot(static_cast<std::size_t>(n), -1);
  std::vector<Index> movable;
  std::vector<char> loaded;
  for (Index i = 0; i < n; ++i) {
    if (removed[static_cast<std::size_t>(i)]) continue;
    slot[static_cast<std::size_t>(i)] = static_cast<int>(movable.size());
    const bool backbone = !network.rattler[static_cast<std::size_t>(i)];
    movable.push_back(i);
    loaded.push_back(backbone ? 1 : 0);
  }
  const std::int64_t backboneCount = std::count(loaded.begin(), loaded.end(), 1);
  if (n == 0) {
    result.verdict = "not tested: no spheres";
    return result;
  }
  if (backboneCount < 2) {
    result.outcome = JammingVerdict::Unjammed;
    result.verdict = "unjammed: no backbone";
    return result;
  }
  const double diameter = 2.0 * spheres.radius.mean();
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
  if (options.strict && options.sequential) {
    throw ConfigError("jamming test: the strict test (deforming lattice) runs with the single-LP test only");
  }
  LoadLp lp = buildLoadLp(spheres, box, slot, options.gapTolerance, diameter, options.strict);
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
  const int cols = lp.cols;
  const bool useSimplex = options.solver == LpSolver::Simplex ||
                          (options.solver == LpSolver::Automatic && jammingTestAvailable() &&
                           static_cast<Index>(movable.size()) <= kSimplexLimit);
#if !POLYDEM_JAMMING_WITH_GLPK
  if (useSimplex) throw ConfigError("the simplex jamming test needs GLPK (libglpk-dev), which this build did not find");
#endif
  int ipIterations = 0;
  int lps = 0;
  std::mt19937_64 rng(options.seed);
  std::normal_distribution<double> normal;
  // A random load on the loaded spheres with zero net force (no drift of the whole packing).
  auto randomLoad = [&]() {
    const std::int64_t loadedCount = std::count(loaded.begin(), loaded.end(), 1);
    std::vector<double> b(static_cast<std::size_t>(cols), 0.0);
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    const int coordinates = 3 * static_cast<int>(loaded.size());  // strain columns carry no load
    for (int c = 0; c < coordinates; ++c) {
      if (!loaded[static_cast<std::size_t>(c / 3)]) continue;
      b[static_cast<std::size_t>(c)] = normal(rng);
      mean[c % 3] += b[static_cast<std::size_t>(c)];
    }
    mean /= static_cast<double>(loadedCount);
    for (int c = 0; c < coordinates; ++c) {
      if (loaded[static_cast<std::size_t>(c / 3)]) b[static_cast<std::size_t>(c)] -= mean[c % 3];
    }
    return b;
  };
  // Pin the first loaded sphere on the periodic axes (the trivial translations).
  auto pin = [&](LoadLp& l) {
    int pinnedSphere = -1;
    for (std::size_t m = 0; m < movable.size() && pinnedSphere < 0; ++m) {
      if (loaded[m]) pinnedSphere = static_cast<int>(m);
    }
    l.pinned.assign(static_cast<std::size_t>(cols), 0);
    for (int k = 0; k < 3; ++k) {
      if (box.periodic(k)) l.pinned[static_cast<std::size_t>(3 * pinnedSphere + k)] = 1;
    }
  };
  int fallbacks = 0;
  auto solveLp = [&](const LoadLp& l, const std::vector<double>& beta) {
    ++lps;
#if POLYDEM_JAMMING_WITH_GLPK
    if (useSimplex) {
      // x = 0 is always feasible and the box bounds the optimum, so a simplex failure or a "no feasible
      // solution" status is GLPK's round-off (seen with hard walls): the interior point solves the same LP.
      try {
        return solveLoadSimplex(l, beta);
      } catch (const SimulationError&) {
        ++fallbacks;
      }
    }
    return solveLoadInteriorPoint(l, beta, ipIterations);
#else
    return solveLoadInteriorPoint(l, beta, ipIterations);
#endif
  };
  auto solverName = [&]() {
    return useSimplex ? (fallbacks == 0 ? std::string("GLPK simplex")
                                        : fmt::format("GLPK simplex; {} of {} LPs by the interior point after a "
                                                      "simplex failure ({} iterations)",
                                                      fallbacks, lps, ipIterations))
                      : fmt::format("interior point ({}, {} iterations over {} LPs)",
                                    interiorPointUsesCholmod() ? "CHOLMOD" : "Eigen simplicial Cholesky",
                                    ipIterations, lps);
  };
  if (options.localRattlers) {
    result.localRattlers = markLocalRattlers(lp, slot, loaded, options.displacementLimit, rng);
    if (options.progress) {
      options.progress(fmt::format("local LP (neighbours fixed, loads +-b): {} more spheres move alone by more "
                                   "than {:.1e} D and carry no load",
                                   result.localRattlers, options.displacementLimit));
    }
    if (std::count(loaded.begin(), loaded.end(), 1) < 2) {
      result.outcome = JammingVerdict::Unjammed;
      result.verdict = "unjammed: no sphere is locally jammed";
      return result;
    }
  }
  if (options.sequential) {
    sequentialLoading(spheres, box, movable, slot, loaded, diameter, lp, options, randomLoad, pin, solveLp, start,
                      result);
    result.solver = solverName();
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
  }
  // Rounds of the seed's Algorithm 13 (:5621-5648): spheres a load displaces beyond the limit are set
  // aside (unloaded, like rattlers, but they keep their constraints, :5713-5725) and the rest is loaded
  // again, until a round displaces nobody: that remainder is a jammed subpacking (:4242-4256). Round 1
  // decides the packing as a whole and gives its unjamming motion.
  Index loose = 0;
  for (int round = 1; round <= std::max(1, options.subpackingRounds); ++round) {
    const std::int64_t loadedCount = std::count(loaded.begin(), loaded.end(), 1);
    if (loadedCount < 2) break;
    pin(lp);
    double worst = -1.0;
    Index worstDisplaced = 0;
    Eigen::Matrix3Xd worstMotion;
    std::vector<char> displacedNow(movable.size(), 0);
    for (int load = 0; load < options.loads; ++load) {
      const std::vector<double> b = randomLoad();  // no net force
      for (double sign : {1.0, -1.0}) {
        std::vector<double> beta(b.size());
        for (std::size_t c = 0; c < b.size(); ++c) beta[c] = sign * b[c];
        const std::vector<double> x = solveLp(lp, beta);
        double objective = 0.0;
        for (std::size_t c = 0; c < beta.size(); ++c) objective += beta[c] * x[c];
        result.objectives.push_back(objective);
        double largest = 0.0;
        Index displaced = 0;
        Eigen::Matrix3Xd motion = Eigen::Matrix3Xd::Zero(3, n);
        if (options.strict) {
          // The cell deformation as a displacement of the cell boundary, |eps| L_max, in mean diameters,
          // judged like a sphere's displacement.
          const std::size_t e = static_cast<std::size_t>(cols - 6);
          Eigen::Matrix3d eps;
          eps << x[e], 0.5 * x[e + 5], 0.5 * x[e + 4], 0.5 * x[e + 5], x[e + 1], 0.5 * x[e + 3], 0.5 * x[e + 4],
              0.5 * x[e + 3], x[e + 2];
          const double boundary = eps.norm() * box.lengths().maxCoeff() / diameter;
          if (boundary > result.strainDisplacement) {
            result.strainDisplacement = boundary;
            result.strain = eps;
          }
          largest = std::max(largest, boundary);
        }
        for (std::size_t m = 0; m < movable.size(); ++m) {
          Eigen::Vector3d dr;
          for (int k = 0; k < 3; ++k) dr[k] = x[3 * m + static_cast<std::size_t>(k)];
          motion.col(movable[m]) = dr * diameter;
          if (!loaded[m]) continue;  // rattlers may wander in their cages
          largest = std::max(largest, dr.norm());
          if (dr.norm() > options.displacementLimit) {
            ++displaced;
            displacedNow[m] = 1;
          }
        }
        if (options.progress) {
          options.progress(fmt::format(
              "round {} load {}{}: {} backbone spheres beyond {:.1e} D, largest {:.3g} D ({:.1f} s so far)", round,
              load + 1, sign > 0 ? "+" : "-", displaced, options.displacementLimit, largest,
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()));
        }
        if (largest > worst) {
          worst = largest;
          worstDisplaced = displaced;
          worstMotion = std::move(motion);
        }
      }
    }
    result.rounds = round;
    if (round == 1) {
      result.largestDisplacement = worst;
      result.displaced = worstDisplaced;
      result.motion = std::move(worstMotion);
      // worst < 0: no LP ran (no loads); that proves nothing.
      result.jammed = worst >= 0.0 && worst <= options.displacementLimit;
      result.outcome = worst < 0.0 ? JammingVerdict::NotTested
                       : result.jammed ? JammingVerdict::Jammed
                                       : JammingVerdict::Unjammed;
    }
    const Index setAside = std::count(displacedNow.begin(), displacedNow.end(), 1);
    result.setAsidePerRound.push_back(setAside);
    if (setAside == 0) {
      result.subpacking = static_cast<Index>(loadedCount);
      result.subpackingJammed = true;
      break;
    }
    loose += setAside;
    for (std::size_t m = 0; m < movable.size(); ++m) {
      if (displacedNow[m]) loaded[m] = 0;
    }
  }
  result.loose = loose;
  const Index backboneTested = static_cast<Index>(backboneCount);
  result.verdict =
      result.outcome == JammingVerdict::NotTested ? std::string("not tested: no LP was solved")
      : result.jammed ? fmt::format("jammed{}: no backbone sphere moves more than {:.1e} D under {} random loads",
                                  options.strict ? " (strictly: lattice deformation allowed)" : "",
                                  options.displacementLimit, 2 * options.loads)
                    : fmt::format("unjammed{}: a load moves {} backbone spheres by more than {:.1e} D (up to {:.3g} D)",
                                  options.strict ? " (strict test, lattice deformation allowed)" : "",
                                  result.displaced, options.displacementLimit, result.largestDisplacement);
  if (options.strict) {
    result.verdict += fmt::format("; largest cell deformation {:.3g} D at the cell boundary (strain norm {:.3g})",
                                  result.strainDisplacement, result.strain.norm());
  }
  if (!result.jammed && options.subpackingRounds > 1) {
    std::string perRound;
    for (Index k : result.setAsidePerRound) perRound += fmt::format("{}{}", perRound.empty() ? "" : ", ", k);
    result.verdict +=
        result.subpackingJammed
            ? fmt::format("; jammed subpacking of {} of {} backbone spheres ({:.2f}%) after {} rounds (displaced per "
                          "round: {})",
                          result.subpacking, backboneTested, 100.0 * static_cast<double>(result.subpacking) /
                                                                 static_cast<double>(backboneTested),
                          result.rounds, perRound)
            : fmt::format("; no jammed subpacking found in {} rounds ({} of {} backbone spheres set aside; displaced "
                          "per round: {})",
                          result.rounds, loose, backboneTested, perRound);
  }
  result.solver = solverName();
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}


}  // namespace polydem::jamming
