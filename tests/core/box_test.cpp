#include "core/box.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "core/errors.hpp"

namespace polydem {
namespace {

TEST(Box, MinimumImageIsOddAndShortest) {
  const Box box(Eigen::Vector3d(10.0, 20.0, 30.0), {Boundary::Periodic, Boundary::Wall, Boundary::Periodic});
  const Eigen::Vector3d d(9.0, 15.0, -16.0);
  const Eigen::Vector3d m = box.minimumImage(d);
  EXPECT_DOUBLE_EQ(m[0], -1.0);
  EXPECT_DOUBLE_EQ(m[1], 15.0);  // walled axis untouched
  EXPECT_DOUBLE_EQ(m[2], 14.0);
  EXPECT_EQ(box.minimumImage(-d), -m);
  EXPECT_EQ(box.minimumImageAny(Eigen::Vector3d(39.0, 0.0, 0.0))[0], -1.0);
}

TEST(Box, WrapAndContains) {
  const Box box = Box::cubic(2.0, Boundary::Periodic);
  const Eigen::Vector3d w = box.wrap(Eigen::Vector3d(-0.5, 2.0, 5.25));
  EXPECT_DOUBLE_EQ(w[0], 1.5);
  EXPECT_DOUBLE_EQ(w[1], 0.0);
  EXPECT_DOUBLE_EQ(w[2], 1.25);
  EXPECT_TRUE(box.contains(w));
  EXPECT_FALSE(box.contains(Eigen::Vector3d(2.0, 0.0, 0.0)));
  const Box walls = Box::cubic(2.0, Boundary::Wall);
  EXPECT_TRUE(walls.contains(Eigen::Vector3d(2.0, 0.0, 0.0)));  // on the wall
  EXPECT_FALSE(walls.contains(Eigen::Vector3d(std::nan(""), 0.0, 0.0)));
  EXPECT_EQ(walls.wrap(Eigen::Vector3d(-1.0, 0.0, 0.0))[0], -1.0);
}

// Fuzz findings (text particle reader, session 9): the quick fold x - L floor(x / L) left the primary cell for
// far images (round-off of the product), for a subnormal length (x / L overflows to inf, the result was -inf)
// and for x one ulp below L (x / L rounds to 1, the result was negative). wrap must land in [0, L) always,
// and wrapping a wrapped point must change nothing (files written and read again are bit-identical).
TEST(Box, WrapLandsInThePrimaryCellForExtremeInputs) {
  const double below = std::nextafter(10.0, 0.0);
  const Box box(Eigen::Vector3d(10.0, 9e-311, 10.0), {Boundary::Periodic, Boundary::Periodic, Boundary::Periodic});
  for (const Eigen::Vector3d& x : {Eigen::Vector3d(1.18e41, 1.0, 7.7e14), Eigen::Vector3d(-1.18e41, -1.0, -7.7e14),
                                   Eigen::Vector3d(below, 5e-311, -1e-300),
                                   Eigen::Vector3d(-1e-18, 0.0, -std::numeric_limits<double>::denorm_min())}) {
    const Eigen::Vector3d w = box.wrap(x);
    EXPECT_TRUE(box.contains(w)) << "wrap(" << x.transpose() << ") = " << w.transpose();
    EXPECT_EQ(box.wrap(w), w) << "wrap is not idempotent at " << w.transpose();
  }
  EXPECT_EQ(box.wrap(Eigen::Vector3d(below, 0.0, 0.0))[0], below);
}

TEST(Box, RejectsBadLengths) {
  EXPECT_THROW(Box::cubic(0.0, Boundary::Wall), ConfigError);
  EXPECT_THROW(Box::cubic(std::nan(""), Boundary::Wall), ConfigError);
  EXPECT_THROW(Box(Eigen::Vector3d(1.0, -1.0, 1.0), {Boundary::Wall, Boundary::Wall, Boundary::Wall}), ConfigError);
}

TEST(Box, Describe) {
  EXPECT_EQ(Box::cubic(2.0, Boundary::Periodic).describe(), "periodic 2 x 2 x 2");
  const Box mixed(Eigen::Vector3d(1.0, 2.0, 3.0), {Boundary::Wall, Boundary::Periodic, Boundary::Wall});
  EXPECT_EQ(mixed.describe(), "walls(xz) periodic(y) 1 x 2 x 3");
}

}  // namespace
}  // namespace polydem
