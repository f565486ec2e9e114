#include "structure/rattlers.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "core/errors.hpp"
#include "core/types.hpp"

namespace polydem::structure {
namespace {

TEST(VelocityRattlers, SlowSpheresAreRattlers) {
  const int n = 10;
  Eigen::Matrix3Xd v(3, n);
  Eigen::VectorXd r = Eigen::VectorXd::Constant(n, 0.5);
  for (int i = 0; i < n; ++i) v.col(i) = Eigen::Vector3d(1.0, -1.0, 0.5) * (1.0 + 0.1 * i);
  v.col(3) *= 1e-7;  // scaled speed ~ 1e-7
  v.col(7) *= 5e-5;  // ~ 6e-5 relative to v_rms
  r[7] = 1.0;
  const Box box = Box::cubic(10.0, Boundary::Periodic);
  const VelocityRattlers rattlers = velocityRattlers(v, r, box, 1e-4);
  EXPECT_EQ(rattlers.count, 2);
  EXPECT_TRUE(rattlers.rattler[3] && rattlers.rattler[7]);
  EXPECT_DOUBLE_EQ(rattlers.numberFraction, 0.2);
  const double rattlerVolume = 4.0 / 3.0 * kPi * (0.125 + 1.0);
  EXPECT_NEAR(rattlers.volumeFraction, rattlerVolume / 1000.0, 1e-15);
  EXPECT_NEAR(rattlers.volumeShare, rattlerVolume / (4.0 / 3.0 * kPi * (9 * 0.125 + 1.0)), 1e-15);
  // A tighter threshold keeps only the slowest.
  EXPECT_EQ(velocityRattlers(v, r, box, 1e-6).count, 1);
}

TEST(VelocityRattlers, BadInputIsAConfigError) {
  const Box box = Box::cubic(10.0, Boundary::Periodic);
  const Eigen::VectorXd r = Eigen::VectorXd::Constant(3, 0.5);
  EXPECT_THROW(velocityRattlers(Eigen::Matrix3Xd::Zero(3, 3), r, box), ConfigError);  // no speed scale
  EXPECT_THROW(velocityRattlers(Eigen::Matrix3Xd::Ones(3, 2), r, box), ConfigError);  // sizes
  EXPECT_THROW(velocityRattlers(Eigen::Matrix3Xd::Ones(3, 3), r, box, 0.0), ConfigError);
  EXPECT_THROW(velocityRattlers(Eigen::Matrix3Xd::Ones(3, 3), r, box, std::nan("")), ConfigError);
}

}  // namespace
}  // namespace polydem::structure
