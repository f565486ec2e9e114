#include "structure/structure_factor.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <random>

#include "core/errors.hpp"
#include "core/types.hpp"
#include "tests/structure/lattices.hpp"

namespace polydem::structure {
namespace {

TEST(StructureFactor, SimpleCubicLatticeHasBraggPeaksOnly) {
  const int cells = 8;
  const test::Lattice lattice = test::sc(cells);  // spacing 1, D = 1
  const double N = lattice.radius.size();
  EXPECT_NEAR(structureFactorAt(lattice.spheres(), lattice.box, {cells, 0, 0}).s, N, 1e-9 * N);
  EXPECT_NEAR(structureFactorAt(lattice.spheres(), lattice.box, {cells, cells, 0}).s, N, 1e-9 * N);
  EXPECT_NEAR(structureFactorAt(lattice.spheres(), lattice.box, {1, 0, 0}).s, 0.0, 1e-20 * N);
  EXPECT_NEAR(structureFactorAt(lattice.spheres(), lattice.box, {3, -2, 5}).s, 0.0, 1e-20 * N);

  // Shells (dk = 2 pi / L): below K = 2 pi / a nothing; the shell holding |n| = 8 has the three Bragg
  // vectors of the half space.
  const StructureFactor sk = structureFactor(lattice.spheres(), lattice.box, {.kMax = 2 * kPi * 1.05});
  ASSERT_FALSE(sk.k.empty());
  bool bragg = false;
  for (std::size_t s = 0; s < sk.k.size(); ++s) {
    const double total = sk.s[s] * double(sk.vectors[s]);
    if (sk.k[s] < 2 * kPi * 0.95) {
      EXPECT_LT(sk.s[s], 1e-20 * N) << "K = " << sk.k[s];
    } else {
      bragg = true;
      EXPECT_NEAR(total, 3 * N, 1e-8 * N);
    }
  }
  EXPECT_TRUE(bragg);
}

TEST(StructureFactor, StrideKeepsTheBraggPeaks) {
  // A vector cap forces n = stride m; the reciprocal lattice vectors (8, 0, 0) etc. are multiples of 2.
  const test::Lattice lattice = test::sc(8);
  const double N = lattice.radius.size();
  const StructureFactor sk =
      structureFactor(lattice.spheres(), lattice.box, {.kMax = 2 * kPi * 1.05, .maxVectors = 200});
  EXPECT_EQ(sk.stride, 2);
  EXPECT_LE(sk.totalVectors, 250);
  double total = 0.0;
  for (std::size_t s = 0; s < sk.k.size(); ++s) total += sk.s[s] * double(sk.vectors[s]);
  EXPECT_NEAR(total, 3 * N, 1e-8 * N);
}

TEST(StructureFactor, ShellAveragesMatchDirectSummation) {
  // Polydisperse random spheres in a non-cubic box: the table/recurrence code against sin/cos sums.
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const int n = 300;
  const Box box(Eigen::Vector3d(7.0, 8.0, 9.5), {Boundary::Periodic, Boundary::Periodic, Boundary::Periodic});
  Eigen::Matrix3Xd x(3, n);
  Eigen::VectorXd r(n);
  for (int i = 0; i < n; ++i) {
    x.col(i) = Eigen::Vector3d(u(rng), u(rng), u(rng)).cwiseProduct(box.lengths());
    r[i] = 0.2 + 0.3 * u(rng);
  }
  const SphereView spheres{x, r};
  const double kMax = 9.0;
  const StructureFactor sk = structureFactor(spheres, box, {.kMax = kMax});
  const double D = 2 * r.mean(), kmax = kMax / D, dk = 2 * kPi / box.lengths().minCoeff();
  std::vector<double> s(sk.k.size() + 64, 0.0), chi(s.size(), 0.0), kk(s.size(), 0.0);
  std::vector<long> count(s.size(), 0);
  long total = 0;
  for (int a = 0; a <= 20; ++a) {
    for (int b = -20; b <= 20; ++b) {
      for (int c = -20; c <= 20; ++c) {
        if (a == 0 && (b < 0 || (b == 0 && c <= 0))) continue;  // half space
        const Eigen::Vector3d k = 2 * kPi * Eigen::Vector3d(a, b, c).cwiseQuotient(box.lengths());
        if (k.norm() > kmax) continue;
        const StructureFactorValue v = structureFactorAt(spheres, box, {a, b, c});
        const auto shell = static_cast<std::size_t>(std::floor(k.norm() / dk + 0.5));
        s[shell] += v.s;
        chi[shell] += v.chi;
        kk[shell] += k.norm() * D;
        ++count[shell];
        ++total;
      }
    }
  }
  EXPECT_EQ(total, sk.totalVectors);
  std::size_t out = 0;
  for (std::size_t shell = 0; shell < s.size(); ++shell) {
    if (count[shell] == 0) continue;
    ASSERT_LT(out, sk.k.size());
    EXPECT_EQ(count[shell], sk.vectors[out]);
    EXPECT_NEAR(sk.k[out], kk[shell] / count[shell], 1e-10);
    EXPECT_NEAR(sk.s[out], s[shell] / count[shell], 1e-9 * (1 + s[shell] / count[shell]));
    EXPECT_NEAR(sk.chi[out], chi[shell] / count[shell], 1e-9 * (chi[shell] / count[shell]) + 1e-15);
    ++out;
  }
  EXPECT_EQ(out, sk.k.size());
}

TEST(StructureFactor, IdealGasIsFlatAtOne) {
  // Uncorrelated points: S(k) is exponentially distributed with mean 1 at every k; over ~30000 vectors
  // the mean is 1 within 3 sigma = 0.02, and each shell with >= 1000 vectors within 0.15.
  const test::Lattice gas = test::idealGas(3000, 15.0, 0.5, 8);
  const StructureFactor sk = structureFactor(gas.spheres(), gas.box, {.kMax = 25.0});
  double sum = 0.0;
  std::int64_t vectors = 0;
  for (std::size_t s = 0; s < sk.k.size(); ++s) {
    sum += sk.s[s] * double(sk.vectors[s]);
    vectors += sk.vectors[s];
    if (sk.vectors[s] >= 1000) {
      EXPECT_NEAR(sk.s[s], 1.0, 0.15) << "K = " << sk.k[s];
    }
    // Equal radii: chi = m(k; R)^2 N S / V.
    const double m = sphereFormFactor(sk.k[s] / sk.diameter, 0.5);
    EXPECT_GT(sk.chi[s], 0.0);
    (void)m;
  }
  EXPECT_GT(vectors, 20000);
  EXPECT_NEAR(sum / double(vectors), 1.0, 0.02);
}

TEST(StructureFactor, FormFactor) {
  EXPECT_NEAR(sphereFormFactor(1e-6, 2.0), 4.0 / 3.0 * kPi * 8.0, 1e-9);
  EXPECT_NEAR(sphereFormFactor(0.0, 2.0), 4.0 / 3.0 * kPi * 8.0, 1e-12);
  // kR = pi: 4 pi (0 + pi) / k^3
  EXPECT_NEAR(sphereFormFactor(kPi / 2.0, 2.0), 4.0 * kPi * kPi / std::pow(kPi / 2.0, 3), 1e-12);
  // Continuity across the series switch at kR = 1e-2.
  // (slope there 4 pi (-2k/30) = -8e-3, so 2e-10 apart they agree to ~2e-12).
  EXPECT_NEAR(sphereFormFactor(0.0099999999, 1.0), sphereFormFactor(0.0100000001, 1.0), 1e-11);
}

TEST(StructureFactor, NeedsAPeriodicBox) {
  const test::Lattice gas = test::idealGas(50, 5.0, 0.2, 1);
  const Box walled(gas.box.lengths(), {Boundary::Periodic, Boundary::Periodic, Boundary::Wall});
  try {
    structureFactor(gas.spheres(), walled);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("periodic on every axis"), std::string::npos) << e.what();
  }
  EXPECT_THROW(structureFactorAt(gas.spheres(), walled, {1, 0, 0}), ConfigError);
  EXPECT_THROW(structureFactor(gas.spheres(), gas.box, {.kMax = -1.0}), ConfigError);
  EXPECT_THROW(structureFactorAt(gas.spheres(), gas.box, {0, 0, 0}), ConfigError);
}

}  // namespace
}  // namespace polydem::structure
