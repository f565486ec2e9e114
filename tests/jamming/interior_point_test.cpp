// The interior-point LP solver behind the load test of large packings: textbook optimum, optimality
// conditions on random LPs, and bad input.
#include "jamming/interior_point.hpp"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "core/errors.hpp"

namespace polydem::jamming {
namespace {

Eigen::SparseMatrix<double> sparse(const Eigen::MatrixXd& dense) { return dense.sparseView(); }

TEST(InteriorPoint, TextbookOptimum) {
  // max x1 + x2 s.t. x1 + 2 x2 <= 4, 3 x1 + x2 <= 6, x >= 0: optimum (1.6, 1.2), value 2.8, duals (0.4, 0.2).
  Eigen::MatrixXd e(2, 4);
  e << 1, 2, 1, 0, 3, 1, 0, 1;
  const Eigen::Vector2d r(4, 6);
  const Eigen::Vector4d c(-1, -1, 0, 0);
  const InteriorPointResult ip = solveStandardFormLp(sparse(e), r, c);
  ASSERT_TRUE(ip.converged) << ip.message;
  EXPECT_NEAR(ip.z[0], 1.6, 1e-8);
  EXPECT_NEAR(ip.z[1], 1.2, 1e-8);
  EXPECT_NEAR(ip.primalObjective, -2.8, 1e-8);
  EXPECT_NEAR(ip.y[0], -0.4, 1e-8);
  EXPECT_NEAR(ip.y[1], -0.2, 1e-8);
  EXPECT_LT(ip.iterations, 30);
}

TEST(InteriorPoint, RandomLpsMeetTheOptimalityConditions) {
  // Feasible and bounded by construction: r = E z0 with z0 > 0, c = E^T y0 + s0 with s0 > 0. At the
  // optimum: E z = r, E^T y + s = c, z, s >= 0, complementarity z.s ~ 0, and c.z = r.y.
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> uniform(0.1, 2.0);
  for (int trial = 0; trial < 5; ++trial) {
    const int m = 20 + 10 * trial, n = 3 * m;
    std::vector<Eigen::Triplet<double>> t;
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < 3; ++k) t.emplace_back(static_cast<int>(rng() % m), j, normal(rng));
    for (int i = 0; i < m; ++i) t.emplace_back(i, i, 1.0);  // full row rank
    Eigen::SparseMatrix<double> e(m, n);
    e.setFromTriplets(t.begin(), t.end());
    Eigen::VectorXd z0(n), s0(n), y0(m);
    for (int j = 0; j < n; ++j) z0[j] = uniform(rng) * (j % 2);  // some zero: a degenerate optimum is fine
    for (int j = 0; j < n; ++j) s0[j] = uniform(rng) * ((j + 1) % 2);
    for (int i = 0; i < m; ++i) y0[i] = normal(rng);
    const Eigen::VectorXd r = e * z0;
    const Eigen::VectorXd c = Eigen::VectorXd(e.transpose() * y0) + s0;
    const InteriorPointResult ip = solveStandardFormLp(e, r, c);
    ASSERT_TRUE(ip.converged) << "trial " << trial << ": " << ip.message;
    // z0 and (y0, s0) are complementary, so both are optimal: the optimum value is c.z0 = r.y0.
    EXPECT_NEAR(ip.primalObjective, c.dot(z0), 1e-7 * (1 + std::abs(c.dot(z0))));
    EXPECT_NEAR(ip.dualObjective, r.dot(y0), 1e-7 * (1 + std::abs(r.dot(y0))));
    EXPECT_LT((e * ip.z - r).norm(), 1e-7 * (1 + r.norm()));
    EXPECT_GE(ip.z.minCoeff(), 0.0);
    EXPECT_GE(ip.s.minCoeff(), 0.0);
    EXPECT_LT(ip.z.dot(ip.s), 1e-7 * n);
  }
}

TEST(InteriorPoint, RejectsMismatchedSizes) {
  Eigen::MatrixXd e = Eigen::MatrixXd::Identity(2, 3);
  EXPECT_THROW(solveStandardFormLp(sparse(e), Eigen::VectorXd::Ones(3), Eigen::VectorXd::Ones(3)), SimulationError);
}

}  // namespace
}  // namespace polydem::jamming
