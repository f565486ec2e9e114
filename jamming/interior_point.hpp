#pragma once
// Primal-dual interior-point solver for sparse linear programs in standard form, for the jamming tests
// of large packings.
//
// Why not GLPK or CLP: on the randomised load LP of a 10,000-sphere packing (30,000 displacements,
// 40,000 constraints) GLPK's simplex, CLP's dual simplex and CLP's barrier each ran > 15 minutes
// without an answer, and GLPK's interior point stopped on numerical instability already at N = 1000
// (measured 2026-11-22, docs/edmd.md). Donev met the same wall (A. Donev, PhD thesis, Princeton (2006),
// §9.3.1 and §4.6.3). The force form of that LP has only 3N equality rows, and its normal
// matrix E D E^T has the sparsity of the contact network (3 x 3 blocks, like a stiffness matrix), which
// a supernodal Cholesky (CHOLMOD with BLAS) factors in ~1.5 s for N = 10,000; with ~30-50 iterations a
// load LP takes about a minute.
//
// Mehrotra's predictor-corrector (S. Mehrotra, SIAM J. Optim. 2, 575 (1992); J. Nocedal & S. Wright,
// Numerical Optimization, 2nd ed., Algorithm 14.3): min c.z s.t. E z = r, z >= 0, with the dual
// max r.y s.t. E^T y + s = c, s >= 0. E must have full row rank (the jamming LPs append +-I columns).
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <string>

namespace polydem::jamming {

struct InteriorPointOptions {
  double tolerance = 1e-9;        ///< |E^T y + s - c| / (1 + |c|) and |c.z - r.y| / (1 + |c.z|)
  double primalTolerance = 1e-6;  ///< |E z - r| / (1 + |r|): near the optimum the normal matrix spans ~20
                                  ///< decades and the solves limit it to ~1e-9..1e-6 on jamming LPs
  int stallIterations = 15;       ///< stop after this many iterations without a better iterate (the best is returned)
  int maxIterations = 200;
  int centralityCorrectors = 2;  ///< Gondzio correctors per iteration (0 = plain Mehrotra)
  bool trace = false;            ///< one line per iteration on stderr
};

struct InteriorPointResult {
  bool converged = false;
  std::string message;  ///< why it stopped
  int iterations = 0;
  Eigen::VectorXd z;             ///< primal solution
  Eigen::VectorXd y;             ///< equality multipliers (dual solution)
  Eigen::VectorXd s;             ///< reduced costs
  double primalObjective = 0.0;  ///< c.z
  double dualObjective = 0.0;    ///< r.y
  double primalResidual = 0.0;   ///< |E z - r| / (1 + |r|)
  double dualResidual = 0.0;     ///< |E^T y + s - c| / (1 + |c|)
  double factorSeconds = 0.0;    ///< time in the Cholesky factorisations
};

/// True if the sparse Cholesky is CHOLMOD's supernodal one (with BLAS); otherwise Eigen's simplicial
/// factorisation, ~5-20x slower on 3D contact networks.
bool interiorPointUsesCholmod();

/// Sparse symmetric positive definite solver with the same Cholesky as the interior point.
class SpdSolver {
 public:
  SpdSolver();
  ~SpdSolver();
  SpdSolver(const SpdSolver&) = delete;
  SpdSolver& operator=(const SpdSolver&) = delete;
  /// Factor k (full symmetric storage); false if it is not numerically positive definite.
  bool factor(const Eigen::SparseMatrix<double>& k);
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const;

 private:
  struct Impl;
  Impl* impl_;
};

/// Solve min c.z s.t. E z = r, z >= 0 (E: m x n, full row rank). Throws SimulationError on size mismatch.
InteriorPointResult solveStandardFormLp(const Eigen::SparseMatrix<double>& e, const Eigen::VectorXd& r,
                                        const Eigen::VectorXd& c, const InteriorPointOptions& options = {});

}  // namespace polydem::jamming
