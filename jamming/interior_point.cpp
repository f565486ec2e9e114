#include "jamming/interior_point.hpp"

#include <fmt/format.h>

#include <Eigen/SparseCholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include "core/errors.hpp"

#if POLYDEM_JAMMING_WITH_CHOLMOD
#include <Eigen/CholmodSupport>
#endif

namespace polydem::jamming {

namespace {

using SparseMatrix = Eigen::SparseMatrix<double>;
#if POLYDEM_JAMMING_WITH_CHOLMOD
using Cholesky = Eigen::CholmodSupernodalLLT<SparseMatrix, Eigen::Lower>;
#else
using Cholesky = Eigen::SimplicialLLT<SparseMatrix, Eigen::Lower>;
#endif

// Largest alpha in (0, 1] with v + alpha dv >= 0.
double maxStep(const Eigen::VectorXd& v, const Eigen::VectorXd& dv) {
  double alpha = 1.0;
  for (Eigen::Index i = 0; i < v.size(); ++i) {
    if (dv[i] < 0.0) alpha = std::min(alpha, -v[i] / dv[i]);
  }
  return alpha;
}

// Normal matrix E diag(d) E^T + delta I. The pattern is the same for every d > 0, so the symbolic
// analysis is done once.
SparseMatrix normalMatrix(const SparseMatrix& e, const SparseMatrix& et, const Eigen::VectorXd& d, double delta) {
  SparseMatrix k = e * d.asDiagonal() * et;
  for (Eigen::Index i = 0; i < k.rows(); ++i) k.coeffRef(i, i) += delta;
  return k;
}

// Factorises E D E^T; a matrix that round-off made indefinite (D spans ~20 decades near the optimum)
// gets a growing multiple of the identity, which only damps the Newton step.
struct NormalFactor {
  NormalFactor(const SparseMatrix& e, const SparseMatrix& et) : e(e), et(et) {
#if POLYDEM_JAMMING_WITH_CHOLMOD
    cholesky.cholmod().print = 0;  // an indefinite matrix is handled below (shifted retry); no warning lines
#endif
  }
  bool factorise(const Eigen::VectorXd& d) {
    const auto start = std::chrono::steady_clock::now();
    SparseMatrix k = normalMatrix(e, et, d, 0.0);
    const double scale = k.diagonal().maxCoeff();
    double shift = 0.0;
    bool ok = false;
    for (int attempt = 0; attempt < 8 && !ok; ++attempt) {
      if (attempt > 0) {
        const double next = attempt == 1 ? 1e-14 * scale : shift * 100.0;
        for (Eigen::Index i = 0; i < k.rows(); ++i) k.coeffRef(i, i) += next - shift;
        shift = next;
      }
      cholesky.factorize(k);
      ok = cholesky.info() == Eigen::Success;
    }
    delta = shift;
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return ok;
  }
  const SparseMatrix& e;
  const SparseMatrix& et;
  Cholesky cholesky;
  double delta = 0.0;    // the last shift used (reported)
  double seconds = 0.0;  // in the factorisations
};

// Gondzio's centrality correctors (J. Gondzio, Comput. Optim. Appl. 6, 137 (1996)) for the step (dz, ds,
// dy) with step lengths stepP, stepD; returns how many were accepted.
int centralityCorrectors(const Cholesky& cholesky, const SparseMatrix& e, const SparseMatrix& et,
                         const Eigen::VectorXd& z, const Eigen::VectorXd& s, const Eigen::VectorXd& d, double target,
                         int maxCorrectors, double& stepP, double& stepD, Eigen::VectorXd& dz, Eigen::VectorXd& ds,
                         Eigen::VectorXd& dy) {
  const Eigen::Index n = z.size();
  int correctors = 0;
  for (int k = 0; k < maxCorrectors; ++k) {
    const double trialP = std::min(1.0, 1.5 * stepP + 0.1), trialD = std::min(1.0, 1.5 * stepD + 0.1);
    const Eigen::VectorXd v = (z + trialP * dz).cwiseProduct(s + trialD * ds);
    Eigen::VectorXd corr(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      corr[i] = std::clamp(v[i], 0.1 * target, 10.0 * target) - v[i];
      corr[i] = std::max(corr[i], -10.0 * target);
    }
    // Newton step for the correction alone (zero residuals): K dy = -E (corr / s).
    const Eigen::VectorXd corrOverS = corr.cwiseQuotient(s);
    const Eigen::VectorXd dyc = cholesky.solve(Eigen::VectorXd(-(e * corrOverS)));
    const Eigen::VectorXd dsc = -(et * dyc);
    const Eigen::VectorXd dzc = corrOverS - d.cwiseProduct(dsc);
    const Eigen::VectorXd dzNew = dz + dzc, dsNew = ds + dsc;
    const double newP = maxStep(z, dzNew), newD = maxStep(s, dsNew);
    if (std::min(newP, newD) < 1.01 * std::min(stepP, stepD) + 0.01) break;
    dz = dzNew;
    ds = dsNew;
    dy += dyc;
    stepP = newP;
    stepD = newD;
    ++correctors;
  }
  return correctors;
}

// Mehrotra's starting point: least-norm z with E z = r and least-squares s = c - E^T y, shifted positive.
// False if E E^T is not positive definite.
bool startingPoint(NormalFactor& factor, const SparseMatrix& e, const SparseMatrix& et, const Eigen::VectorXd& r,
                   const Eigen::VectorXd& c, Eigen::VectorXd& y, Eigen::VectorXd& s, Eigen::VectorXd& z) {
  Eigen::VectorXd ones = Eigen::VectorXd::Ones(e.cols());
  factor.cholesky.analyzePattern(normalMatrix(e, et, ones, 0.0));
  if (!factor.factorise(ones)) return false;
  y = factor.cholesky.solve(e * c);
  s = c - et * y;
  z = et * factor.cholesky.solve(r);
  z.array() += std::max(-1.5 * z.minCoeff(), 0.0);
  s.array() += std::max(-1.5 * s.minCoeff(), 0.0);
  {
    const double zs = std::max(z.dot(s), 1e-12);
    z.array() += 0.5 * zs / std::max(s.sum(), 1e-12);
    s.array() += 0.5 * zs / std::max(z.sum(), 1e-12);
    // Degenerate data (c = 0 or r = 0) can leave zeros.
    z = z.cwiseMax(1e-8);
    s = s.cwiseMax(1e-8);
  }
  return true;
}

// Newton directions of one iteration and their buffers (reused across iterations).
struct Directions {
  Directions(Eigen::Index m, Eigen::Index n) : rhs(m), dy(m), ds(n), dz(n), rc(n), dzAff(n), dsAff(n) {}
  Eigen::VectorXd rhs, dy, ds, dz, rc, dzAff, dsAff;
};

// Step lengths of one iteration (and what the trace reports).
struct StepLengths {
  double alphaPAff, alphaDAff, sigma;  // affine-scaling step lengths, centring parameter
  int correctors;                      // accepted centrality correctors
  double alphaP, alphaD;               // primal and dual step lengths taken
};

// Mehrotra's predictor-corrector direction (dz, ds, dy) into dir, with Gondzio's correctors, for the
// residuals rp, rd at (z, s) with D = diag(d) already factorised.
StepLengths predictorCorrector(const Cholesky& cholesky, const SparseMatrix& e, const SparseMatrix& et,
                               const Eigen::VectorXd& z, const Eigen::VectorXd& s, const Eigen::VectorXd& d,
                               const Eigen::VectorXd& rp, const Eigen::VectorXd& rd, double mu, double nd,
                               int maxCorrectors, Directions& dir) {
  // K dy = rp + E (d rd - rc / s);  ds = rd - E^T dy;  dz = rc / s - d ds.
  auto newton = [&](const Eigen::VectorXd& rcv) {
    dir.rhs = rp + e * (d.cwiseProduct(rd) - rcv.cwiseQuotient(s));
    dir.dy = cholesky.solve(dir.rhs);
    dir.ds = rd - et * dir.dy;
    dir.dz = rcv.cwiseQuotient(s) - d.cwiseProduct(dir.ds);
  };
  dir.rc = -z.cwiseProduct(s);
  newton(dir.rc);
  StepLengths out;
  out.alphaPAff = maxStep(z, dir.dz);
  out.alphaDAff = maxStep(s, dir.ds);
  const double muAff = (z + out.alphaPAff * dir.dz).dot(s + out.alphaDAff * dir.ds) / nd;
  out.sigma = std::pow(std::clamp(muAff / mu, 0.0, 1.0), 3);
  dir.dzAff = dir.dz;
  dir.dsAff = dir.ds;
  dir.rc.array() += out.sigma * mu - dir.dzAff.cwiseProduct(dir.dsAff).array();
  newton(dir.rc);
  // Gondzio's centrality correctors (J. Gondzio, Comput. Optim. Appl. 6, 137 (1996)): aim at longer
  // steps by pulling the complementarity products of the trial point into [0.1, 10] x the target;
  // each costs one solve with the same factor (~3% of a factorisation here). Accepted while they
  // lengthen the step.
  double stepP = maxStep(z, dir.dz), stepD = maxStep(s, dir.ds);
  out.correctors = centralityCorrectors(cholesky, e, et, z, s, d, out.sigma * mu, maxCorrectors, stepP, stepD, dir.dz,
                                        dir.ds, dir.dy);
  constexpr double kEta = 0.995;
  out.alphaP = std::min(1.0, kEta * stepP);
  out.alphaD = std::min(1.0, kEta * stepD);
  return out;
}

// Objectives and scaled residuals of the iterate (z, y) into out; returns the relative duality gap.
double measureIterate(const Eigen::VectorXd& r, const Eigen::VectorXd& c, const Eigen::VectorXd& z,
                      const Eigen::VectorXd& y, const Eigen::VectorXd& rp, const Eigen::VectorXd& rd, double rNorm,
                      double cNorm, InteriorPointResult& out) {
  out.primalObjective = c.dot(z);
  out.dualObjective = r.dot(y);
  out.primalResidual = rp.norm() / rNorm;
  out.dualResidual = rd.norm() / cNorm;
  return std::abs(out.primalObjective - out.dualObjective) / (1.0 + std::abs(out.primalObjective));
}

// Not converged: the best iterate, with why the method stopped (the last iteration's count kept).
InteriorPointResult bestIterate(InteriorPointResult out, InteriorPointResult best,
                                const InteriorPointOptions& options) {
  const std::string why =
      out.message.empty() ? fmt::format("no convergence in {} iterations", options.maxIterations) : out.message;
  const int iterations = out.iterations;
  out = std::move(best);
  out.converged = false;
  out.message = fmt::format(
      "{}; best iterate (iteration {}): primal residual {:.1e}, dual residual {:.1e}, gap "
      "{:.1e}",
      why, out.iterations, out.primalResidual, out.dualResidual,
      std::abs(out.primalObjective - out.dualObjective) / (1.0 + std::abs(out.primalObjective)));
  out.iterations = iterations;
  return out;
}

}  // namespace

struct SpdSolver::Impl {
  Cholesky cholesky;
};
SpdSolver::SpdSolver() : impl_(new Impl) {
#if POLYDEM_JAMMING_WITH_CHOLMOD
  impl_->cholesky.cholmod().print = 0;
#endif
}
SpdSolver::~SpdSolver() { delete impl_; }
bool SpdSolver::factor(const SparseMatrix& k) {
  impl_->cholesky.compute(k);
  return impl_->cholesky.info() == Eigen::Success;
}
Eigen::VectorXd SpdSolver::solve(const Eigen::VectorXd& b) const { return impl_->cholesky.solve(b); }

bool interiorPointUsesCholmod() { return POLYDEM_JAMMING_WITH_CHOLMOD != 0; }

InteriorPointResult solveStandardFormLp(const SparseMatrix& e, const Eigen::VectorXd& r, const Eigen::VectorXd& c,
                                        const InteriorPointOptions& options) {
  const Eigen::Index m = e.rows(), n = e.cols();
  if (r.size() != m || c.size() != n) {
    throw SimulationError(
        fmt::format("interior point: E is {} x {}, r has {} and c {} entries", m, n, r.size(), c.size()));
  }
  InteriorPointResult out;
  const SparseMatrix et = e.transpose();
  NormalFactor factor(e, et);
  const Cholesky& cholesky = factor.cholesky;
  auto factorise = [&](const Eigen::VectorXd& d) { return factor.factorise(d); };

  Eigen::VectorXd y, s, z;
  if (!startingPoint(factor, e, et, r, c, y, s, z)) {
    out.message = "E E^T is not positive definite (E lacks full row rank)";
    return out;
  }

  const double rNorm = 1.0 + r.norm(), cNorm = 1.0 + c.norm();
  const double nd = static_cast<double>(n);
  Eigen::VectorXd d(n);
  Directions dir(m, n);
  const Eigen::VectorXd &dy = dir.dy, &ds = dir.ds, &dz = dir.dz;
  // The best iterate by the worst of the three criteria relative to its tolerance: past the optimum the
  // round-off in the solves can make the primal residual grow again, and the best point is returned.
  InteriorPointResult best;
  double bestMerit = std::numeric_limits<double>::infinity();
  int sinceBest = 0;
  auto keepBest = [&](double merit) {
    if (merit < bestMerit) {
      bestMerit = merit;
      best = out;
      best.z = z;
      best.y = y;
      best.s = s;
      sinceBest = 0;
    } else {
      ++sinceBest;
    }
  };
  for (int iteration = 0; iteration < options.maxIterations; ++iteration) {
    const Eigen::VectorXd rp = r - e * z;
    const Eigen::VectorXd rd = c - et * y - s;
    const double mu = z.dot(s) / nd;
    const double gap = measureIterate(r, c, z, y, rp, rd, rNorm, cNorm, out);
    out.iterations = iteration;
    if (options.trace) {
      fmt::print(stderr,
                 "ip {:3d}  primal {:.6e}  dual {:.6e}  rp {:.2e}  rd {:.2e}  gap {:.2e}  mu {:.2e}  delta {:.1e}\n",
                 iteration, out.primalObjective, out.dualObjective, out.primalResidual, out.dualResidual, gap, mu,
                 factor.delta);
    }
    const double merit = std::max(
        {out.primalResidual / options.primalTolerance, out.dualResidual / options.tolerance, gap / options.tolerance});
    keepBest(merit);
    if (merit <= 1.0) {
      out.converged = true;
      out.message = fmt::format("converged in {} iterations", iteration);
      break;
    }
    // Far from the optimum the merit can rise for a while (infeasibility traded for centrality): only a
    // stall near convergence stops the method.
    if (sinceBest >= options.stallIterations && bestMerit < 1e4) {
      out.message = fmt::format("stalled at iteration {}", iteration);
      break;
    }
    if (!std::isfinite(mu)) {
      out.message = fmt::format("diverged at iteration {}", iteration);
      break;
    }
    d = z.cwiseQuotient(s);
    if (!factorise(d)) {
      out.message = fmt::format("normal matrix not positive definite at iteration {}", iteration);
      break;
    }
    const StepLengths step =
        predictorCorrector(cholesky, e, et, z, s, d, rp, rd, mu, nd, options.centralityCorrectors, dir);
    const double alphaP = step.alphaP, alphaD = step.alphaD;
    if (options.trace) {
      fmt::print(stderr, "     alphaAff {:.3f} {:.3f}  sigma {:.2e}  correctors {}  alpha {:.3f} {:.3f}\n",
                 step.alphaPAff, step.alphaDAff, step.sigma, step.correctors, alphaP, alphaD);
    }
    z += alphaP * dz;
    y += alphaD * dy;
    s += alphaD * ds;
  }
  if (out.converged) {
    out.z = std::move(z);
    out.y = std::move(y);
    out.s = std::move(s);
  } else {
    out = bestIterate(std::move(out), std::move(best), options);
  }
  out.factorSeconds = factor.seconds;
  return out;
}

}  // namespace polydem::jamming
