// The rules of relax --sweep (integrators/convergence.hpp), and the DemSettings and CompressionSettings
// predicates that the command line and the library share.
#include "integrators/convergence.hpp"

#include <gtest/gtest.h>

#include <optional>

#include "integrators/dem_simulation.hpp"
#include "integrators/soft_compression.hpp"

namespace polydem::integrators {
namespace {

TEST(Convergence, StepsCoverTheSameSimulatedTime) {
  EXPECT_EQ(stepsForSameTime(1000, 50.0, 100.0), 2000);
  EXPECT_EQ(stepsForSameTime(1000, 50.0, 10.0), 200);
  EXPECT_EQ(stepsForSameTime(7, 20.0, 10.0), 4);  // 3.5 rounds away from zero
  EXPECT_EQ(stepsForSameTime(0, 50.0, 200.0), 0);
}

TEST(Convergence, DissipationFreeRunsMeasureTheirOwnDrift) {
  const Box box(Eigen::Vector3d(10.0, 10.0, 10.0), {Boundary::Periodic, Boundary::Periodic, Boundary::Periodic});
  Eigen::Matrix3Xd x(3, 1), xref(3, 1);
  x << 1.0, 1.0, 1.0;
  xref << 1.0, 1.0, 1.0;
  // The reference's energies do not matter for a dissipation-free scene.
  const ConvergenceError e = convergenceError({2.0, 2.02, x}, {5.0, 1.0, xref}, true, box, 0.5);
  ASSERT_TRUE(e.energy.has_value());
  EXPECT_NEAR(*e.energy, 0.01, 1e-12);
  EXPECT_EQ(e.position, 0.0);
}

TEST(Convergence, DissipativeRunsAreComparedWithTheReference) {
  const Box box(Eigen::Vector3d(10.0, 10.0, 10.0), {Boundary::Periodic, Boundary::Periodic, Boundary::Wall});
  Eigen::Matrix3Xd x(3, 2), xref(3, 2);
  x << 9.9, 5.0, 1.0, 5.0, 1.0, 9.0;
  xref << 0.1, 5.0, 1.0, 5.0, 1.0, 8.0;  // x wraps (0.2 apart); z is walled (1.0 apart)
  const ConvergenceError e = convergenceError({4.0, 3.0, x}, {2.0, 2.5, xref}, false, box, 0.5);
  ASSERT_TRUE(e.energy.has_value());
  EXPECT_NEAR(*e.energy, 0.25, 1e-12);  // |3 - 2.5| / |2|
  EXPECT_NEAR(e.position, 2.0, 1e-12);  // largest distance 1.0 over r_min 0.5
}

TEST(Convergence, ZeroEnergyScale) {
  const Box box(Eigen::Vector3d(1.0, 1.0, 1.0), {Boundary::Wall, Boundary::Wall, Boundary::Wall});
  const Eigen::Matrix3Xd x = Eigen::Matrix3Xd::Constant(3, 1, 0.5);
  EXPECT_EQ(convergenceError({0.0, 0.0, x}, {0.0, 0.0, x}, true, box, 1.0).energy, std::optional<double>(0.0));
  EXPECT_FALSE(convergenceError({0.0, 1e-9, x}, {0.0, 0.0, x}, true, box, 1.0).energy.has_value());
}

TEST(DemSettingsRules, RotationForFrictionOrTheGeneralKernel) {
  DemSettings s;
  s.contact.stiffness = 1.0;
  EXPECT_FALSE(s.needsRotation());
  s.contact.friction = 0.3;
  EXPECT_TRUE(s.needsRotation());
  s.contact.friction = 0.0;
  s.generalKernel = true;
  EXPECT_TRUE(s.needsRotation());
}

TEST(DemSettingsRules, DissipationFree) {
  DemSettings s;
  s.contact.stiffness = 1.0;
  EXPECT_TRUE(s.dissipationFree());  // e = 1, mu = 0, no damping by default
  s.contact.restitution = 0.9;
  EXPECT_FALSE(s.dissipationFree());
  s.contact.restitution = 1.0;
  s.contact.friction = 0.1;
  EXPECT_FALSE(s.dissipationFree());
  s.contact.friction = 0.0;
  s.viscousDamping = 0.5;
  EXPECT_FALSE(s.dissipationFree());
  s.viscousDamping = 0.0;
  s.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);  // gravity conserves energy: still dissipation-free
  EXPECT_TRUE(s.dissipationFree());
}

TEST(CompressionRules, StartIsGeneratedAtMostAtTheTarget) {
  CompressionSettings c;
  c.targetPacking = 0.6;
  EXPECT_EQ(c.startPacking(0.3), 0.3);
  EXPECT_EQ(c.startPacking(0.7), 0.6);
}

}  // namespace
}  // namespace polydem::integrators
