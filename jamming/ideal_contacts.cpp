#include "jamming/ideal_contacts.hpp"

#include <fmt/format.h>

#include <Eigen/SparseCore>
#include <array>
#include <chrono>
#include <cmath>
#include <random>
#include <vector>

#include "core/errors.hpp"
#include "jamming/glpk_simplex.hpp"
#include "jamming/interior_point.hpp"

namespace polydem::jamming {

bool jammingTestAvailable() { return POLYDEM_JAMMING_WITH_GLPK != 0; }

#if POLYDEM_JAMMING_WITH_GLPK

namespace {

// Rigidity matrix of the backbone: one row per contact (u . (dR_i - dR_j)), columns 3 b(i) + k.
struct Rigidity {
  std::vector<int> ia{0}, ja{0};  // GLPK arrays are 1-based
  std::vector<double> ar{0.0};
  int rows = 0, cols = 0;
  std::vector<std::array<Index, 2>> pairs;  // backbone indices per row
};

// LP-free certificate for isostatic or hyperstatic backbones (Donev 2006, §9.3.1.1, eq. 9.5, and §5.5.1.1,
// eq. 5.8-5.9): with one sphere pinned, the rigidity matrix A (free coordinates x contacts) has full
// row rank iff K = A A^T is positive definite (no floppy modes), and then f = 1 - A^T K^-1 A 1 is the
// projection of the all-ones vector onto the self-stresses (A f = 0). f > 0 everywhere is a strict
// self-stress, which with full rank proves collective first-order jamming, i.e. jamming for spheres
// (Donev 2006, §5.5.2.2). For an isostatic backbone the self-stress is unique up to scale, so a sign change in f
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
  const std::string method =
      fmt::format("augmented-system certificate, {} backbone spheres, {} contacts", backbone.size(), a.rows);
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
    result.verdict = fmt::format(
        "unjammed: rigidity matrix numerically rank deficient (lambda_min / lambda_max = "
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

// The rigidity matrix of the backbone spheres (slot >= 0): their contacts, and their hard-wall contacts.
Rigidity rigidityMatrix(const SphereView& spheres, const Box& box, const ContactNetwork& network,
                        const std::vector<int>& slot, std::size_t backboneCount) {
  Rigidity a;
  a.cols = 3 * static_cast<int>(backboneCount);
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
  return a;
}

// The unjamming motion of the backbone from the columns of a solved LP.
void motionFrom(glp_prob* p, const std::vector<Index>& backbone, JammingTestResult& result) {
  for (std::size_t b = 0; b < backbone.size(); ++b)
    for (int k = 0; k < 3; ++k) result.motion(k, backbone[b]) = glp_get_col_prim(p, static_cast<int>(3 * b) + k + 1);
}

// LP 1: open contacts. Objective = sum of rows = column sums of A.
void openingLp(const Rigidity& a, const Box& box, const std::vector<Index>& backbone, JammingTestResult& result) {
  const int ne = static_cast<int>(a.ar.size()) - 1;
  glpk::Lp lp;
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
  const int status = glpk::solve(lp.p);
  if (status != GLP_OPT) throw SimulationError(fmt::format("jamming test: opening LP status {}", status));
  ++result.lps;
  result.openingObjective = glp_get_obj_val(lp.p);
  // Any opening motion can be scaled until some contact opens at rate 1, so a non-zero optimum is >= 1.
  if (result.openingObjective > 0.5) {
    for (int r = 1; r <= a.rows; ++r) result.contactsOpened += glp_get_row_prim(lp.p, r) > 1e-6 ? 1 : 0;
    motionFrom(lp.p, backbone, result);
    result.outcome = JammingVerdict::Unjammed;
    result.verdict = fmt::format("unjammed: a motion opens {} of {} backbone contacts", result.contactsOpened, a.rows);
  }
}

// LP 2: floppy modes, keeping every contact; random objective w.
void floppyLp(const Rigidity& a, const Box& box, const std::vector<Index>& backbone, double tolerance,
              std::uint64_t seed, JammingTestResult& result) {
  const int ne = static_cast<int>(a.ar.size()) - 1;
  glpk::Lp lp;
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
  const int status = glpk::solve(lp.p);
  if (status != GLP_OPT) throw SimulationError(fmt::format("jamming test: floppy-mode LP status {}", status));
  ++result.lps;
  result.floppyObjective = glp_get_obj_val(lp.p);
  if (result.floppyObjective > tolerance * a.cols) {
    motionFrom(lp.p, backbone, result);
    result.outcome = JammingVerdict::Unjammed;
    result.verdict = "unjammed: floppy modes (a motion keeps every contact)";
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
  const Rigidity a = rigidityMatrix(spheres, box, network, slot, backbone.size());
  if (a.rows == 0) {
    result.outcome = JammingVerdict::Unjammed;
    result.verdict = "unjammed: no contacts";
    return result;
  }
  // Large backbones: GLPK's simplex does not finish at N' = 10,000 (>30 min), so decide by counting where
  // counting suffices: fewer than N_f + 1 contacts leave floppy modes, and a hypostatic sphere packing
  // cannot be jammed (Donev 2006, §5.5.2.2 and §4.3.1.1).
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
  openingLp(a, box, backbone, result);
  if (result.verdict.empty()) floppyLp(a, box, backbone, tolerance, seed, result);
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

}  // namespace polydem::jamming
