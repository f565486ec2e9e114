// The generic minimisers on their own: Nelder-Mead and BFGS on smooth test functions with known minima.
#include "broadphase/minimisers.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace polydem::broadphase {
namespace {

// Rosenbrock's banana valley, minimum 0 at (1, 1).
double rosenbrock(const double* x) {
  const double a = 1.0 - x[0], b = x[1] - x[0] * x[0];
  return a * a + 100.0 * b * b;
}

// A shifted, anisotropic quadratic in n dimensions, minimum 1 at x_k = k / n.
double bowl(const double* x, int n) {
  double f = 1.0;
  for (int k = 0; k < n; ++k) {
    const double d = x[k] - static_cast<double>(k) / n;
    f += (1.0 + k) * d * d;
  }
  return f;
}

TEST(NelderMead, FindsTheMinimumOfAQuadratic) {
  const int n = 5;
  std::vector<double> x(n, 2.0);
  long calls = 0;
  const double f = nelderMead(
      [&](const double* p) {
        ++calls;
        return bowl(p, n);
      },
      x, 0.5, 20000, 1e-14);
  EXPECT_NEAR(f, 1.0, 1e-9);
  for (int k = 0; k < n; ++k) EXPECT_NEAR(x[k], static_cast<double>(k) / n, 1e-4) << "k = " << k;
  EXPECT_LE(calls, 20000 + 2 * n + 2);  // the budget, plus at most one step's evaluations
}

TEST(NelderMead, RespectsTheEvaluationBudget) {
  std::vector<double> x{-1.2, 1.0};
  long calls = 0;
  const double f = nelderMead(
      [&](const double* p) {
        ++calls;
        return rosenbrock(p);
      },
      x, 0.3, 50, 0.0);
  EXPECT_LE(calls, 50 + 4);  // stops at the first check past the budget (a shrink costs n = 2 more)
  EXPECT_EQ(f, rosenbrock(x.data()));
  EXPECT_LT(f, rosenbrock(std::vector<double>{-1.2, 1.0}.data()));
}

TEST(Bfgs, FindsTheMinimumOfRosenbrock) {
  std::vector<double> x{-1.2, 1.0};
  const double f = bfgs(rosenbrock, x, rosenbrock(x.data()), 1e-6, 500, 0.0);
  EXPECT_LT(f, 1e-8);
  EXPECT_NEAR(x[0], 1.0, 1e-3);
  EXPECT_NEAR(x[1], 1.0, 2e-3);
}

TEST(Bfgs, StopsWhenAStepGainsLittle) {
  const int n = 4;
  std::vector<double> x(n, 3.0);
  auto f = [&](const double* p) { return bowl(p, n); };
  const double start = f(x.data());
  const double value = bfgs(f, x, start, 1e-6, 100, 1e-3);
  EXPECT_LT(value, start);
  EXPECT_EQ(value, f(x.data()));
  EXPECT_GE(value, 1.0);
}

TEST(Minimisers, AreDeterministic) {
  std::vector<double> a{-1.2, 1.0}, b{-1.2, 1.0};
  EXPECT_EQ(nelderMead(rosenbrock, a, 0.3, 400, 1e-12), nelderMead(rosenbrock, b, 0.3, 400, 1e-12));
  EXPECT_EQ(a, b);
  EXPECT_EQ(bfgs(rosenbrock, a, rosenbrock(a.data()), 1e-6, 50, 0.0),
            bfgs(rosenbrock, b, rosenbrock(b.data()), 1e-6, 50, 0.0));
  EXPECT_EQ(a, b);
}

}  // namespace
}  // namespace polydem::broadphase
