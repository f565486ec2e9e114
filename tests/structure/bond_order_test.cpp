#include "structure/bond_order.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <complex>
#include <random>
#include <string>

#include "core/errors.hpp"
#include "core/types.hpp"
#include "polydem/config.hpp"
#include "structure/delaunay_neighbours.hpp"
#include "structure/spherical_harmonics.hpp"
#include "tests/structure/lattices.hpp"

namespace polydem::structure {
namespace {

using C = std::complex<double>;

Eigen::Vector3d direction(double theta, double phi) {
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

TEST(SphericalHarmonics, KnownValues) {
  std::array<C, 25> y{};
  sphericalHarmonics(0, direction(0.3, 1.1), y);
  EXPECT_NEAR(y[0].real(), 1.0 / std::sqrt(4.0 * kPi), 1e-15);
  // Y_60 at the pole = sqrt(13 / 4 pi); Y_66 on the equator at phi = 0 = sqrt(3003 / pi) / 64.
  sphericalHarmonics(6, direction(0.0, 0.0), y);
  EXPECT_NEAR(y[6].real(), std::sqrt(13.0 / (4.0 * kPi)), 1e-13);
  EXPECT_NEAR(std::abs(y[7]), 0.0, 1e-15);
  sphericalHarmonics(6, direction(kPi / 2, 0.0), y);
  EXPECT_NEAR(y[12].real(), std::sqrt(3003.0 / kPi) / 64.0, 1e-13);
  EXPECT_NEAR(y[0].real(), std::sqrt(3003.0 / kPi) / 64.0, 1e-13);  // (-1)^6 conj
  // Y_21 = -(1/2) sqrt(15 / 2 pi) sin(theta) cos(theta) e^{i phi} (Condon-Shortley sign).
  const double theta = 0.7, phi = 2.3;
  sphericalHarmonics(2, direction(theta, phi), y);
  const C expected = -0.5 * std::sqrt(15.0 / (2.0 * kPi)) * std::sin(theta) * std::cos(theta) * std::polar(1.0, phi);
  EXPECT_NEAR(std::abs(y[3] - expected), 0.0, 1e-14);
  EXPECT_NEAR(std::abs(y[1] + std::conj(expected)), 0.0, 1e-14);  // Y_2,-1 = -conj(Y_21)
  // Y_30 = (1/4) sqrt(7 / pi) (5 cos^3 - 3 cos)
  sphericalHarmonics(3, direction(theta, phi), y);
  const double c = std::cos(theta);
  EXPECT_NEAR(y[3].real(), 0.25 * std::sqrt(7.0 / kPi) * (5 * c * c * c - 3 * c), 1e-14);
}

TEST(SphericalHarmonics, AdditionTheoremHoldsForEveryDegree) {
  // sum_m |Y_lm|^2 = (2l + 1) / 4 pi, and sum_m Y_lm(u) conj(Y_lm(v)) = (2l + 1)/(4 pi) P_l(u.v).
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g;
  std::array<C, 25> a{}, b{};
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Vector3d u = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    const Eigen::Vector3d v = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    for (int l = 0; l <= kMaxDegree; ++l) {
      sphericalHarmonics(l, u, a);
      sphericalHarmonics(l, v, b);
      double norm = 0.0;
      C cross = 0.0;
      for (int m = 0; m < 2 * l + 1; ++m) {
        norm += std::norm(a[m]);
        cross += a[m] * std::conj(b[m]);
      }
      EXPECT_NEAR(norm, (2 * l + 1) / (4 * kPi), 1e-12) << "l = " << l;
      if (l == 6) {
        const double x = u.dot(v);
        const double p6 = (231 * std::pow(x, 6) - 315 * std::pow(x, 4) + 105 * x * x - 5) / 16;
        EXPECT_NEAR(cross.real(), 13.0 / (4 * kPi) * p6, 1e-12);
        EXPECT_NEAR(cross.imag(), 0.0, 1e-12);
      }
    }
  }
}

// Literature q6 of perfect lattices with their first shell, recomputed independently from the addition
// theorem q6 = sqrt(sum_jk P6(cos g_jk)) / N_b: FCC 0.5745243, HCP 0.4847617, SC 0.3535534,
// BCC (8) 0.6285394, BCC (8 + 6) 0.5106882.
struct LatticeCase {
  const char* name;
  test::Lattice lattice;
  double cutoff;
  int neighbours;
  double q6;
};

TEST(BondOrder, PerfectLatticesWithFirstShellNeighbours) {
  const LatticeCase cases[] = {
      {"fcc", test::fcc(3), 1.01, 12, 0.5745242597140695}, {"hcp", test::hcp(3), 1.01, 12, 0.4847616852236832},
      {"sc", test::sc(5), 1.01, 6, 0.35355339059327373},   {"bcc8", test::bcc(4), 1.01, 8, 0.6285393610547096},
      {"bcc14", test::bcc(4), 1.2, 14, 0.510688230856951},
  };
  for (const LatticeCase& c : cases) {
    SCOPED_TRACE(c.name);
    const NeighbourList nb = cutoffNeighbours(c.lattice.spheres(), c.lattice.box, c.cutoff);
    for (Index i = 0; i < nb.count(); ++i) ASSERT_EQ(nb.degree(i), c.neighbours);
    const BondOrder order = bondOrder(nb);
    for (double q : order.q) EXPECT_NEAR(q, c.q6, 1e-12);
    EXPECT_NEAR(order.meanQ, c.q6, 1e-12);
    // Every particle has the same q_6m (HCP's two sublattices too: their environments are mirror images
    // through the basal plane, which leaves the l = 6 harmonics with m = 0, +-6 unchanged and q_6,+-3 = 0),
    // so the bond average Q6 equals q6.
    EXPECT_NEAR(order.globalQ, c.q6, 1e-12);
    EXPECT_DOUBLE_EQ(order.crystallineFraction, 1.0);
  }
}

TEST(BondOrder, BccDelaunayNeighboursAreTheFourteenOfTheFirstTwoShells) {
  ASSERT_TRUE(POLYDEM_WITH_CGAL) << "built without CGAL (POLYDEM_WITH_CGAL=OFF): no Delaunay neighbours";
  // BCC's Voronoi cell (truncated octahedron) is simple, so the Delaunay triangulation is unique: 8 + 6
  // neighbours, q6 = 0.5106882 exactly (the literature BCC value).
  const test::Lattice bcc = test::bcc(4);
  const NeighbourList nb = delaunayNeighbours(bcc.spheres(), bcc.box);
  for (Index i = 0; i < nb.count(); ++i) ASSERT_EQ(nb.degree(i), 14) << i;
  const BondOrder order = bondOrder(nb);
  for (double q : order.q) EXPECT_NEAR(q, 0.510688230856951, 1e-9);
  EXPECT_DOUBLE_EQ(order.crystallineFraction, 1.0);
}

TEST(BondOrder, DegenerateLatticesWithDelaunayNeighboursAreFullyCrystalline) {
  ASSERT_TRUE(POLYDEM_WITH_CGAL) << "built without CGAL (POLYDEM_WITH_CGAL=OFF): no Delaunay neighbours";
  // FCC / HCP octahedra and SC cubes are cospherical: the triangulation splits them arbitrarily and
  // adds some second-shell neighbours, so q6 is not the first-shell value, but every particle keeps its
  // first shell and stays solid-like (d6 > 0.65 with >= 6 neighbours).
  const std::pair<const char*, test::Lattice> cases[] = {{"fcc", test::fcc(4)},
                                                         {"hcp", test::hcp(4)},
                                                         {"fcc jittered", test::fcc(4, 1e-3)},
                                                         {"hcp jittered", test::hcp(4, 1e-3)}};
  for (const auto& [name, lattice] : cases) {
    SCOPED_TRACE(name);
    const NeighbourList nb = delaunayNeighbours(lattice.spheres(), lattice.box);
    for (Index i = 0; i < nb.count(); ++i) {
      int firstShell = 0;
      for (Index k = nb.start[i]; k < nb.start[i + 1]; ++k) firstShell += nb.displacement.col(k).norm() < 1.01;
      ASSERT_EQ(firstShell, 12) << i;
      ASSERT_GE(nb.degree(i), 12);
    }
    const BondOrder order = bondOrder(nb);
    EXPECT_DOUBLE_EQ(order.crystallineFraction, 1.0);
  }
}

TEST(BondOrder, IdealGasIsNotCrystalline) {
  ASSERT_TRUE(POLYDEM_WITH_CGAL) << "built without CGAL (POLYDEM_WITH_CGAL=OFF): no Delaunay neighbours";
  const test::Lattice gas = test::idealGas(3000, 20.0, 0.1, 7);
  const BondOrder order = bondOrder(delaunayNeighbours(gas.spheres(), gas.box));
  EXPECT_LT(order.crystallineFraction, 0.02);
  EXPECT_LT(order.globalQ, 0.05);  // random bonds: Q6 ~ 1 / sqrt(bonds)
  EXPECT_GT(order.meanQ, 0.2);     // ~15 random bonds per particle: q6 ~ 0.3
  EXPECT_LT(order.meanQ, 0.45);
}

TEST(BondOrder, MatchesTheAdditionTheoremOnRandomBondSets) {
  ASSERT_TRUE(POLYDEM_WITH_CGAL) << "built without CGAL (POLYDEM_WITH_CGAL=OFF): no Delaunay neighbours";
  const test::Lattice gas = test::idealGas(200, 6.0, 0.1, 11);
  const NeighbourList nb = delaunayNeighbours(gas.spheres(), gas.box);
  const BondOrder order = bondOrder(nb);
  for (Index i = 0; i < nb.count(); ++i) {
    double s = 0.0;
    for (Index a = nb.start[i]; a < nb.start[i + 1]; ++a) {
      for (Index b = nb.start[i]; b < nb.start[i + 1]; ++b) {
        const double x = nb.displacement.col(a).normalized().dot(nb.displacement.col(b).normalized());
        s += (231 * std::pow(x, 6) - 315 * std::pow(x, 4) + 105 * x * x - 5) / 16;
      }
    }
    EXPECT_NEAR(order.q[i], std::sqrt(std::max(0.0, s)) / nb.degree(i), 1e-10);
    EXPECT_NEAR(bondCorrelation(order, i, i), 1.0, 1e-12);
  }
}

TEST(BondOrder, RejectsBadOptions) {
  const test::Lattice lattice = test::sc(3);
  const NeighbourList nb = cutoffNeighbours(lattice.spheres(), lattice.box, 1.01);
  EXPECT_THROW(bondOrder(nb, {.degree = 13}), ConfigError);
  EXPECT_THROW(bondOrder(nb, {.connectionThreshold = 1.5}), ConfigError);
  EXPECT_THROW(bondOrder(nb, {.minConnections = -1}), ConfigError);
}

}  // namespace
}  // namespace polydem::structure
