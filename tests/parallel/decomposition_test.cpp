#include "parallel/decomposition.hpp"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "core/errors.hpp"

namespace polydem::parallel {
namespace {

bool inRegion(const Region& r, const Eigen::Vector3d& x, const Box& box) {
  for (int k = 0; k < 3; ++k) {
    if (x[k] < r.lo[k] || (x[k] >= r.hi[k] && r.hi[k] < box.length(k))) return false;
  }
  return true;
}

std::vector<Eigen::Vector3d> points(const Box& box, int n, unsigned seed, bool clustered) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d x;
    for (int k = 0; k < 3; ++k) x[k] = u(rng) * box.length(k);
    if (clustered) x[2] *= u(rng) * u(rng);  // settled at the bottom: far from uniform
    out.push_back(x);
  }
  return out;
}

TEST(Decomposition, BrickChoosesTheLeastCutArea) {
  const Box cube = Box::cubic(1.0, Boundary::Periodic);
  EXPECT_EQ(Decomposition::brick(cube, 8).describe(), "brick grid 2 x 2 x 2");
  EXPECT_EQ(Decomposition::brick(cube, 3).describe(), "brick grid 1 x 1 x 3");
  // A walled axis has one interface fewer: two ranks cut across it.
  const Box walled(Eigen::Vector3d(1.0, 1.0, 1.0), {Boundary::Periodic, Boundary::Periodic, Boundary::Wall});
  EXPECT_EQ(Decomposition::brick(walled, 2).describe(), "brick grid 1 x 1 x 2");
  // A long box is cut along its length.
  const Box longBox(Eigen::Vector3d(8.0, 1.0, 1.0), {Boundary::Periodic, Boundary::Periodic, Boundary::Periodic});
  EXPECT_EQ(Decomposition::brick(longBox, 4).describe(), "brick grid 4 x 1 x 1");
  EXPECT_THROW(Decomposition::brick(cube, 0), ConfigError);
}

TEST(Decomposition, OwnersLieInTheirRegions) {
  const Box box(Eigen::Vector3d(3.0, 2.0, 1.0), {Boundary::Periodic, Boundary::Wall, Boundary::Wall});
  const std::vector<Eigen::Vector3d> xs = points(box, 2000, 1, true);
  for (int ranks : {1, 2, 3, 4, 6, 7}) {
    SCOPED_TRACE(ranks);
    const Decomposition brick = Decomposition::brick(box, ranks);
    const Decomposition rcb = Decomposition::bisection(box, ranks, [&](const Region& r, int axis, double cut) {
      double w = 0.0;
      for (const auto& x : xs) w += (x[axis] < cut && inRegion(r, x, box)) ? 1.0 : 0.0;
      return w;
    });
    for (const Decomposition* d : {&brick, &rcb}) {
      std::vector<int> count(static_cast<std::size_t>(ranks), 0);
      for (const auto& x : xs) {
        const int q = d->owner(x.data());
        ASSERT_GE(q, 0);
        ASSERT_LT(q, ranks);
        EXPECT_EQ(d->distanceSquared(x.data(), q), 0.0);
        ++count[static_cast<std::size_t>(q)];
      }
      if (d == &rcb) {
        // Equal counts up to the halving resolution (ties at a cut are not split).
        for (int c : count) EXPECT_NEAR(c, 2000.0 / ranks, 2.0);
      }
    }
  }
}

TEST(Decomposition, DistanceGoesThroughPeriodicImages) {
  const Box box(Eigen::Vector3d(10.0, 10.0, 10.0), {Boundary::Periodic, Boundary::Periodic, Boundary::Wall});
  const Decomposition d = Decomposition::brick(box, 2);  // cut across z (walled): [0, 5) and [5, 10]
  const Eigen::Vector3d low(1.0, 1.0, 1.0), high(1.0, 1.0, 9.5);
  EXPECT_DOUBLE_EQ(d.distanceSquared(low.data(), 1), 16.0);  // no image across a wall
  EXPECT_DOUBLE_EQ(d.distanceSquared(high.data(), 0), 20.25);
  const Box periodic = Box::cubic(10.0, Boundary::Periodic);
  const Decomposition p = Decomposition::brick(periodic, 2);  // [0, 5) and [5, 10) along z (the first of equals)
  ASSERT_EQ(p.describe(), "brick grid 1 x 1 x 2");
  const Eigen::Vector3d nearZero(3.0, 3.0, 0.5), nearTop(3.0, 3.0, 9.75);
  EXPECT_DOUBLE_EQ(p.distanceSquared(nearZero.data(), 1), 0.25);  // to x = 10 through the image
  EXPECT_DOUBLE_EQ(p.distanceSquared(nearTop.data(), 0), 0.0625);
}

}  // namespace
}  // namespace polydem::parallel
