#include "structure/channel_size.hpp"

#include <gtest/gtest.h>

#include <Eigen/QR>
#include <cmath>
#include <numeric>
#include <random>

#include "core/errors.hpp"
#include "core/types.hpp"
#include "polydem/config.hpp"
#include "structure/delaunay_neighbours.hpp"
#include "tests/structure/lattices.hpp"

namespace polydem::structure {
namespace {

/// A random rigid motion, so the exact cases are not all axis-aligned.
struct Motion {
  Eigen::Matrix3d rotation;
  Eigen::Vector3d shift;
  Eigen::Vector3d operator()(const Eigen::Vector3d& x) const { return rotation * x + shift; }
};
Motion randomMotion(unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g;
  Eigen::Matrix3d a;
  for (int k = 0; k < 9; ++k) a(k / 3, k % 3) = g(rng);
  Eigen::HouseholderQR<Eigen::Matrix3d> qr(a);
  return {Eigen::Matrix3d(qr.householderQ()), Eigen::Vector3d(g(rng), g(rng), g(rng)) * 10.0};
}

TEST(Apollonius, ThreeTouchingEqualSpheres) {
  for (unsigned seed : {1u, 2u, 3u}) {
    const Motion m = randomMotion(seed);
    const double r = 0.37;
    const Eigen::Vector3d a = m({0, 0, 0}), b = m({2 * r, 0, 0}), c = m({r, std::sqrt(3.0) * r, 0});
    const auto R = apolloniusGapRadius(a, r, b, r, c, r);
    ASSERT_TRUE(R.has_value());
    EXPECT_NEAR(*R / r, 2.0 / std::sqrt(3.0) - 1.0, 1e-9);
    EXPECT_NEAR(*R / r, 0.1547005, 1e-7);
    EXPECT_TRUE(acuteTriangle(a, b, c));
  }
}

TEST(Apollonius, SquareOfTouchingSpheresIsARightTriangleKeptByEpsilon) {
  for (unsigned seed : {4u, 5u}) {
    const Motion m = randomMotion(seed);
    const double r = 1.3;
    const Eigen::Vector3d a = m({0, 0, 0}), b = m({2 * r, 0, 0}), c = m({2 * r, 2 * r, 0});
    EXPECT_TRUE(acuteTriangle(a, b, c));  // right angle within eps = 1 - 1e-12
    const auto R = apolloniusGapRadius(a, r, b, r, c, r);
    ASSERT_TRUE(R.has_value());
    EXPECT_NEAR(*R / r, std::sqrt(2.0) - 1.0, 1e-9);
  }
}

TEST(Apollonius, AcuteFilterKeepsRightAnglesOnlyThroughEpsilon) {
  EXPECT_TRUE(acuteTriangle({0, 0, 0}, {2, 0, 0}, {2, 2, 0}));
  EXPECT_FALSE(acuteTriangle({0, 0, 0}, {2, 0, 0}, {2, 2, 0}, 1.0));  // exact integers: eps = 1 drops it
  EXPECT_TRUE(acuteTriangle({0, 0, 0}, {2, 0, 0}, {1, 1.5, 0}, 1.0));
}

TEST(Apollonius, InnerSoddyCircleOfRadiiOneTwoThree) {
  // Mutually tangent circles of radii 1, 2, 3 (a 3-4-5 triangle): Descartes gives 6/23 for the gap circle.
  const auto R = apolloniusGapRadius({0, 0, 0}, 1.0, {3, 0, 0}, 2.0, {0, 4, 0}, 3.0);
  ASSERT_TRUE(R.has_value());
  EXPECT_NEAR(*R, 6.0 / 23.0, 1e-12);
}

TEST(Apollonius, NoGapCircleWhenCirclesCoverTheTriangleOrCentresAreCollinear) {
  EXPECT_FALSE(apolloniusGapRadius({0, 0, 0}, 1.0, {1, 0, 0}, 1.0, {0.5, 0.8, 0}, 1.0).has_value());
  EXPECT_FALSE(apolloniusGapRadius({0, 0, 0}, 0.1, {1, 0, 0}, 0.1, {2, 0, 0}, 0.1).has_value());
  EXPECT_FALSE(acuteTriangle({0, 0, 0}, {2, 0, 0}, {1, 0.2, 0}));  // obtuse
}

/// One central particle with the given neighbours (explicit list, no triangulation).
ChannelHistogram channelsAround(double rc, const std::vector<Eigen::Vector3d>& centres,
                                const std::vector<double>& radii) {
  const int n = static_cast<int>(centres.size()) + 1;
  Eigen::Matrix3Xd x = Eigen::Matrix3Xd::Zero(3, n);
  Eigen::VectorXd r(n);
  r[0] = rc;
  NeighbourList nb;
  nb.start = {0, n - 1};
  for (int k = 1; k < n; ++k) {
    x.col(k) = centres[k - 1];
    r[k] = radii[k - 1];
    nb.start.push_back(n - 1);
    nb.neighbour.push_back(k);
  }
  nb.displacement = x.rightCols(n - 1);
  return channelSizes(SphereView{x, r}, nb);
}

TEST(ChannelSizes, CoplanarTouchingNeighboursAt120DegreesGiveOne) {
  const double r = 0.8;
  std::vector<Eigen::Vector3d> c;
  for (int k = 0; k < 3; ++k)
    c.push_back(2 * r * Eigen::Vector3d(std::cos(2 * kPi * k / 3), std::sin(2 * kPi * k / 3), 0));
  const auto R = apolloniusGapRadius(c[0], r, c[1], r, c[2], r);
  ASSERT_TRUE(R.has_value());
  EXPECT_NEAR(*R / r, 1.0, 1e-9);
  const ChannelHistogram h = channelsAround(r, c, {r, r, r});
  EXPECT_EQ(h.triangles, 1);
  EXPECT_EQ(h.channels, 1);
  EXPECT_NEAR(h.mean, 1.0, 1e-9);
  EXPECT_NEAR(std::accumulate(h.density.begin(), h.density.end(), 0.0) * h.binWidth, 1.0, 1e-12);
}

TEST(ChannelSizes, CentralParticleRadiusScalesTheStatistic) {
  // The channel of three touching spheres of radius 1 seen from a central sphere of radius 2: 0.1547 / 2.
  const std::vector<Eigen::Vector3d> c = {{0, 0, 3}, {2, 0, 3}, {1, std::sqrt(3.0), 3}};
  const ChannelHistogram h = channelsAround(2.0, c, {1, 1, 1});
  EXPECT_NEAR(h.mean, (2.0 / std::sqrt(3.0) - 1.0) / 2.0, 1e-9);
  EXPECT_EQ(h.counts.size(), 8u);  // bin 7 = [0.07, 0.08)
}

TEST(ChannelSizes, FccHasDiscreteBraggLikePeaks) {
  // Perfect FCC of touching spheres with its 12-neighbour shell: every particle sees the same acute
  // triangles, so the histogram is a set of delta peaks (Ogarko's thesis §4.4: "Bragg-like"): 8 triangles
  // of mutually touching neighbours (2/sqrt(3) - 1), 24 squares (sqrt(2) - 1), 68 channels at exactly 1
  // (coplanar triples in the four close-packed planes through the centre, and the like), and three
  // further values 0.73, 0.80, 0.89.
  const test::Lattice fcc = test::fcc(3);
  const NeighbourList nb = cutoffNeighbours(fcc.spheres(), fcc.box, 1.01);
  const ChannelHistogram h = channelSizes(fcc.spheres(), nb);
  const std::int64_t n = fcc.radius.size();
  EXPECT_EQ(h.counts[static_cast<std::size_t>((2.0 / std::sqrt(3.0) - 1.0) / 0.01)], 8 * n);
  EXPECT_EQ(h.counts[static_cast<std::size_t>((std::sqrt(2.0) - 1.0) / 0.01)], 24 * n);
  EXPECT_EQ(h.counts[99] + h.counts[100], 68 * n);  // R/r = 1 up to round-off lands in either bin
  int occupied = 0;
  for (std::int64_t c : h.counts) occupied += c > 0;
  EXPECT_EQ(occupied, 7);
  EXPECT_EQ(h.counts.size(), 101u);
}

TEST(ChannelSizes, DiluteGasIsGaussianAroundSixteen) {
  ASSERT_TRUE(POLYDEM_WITH_CGAL) << "built without CGAL (POLYDEM_WITH_CGAL=OFF): no Delaunay neighbours";
  // Ogarko's thesis Fig. 4.2: ideal gas at nu = 0.0014, mean R_j / r_i ~ 15.9, width ~ 4 (+-5%).
  const int n = 4096;
  const double r = 0.5, phi = 0.0014;
  const double length = std::cbrt(n * 4.0 / 3.0 * kPi * r * r * r / phi);
  const test::Lattice gas = test::idealGas(n, length, r, 21);
  const NeighbourList nb = delaunayNeighbours(gas.spheres(), gas.box);
  EXPECT_EQ(nb.unverifiedCells, 0);
  const ChannelHistogram h = channelSizes(gas.spheres(), nb);
  EXPECT_NEAR(h.mean, 15.9, 0.05 * 15.9);
  EXPECT_NEAR(h.stddev, 4.0, 1.0);
  EXPECT_GT(h.acute, 0);
  EXPECT_LT(h.acute, h.triangles);
}

TEST(ChannelSizes, LargeRatiosGoToOverflow) {
  const std::vector<Eigen::Vector3d> c = {{0, 0, 3}, {2, 0, 3}, {1, std::sqrt(3.0), 3}};
  NeighbourList nb;
  Eigen::Matrix3Xd x = Eigen::Matrix3Xd::Zero(3, 4);
  for (int k = 0; k < 3; ++k) x.col(k + 1) = c[k] * 100.0;  // spheres 100 apart, radius 1: R ~ 114
  Eigen::VectorXd r = Eigen::VectorXd::Ones(4);
  nb.start = {0, 3, 3, 3, 3};
  nb.neighbour = {1, 2, 3};
  nb.displacement = x.rightCols(3);
  const ChannelHistogram h = channelSizes(SphereView{x, r}, nb, {.maxRatio = 50.0});
  EXPECT_EQ(h.channels, 1);
  EXPECT_EQ(h.overflow, 1);
  EXPECT_TRUE(h.counts.empty());
  EXPECT_NEAR(h.mean, 200.0 / std::sqrt(3.0) - 1.0, 1e-9);
}

TEST(ChannelSizes, RejectsBadOptions) {
  const test::Lattice lattice = test::sc(3);
  const NeighbourList nb = cutoffNeighbours(lattice.spheres(), lattice.box, 1.01);
  EXPECT_THROW(channelSizes(lattice.spheres(), nb, {.binWidth = 0.0}), ConfigError);
  EXPECT_THROW(channelSizes(lattice.spheres(), nb, {.eps = 1.5}), ConfigError);
  EXPECT_THROW(channelSizes(lattice.spheres(), nb, {.maxRatio = 0.001}), ConfigError);
  const test::Lattice other = test::sc(2);
  EXPECT_THROW(channelSizes(other.spheres(), nb), ConfigError);
}

}  // namespace
}  // namespace polydem::structure
