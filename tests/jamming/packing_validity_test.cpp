// Verdicts only where they apply (issue 15): the validity check of a hard-sphere packing (overlaps against
// the smaller radius, density against the bound of jamming/contact_network.hpp), the true smallest gap, and
// jamming tests that say "not tested" instead of a vacuous "jammed".
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "core/errors.hpp"
#include "jamming/contact_network.hpp"
#include "jamming/load_protocols.hpp"
#include "tests/support/lattices.hpp"

namespace polydem::jamming {
namespace {

const double kFcc = kPi / std::sqrt(18.0);

TEST(PackingValidity, InflatedFccIsRefused) {
  // FCC with radii inflated by 1%: every nearest pair overlaps by 2% of the diameter (1.98% of the radius,
  // far beyond any contact tolerance), and the packing fraction is 1.01^3 x pi/sqrt(18) = 0.763.
  Eigen::Matrix3Xd x;
  Eigen::VectorXd r;
  const Box box = edmd::testing::latticePacking(true, 3, -0.01, x, r);
  const SphereView spheres{x, r};
  const PackingValidity v = checkHardSpherePacking(spheres, box, {.overlapTolerance = 1e-4});
  EXPECT_FALSE(v.valid());
  EXPECT_TRUE(v.overlapTooLarge());
  EXPECT_TRUE(v.densityTooHigh());
  EXPECT_TRUE(v.equalSpheres);
  EXPECT_NEAR(v.densityBound, kFcc, 1e-14);
  EXPECT_NEAR(v.packingFraction, kFcc * std::pow(1.01, 3), 1e-12);
  EXPECT_NEAR(v.worstOverlap, 0.02 / 1.01, 1e-9);
  EXPECT_EQ(v.overlaps, 108 * 12 / 2);  // every nearest-neighbour bond
  ASSERT_GE(v.worstI, 0);
  ASSERT_GE(v.worstJ, 0);
  EXPECT_NE(v.worstI, v.worstJ);
  const std::string text = describeInvalidPacking(v);
  EXPECT_NE(text.find("spheres " + std::to_string(v.worstI) + " and " + std::to_string(v.worstJ) +
                      " overlap by 0.0198 of the smaller radius"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("packing fraction 0.76"), std::string::npos) << text;
  EXPECT_NE(text.find("FCC density"), std::string::npos) << text;
  // The ids of the file name the pair, not the indices.
  std::vector<Index> ids(108);
  for (Index i = 0; i < 108; ++i) ids[static_cast<std::size_t>(i)] = 1000 + i;
  EXPECT_NE(describeInvalidPacking(v, ids).find("spheres " + std::to_string(1000 + v.worstI) + " and " +
                                                std::to_string(1000 + v.worstJ)),
            std::string::npos);
  EXPECT_THROW(requireHardSpherePacking(spheres, box, {.overlapTolerance = 1e-4}, "fcc.txt"), InputError);
  try {
    requireHardSpherePacking(spheres, box, {.overlapTolerance = 1e-4}, "fcc.txt");
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("fcc.txt: not a valid hard-sphere packing: spheres"), std::string::npos)
        << e.what();
  }
}

TEST(PackingValidity, DensityAboveFccIsRefusedEvenWithOverlapsInsideTheTolerance) {
  // A contact tolerance of 5% would accept the 2% overlaps, but no packing of equal spheres is denser than
  // FCC: the density alone refuses it, and the message still names the worst pair.
  Eigen::Matrix3Xd x;
  Eigen::VectorXd r;
  const Box box = edmd::testing::latticePacking(true, 3, -0.01, x, r);
  const PackingValidity v = checkHardSpherePacking(SphereView{x, r}, box, {.overlapTolerance = 0.05});
  EXPECT_FALSE(v.overlapTooLarge());
  EXPECT_TRUE(v.densityTooHigh());
  EXPECT_FALSE(v.valid());
  const std::string text = describeInvalidPacking(v);
  EXPECT_NE(text.find("worst overlap: spheres"), std::string::npos) << text;
}

TEST(PackingValidity, JammedFccAndLatticesAtContactAreValid) {
  for (const double gap : {1e-9, 0.0}) {
    Eigen::Matrix3Xd x;
    Eigen::VectorXd r;
    const Box box = edmd::testing::latticePacking(true, 3, gap, x, r);
    const PackingValidity v = checkHardSpherePacking(SphereView{x, r}, box, {.overlapTolerance = 1e-8});
    EXPECT_TRUE(v.valid()) << describeInvalidPacking(v);
    EXPECT_LE(v.packingFraction, kFcc * (1.0 + 1e-12));
    EXPECT_LT(v.worstOverlap, 1e-12);
    EXPECT_TRUE(describeInvalidPacking(v).empty());
  }
}

TEST(PackingValidity, PolydisperseBoundShrinksToTheSmallestRadius) {
  // Half the spheres of radius 1, half of 1.1: phi_max = pi/sqrt(18) (1 + 1.331) / 2 = 0.8633.
  Eigen::Matrix3Xd x(3, 4);
  x << 1, 5, 1, 5, 1, 1, 5, 5, 1, 1, 1, 1;
  Eigen::VectorXd r(4);
  r << 1.0, 1.1, 1.0, 1.1;
  const Box box = Box::cubic(8.0, Boundary::Periodic);
  const PackingValidity v = checkHardSpherePacking(SphereView{x, r}, box, {});
  EXPECT_FALSE(v.equalSpheres);
  EXPECT_NEAR(v.densityBound, kFcc * (1.0 + 1.331) / 2.0, 1e-12);
  EXPECT_TRUE(v.valid());
  // A wide distribution: the bound is the box itself.
  r << 1.0, 3.0, 1.0, 1.0;
  x.col(1) << 5, 5, 5;
  const PackingValidity wide = checkHardSpherePacking(SphereView{x, r}, Box::cubic(12.0, Boundary::Periodic), {});
  EXPECT_DOUBLE_EQ(wide.densityBound, 1.0);
  EXPECT_TRUE(wide.valid()) << describeInvalidPacking(wide);
  // More sphere volume than box volume (phi = 1.04): refused against the box volume whatever the tolerance.
  r[1] = 3.7;
  const PackingValidity full =
      checkHardSpherePacking(SphereView{x, r}, Box::cubic(6.0, Boundary::Periodic), {.overlapTolerance = 10.0});
  EXPECT_FALSE(full.overlapTooLarge());
  EXPECT_GT(full.packingFraction, 1.0);
  EXPECT_TRUE(full.densityTooHigh());
  EXPECT_NE(describeInvalidPacking(full).find("the box volume"), std::string::npos) << describeInvalidPacking(full);
}

TEST(PackingValidity, OverlapIsMeasuredAgainstTheSmallerRadius) {
  // A sphere of radius 0.1 sunk 0.1 deep into one of radius 1: 100% of the small radius (4.5% of r_i + r_j).
  Eigen::Matrix3Xd x(3, 2);
  x << 5, 6, 5, 5, 5, 5;
  Eigen::VectorXd r(2);
  r << 1.0, 0.1;
  const PackingValidity v =
      checkHardSpherePacking(SphereView{x, r}, Box::cubic(10.0, Boundary::Periodic), {.overlapTolerance = 0.5});
  EXPECT_NEAR(v.worstOverlap, 1.0, 1e-12);
  EXPECT_EQ(v.worstI, 0);
  EXPECT_EQ(v.worstJ, 1);
  EXPECT_TRUE(v.overlapTooLarge());
}

TEST(PackingValidity, WallsAndOwnImages) {
  Eigen::Matrix3Xd x(3, 1);
  x << 0.5, 5, 5;
  Eigen::VectorXd r(1);
  r << 1.0;
  // Crossing the lower x wall by half its radius.
  const PackingValidity wall = checkHardSpherePacking(SphereView{x, r}, Box::cubic(10.0, Boundary::Wall), {});
  EXPECT_NEAR(wall.worstOverlap, 0.5, 1e-12);
  EXPECT_EQ(wall.worstJ, -1);
  EXPECT_EQ(wall.worstWall, 0);
  EXPECT_NE(describeInvalidPacking(wall).find("sphere 0 crosses the lower wall at x = 0 by 0.5"), std::string::npos)
      << describeInvalidPacking(wall);
  // Wider than a periodic length: it overlaps itself (brute force, no broad phase fits that box).
  const PackingValidity self = checkHardSpherePacking(
      SphereView{x, r}, Box(Eigen::Vector3d(1.5, 10, 10), {Boundary::Periodic, Boundary::Periodic, Boundary::Periodic}),
      {});
  EXPECT_NEAR(self.worstOverlap, 0.5, 1e-12);
  EXPECT_EQ(self.worstJ, 0);
  EXPECT_NE(describeInvalidPacking(self).find("own periodic image"), std::string::npos);
}

TEST(PackingValidity, EmptyAndSingleSphereAreValid) {
  const Eigen::Matrix3Xd none(3, 0);
  const Eigen::VectorXd noRadius(0);
  const PackingValidity empty =
      checkHardSpherePacking(SphereView{none, noRadius}, Box::cubic(10.0, Boundary::Periodic), {});
  EXPECT_TRUE(empty.valid());
  EXPECT_EQ(empty.packingFraction, 0.0);
  Eigen::Matrix3Xd x(3, 1);
  x << 5, 5, 5;
  Eigen::VectorXd r(1);
  r << 1.0;
  EXPECT_TRUE(checkHardSpherePacking(SphereView{x, r}, Box::cubic(10.0, Boundary::Periodic), {}).valid());
}

TEST(SmallestGap, UndefinedBelowTwoSpheresAndThroughTheMinimumImage) {
  Eigen::Matrix3Xd x(3, 2);
  x << 1, 9, 5, 5, 5, 5;
  Eigen::VectorXd r(2);
  r << 0.5, 0.5;
  const Box box = Box::cubic(10.0, Boundary::Periodic);
  EXPECT_FALSE(smallestGap(SphereView{x.leftCols(0), r.head(0)}, box).has_value());
  EXPECT_FALSE(smallestGap(SphereView{x.leftCols(1), r.head(1)}, box).has_value());
  const auto gap = smallestGap(SphereView{x, r}, box);
  ASSERT_TRUE(gap.has_value());
  EXPECT_NEAR(gap->gap, 1.0, 1e-12);  // distance 2 across the boundary, r_i + r_j = 1
  // With walls the spheres are 8 apart.
  const auto walled = smallestGap(SphereView{x, r}, Box::cubic(10.0, Boundary::Wall));
  EXPECT_NEAR(walled->gap, 7.0, 1e-12);
}

TEST(SmallestGap, DiluteGasAgreesWithBruteForce) {
  // 3000 spheres (above the brute-force threshold) at phi ~ 0.004: the closest pair is far beyond any
  // contact cutoff, and the growing broad-phase search must still find it.
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 100.0), radius(0.2, 0.6);
  const Index n = 3000;
  Eigen::Matrix3Xd x(3, n);
  Eigen::VectorXd r(n);
  for (Index i = 0; i < n; ++i) {
    x.col(i) << u(rng), u(rng), u(rng);
    r[i] = radius(rng);
  }
  const Box box = Box::cubic(100.0, Boundary::Periodic);
  double best = 1e300;
  for (Index i = 0; i < n; ++i) {
    for (Index j = i + 1; j < n; ++j) {
      const double s = r[i] + r[j];
      best = std::min(best, (box.minimumImage(x.col(i) - x.col(j)).norm() - s) / s);
    }
  }
  const auto gap = smallestGap(SphereView{x, r}, box);
  ASSERT_TRUE(gap.has_value());
  EXPECT_DOUBLE_EQ(gap->gap, best);
}

TEST(JammingVerdicts, NoLoadsIsRefusedAndNoSpheresIsNotTested) {
  Eigen::Matrix3Xd x;
  Eigen::VectorXd r;
  const Box box = edmd::testing::latticePacking(true, 2, 1e-9, x, r);
  const SphereView spheres{x, r};
  const ContactNetwork net = analyseContacts(spheres, box, ContactOptions{.relativeGap = 1e-8});
  LoadTestOptions none;
  none.loads = 0;
  EXPECT_THROW(testJammingUnderLoad(spheres, box, net, none), ConfigError);
  none.protocol = LoadProtocol::Sequential;
  EXPECT_THROW(testJammingUnderLoad(spheres, box, net, none), ConfigError);

  const Eigen::Matrix3Xd noCentre(3, 0);
  const Eigen::VectorXd noRadius(0);
  const SphereView empty{noCentre, noRadius};
  const ContactNetwork emptyNet = analyseContacts(empty, box, {});
  for (LoadProtocol protocol : {LoadProtocol::SingleLp, LoadProtocol::Sequential}) {
    LoadTestOptions options;
    options.protocol = protocol;
    const LoadTestResult result = testJammingUnderLoad(empty, box, emptyNet, options);
    const LoadTestSummary& load = summaryOf(result);
    EXPECT_EQ(load.outcome, JammingVerdict::NotTested);
    EXPECT_FALSE(load.jammed);
    EXPECT_EQ(load.verdict.find("jammed"), std::string::npos) << load.verdict;
  }
  if (jammingTestAvailable()) {
    const JammingTestResult ideal = testCollectiveJamming(empty, box, emptyNet);
    EXPECT_EQ(ideal.outcome, JammingVerdict::NotTested);
    EXPECT_FALSE(ideal.jammed);
    // The jammed FCC crystal: both tests say so, with the verdict type to match.
    const JammingTestResult fcc = testCollectiveJamming(spheres, box, net);
    EXPECT_EQ(fcc.outcome, JammingVerdict::Jammed) << fcc.verdict;
    EXPECT_GT(fcc.lps, 0);
    const SingleLoadResult loaded = testSingleLoads(spheres, box, net);
    EXPECT_EQ(loaded.outcome, JammingVerdict::Jammed) << loaded.verdict;
  }
  EXPECT_EQ(verdictName(JammingVerdict::NotTested), "not tested");
}

TEST(JammingVerdicts, AGasIsUnjammedNotJammed) {
  // Two spheres far apart: every sphere is a rattler.
  Eigen::Matrix3Xd x(3, 2);
  x << 2, 7, 5, 5, 5, 5;
  Eigen::VectorXd r(2);
  r << 1.0, 1.0;
  const Box box = Box::cubic(10.0, Boundary::Periodic);
  const SphereView spheres{x, r};
  const ContactNetwork net = analyseContacts(spheres, box, {});
  EXPECT_EQ(net.backbone, 0);
  const SingleLoadResult load = testSingleLoads(spheres, box, net);
  EXPECT_EQ(load.outcome, JammingVerdict::Unjammed);
  EXPECT_FALSE(load.jammed);
  if (jammingTestAvailable()) {
    EXPECT_EQ(testCollectiveJamming(spheres, box, net).outcome, JammingVerdict::Unjammed);
  }
}

}  // namespace
}  // namespace polydem::jamming
