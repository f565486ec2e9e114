// The pressure-leak test (jamming/pressure_leak.hpp; Donev 2006 thesis, §9.3.1): FCC just below close packing keeps
// its pressure and its spheres stay in their cages; simple cubic at the same gap is not jammed (its rows
// slide, Donev 2006, Table 4.1) and its spheres drift away from the lattice.
#include "jamming/pressure_leak.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/errors.hpp"
#include "tests/support/lattices.hpp"

namespace polydem::jamming {
namespace {

Box lattice(bool fcc, int m, double gap, Eigen::Matrix3Xd& x, Eigen::VectorXd& r) {
  return edmd::testing::latticePacking(fcc, m, gap, x, r);
}

TEST(PressureLeak, FccKeepsItsPressureSimpleCubicLeaks) {
  LeakTestOptions options;
  options.collisionsPerParticle = 4000;
  options.blocks = 8;
  // 256 spheres and 1.3e5 collisions per block: block pressures scatter by a few 1e-3, so the
  // tolerance here is wider than the default for 10^4-sphere packings.
  options.pressureTolerance = 2e-2;
  for (bool fcc : {true, false}) {
    SCOPED_TRACE(fcc ? "fcc" : "sc");
    Eigen::Matrix3Xd x;
    Eigen::VectorXd r;
    const Box box = lattice(fcc, fcc ? 4 : 6, 1e-9, x, r);
    const LeakTestResult result = testPressureLeak(x, r, box, {}, options);
    ASSERT_EQ(result.blocks.size(), 8u);
    EXPECT_EQ(result.leaks, !fcc) << result.verdict;
    const double first = result.blocks.front().pressure;
    if (fcc) {
      // Gap 1e-9 of the diameter: p ~ 1e9, and every sphere stays within ~the gap of its site.
      EXPECT_GT(first, 1e8);
      EXPECT_LT(std::abs(result.pressureChange), 2e-2) << result.verdict;
      EXPECT_LT(result.driftRatio, 1.5) << result.verdict;
      for (const LeakBlock& b : result.blocks) EXPECT_LT(b.maxDisplacement, 1e-8);
      EXPECT_NE(result.verdict.find("no pressure leak, no drift (jammed)"), std::string::npos) << result.verdict;
    } else {
      // The rows slide: within 4000 collisions per particle the spheres wander hundreds of gaps from
      // their sites, and keep going (the pressure itself falls only slowly at this point).
      EXPECT_GT(result.driftRatio, 1.5) << result.verdict;
      EXPECT_GT(result.blocks.back().maxDisplacement, 1e-7);
      EXPECT_NE(result.verdict.find("not jammed"), std::string::npos) << result.verdict;
    }
    EXPECT_GE(result.counts.collisions, static_cast<std::int64_t>(0.99 * 4000 * r.size()));
  }
}

TEST(PressureLeak, RattlersAreNotWatchedAndBadOptionsAreRefused) {
  Eigen::Matrix3Xd x;
  Eigen::VectorXd r;
  const Box box = lattice(true, 3, 1e-9, x, r);
  LeakTestOptions options;
  options.collisionsPerParticle = 200;
  options.blocks = 4;
  options.pressureTolerance = 5e-2;
  // All but sphere 0 flagged: only sphere 0 is watched, and relative to the watched spheres' own mean
  // translation it does not move, so the displacements stay zero.
  std::vector<char> allButOne(static_cast<std::size_t>(r.size()), 1);
  allButOne[0] = 0;
  const LeakTestResult one = testPressureLeak(x, r, box, allButOne, options);
  ASSERT_EQ(one.blocks.size(), 4u);
  for (const LeakBlock& b : one.blocks) {
    EXPECT_EQ(b.meanDisplacement, 0.0);
    EXPECT_EQ(b.maxSphere, -1);
  }
  // Every sphere flagged (issue 15): nothing jammed to watch, so no verdict, and no dynamics run.
  const LeakTestResult none = testPressureLeak(x, r, box, std::vector<char>(r.size(), 1), options);
  EXPECT_EQ(none.outcome, JammingVerdict::NotTested);
  EXPECT_FALSE(none.leaks);
  EXPECT_TRUE(none.blocks.empty());
  EXPECT_EQ(none.verdict.find("(jammed)"), std::string::npos) << none.verdict;
  EXPECT_THROW(testPressureLeak(x, r, box, std::vector<char>(3, 0), options), ConfigError);
  LeakTestOptions bad = options;
  bad.blocks = 2;
  EXPECT_THROW(testPressureLeak(x, r, box, {}, bad), ConfigError);
  bad = options;
  bad.collisionsPerParticle = 0.0;
  EXPECT_THROW(testPressureLeak(x, r, box, {}, bad), ConfigError);
  bad = options;
  bad.driftFactor = 1.0;
  EXPECT_THROW(testPressureLeak(x, r, box, {}, bad), ConfigError);
}

TEST(PressureLeak, NoSpheresOrOneSphereIsNotTested) {
  // Issue 15: no collisions means no pressure; the test says so instead of printing nan or "jammed".
  LeakTestOptions options;
  options.collisionsPerParticle = 100;
  options.blocks = 4;
  const Box box = Box::cubic(10.0, Boundary::Periodic);
  const LeakTestResult empty = testPressureLeak(Eigen::Matrix3Xd(3, 0), Eigen::VectorXd(0), box, {}, options);
  EXPECT_EQ(empty.outcome, JammingVerdict::NotTested);
  EXPECT_NE(empty.verdict.find("not tested"), std::string::npos);
  Eigen::Matrix3Xd x(3, 1);
  x << 5, 5, 5;
  const LeakTestResult single = testPressureLeak(x, Eigen::VectorXd::Constant(1, 1.0), box, {}, options);
  EXPECT_EQ(single.outcome, JammingVerdict::NotTested);
  EXPECT_FALSE(single.leaks);
  EXPECT_EQ(single.counts.collisions, 0);
  // A jammed FCC crystal has a verdict, and the verdict type says which.
  Eigen::Matrix3Xd fx;
  Eigen::VectorXd fr;
  const Box fcc = lattice(true, 3, 1e-9, fx, fr);
  options.pressureTolerance = 5e-2;
  const LeakTestResult jammed = testPressureLeak(fx, fr, fcc, {}, options);
  EXPECT_EQ(jammed.outcome, JammingVerdict::Jammed) << jammed.verdict;
}

TEST(PressureLeak, WithoutASphereTheLastTakesItsNumber) {
  // testPressureLeakWithout(k) is the test of the packing with sphere k replaced by the last one (the
  // renumbering `analyze --leak-test --remove K` prints), rattler flags moved with it.
  Eigen::Matrix3Xd x;
  Eigen::VectorXd r;
  const Box box = lattice(true, 3, 1e-9, x, r);
  LeakTestOptions options;
  options.collisionsPerParticle = 100;
  options.blocks = 4;
  const Index n = static_cast<Index>(r.size()), k = 5;
  std::vector<char> rattler(static_cast<std::size_t>(n), 0);
  rattler[static_cast<std::size_t>(n - 1)] = 1;
  Eigen::Matrix3Xd y = x;
  Eigen::VectorXd s = r;
  y.col(k) = x.col(n - 1);
  s[k] = r[n - 1];
  y.conservativeResize(3, n - 1);
  s.conservativeResize(n - 1);
  std::vector<char> moved(rattler.begin(), rattler.end() - 1);
  moved[static_cast<std::size_t>(k)] = 1;
  const LeakTestResult by = testPressureLeakWithout(x, r, box, rattler, k, options);
  const LeakTestResult direct = testPressureLeak(y, s, box, moved, options);
  ASSERT_EQ(by.blocks.size(), direct.blocks.size());
  for (std::size_t b = 0; b < by.blocks.size(); ++b) {
    EXPECT_EQ(by.blocks[b].pressure, direct.blocks[b].pressure);
    EXPECT_EQ(by.blocks[b].maxDisplacement, direct.blocks[b].maxDisplacement);
    EXPECT_EQ(by.blocks[b].maxSphere, direct.blocks[b].maxSphere);
  }
  EXPECT_EQ(by.counts.collisions, direct.counts.collisions);
  // The hole unjams the crystal: its pressure is not that of the intact one.
  const LeakTestResult intact = testPressureLeakWithout(x, r, box, rattler, -1, options);
  EXPECT_NE(intact.blocks.front().pressure, by.blocks.front().pressure);
  EXPECT_THROW(testPressureLeakWithout(x, r, box, rattler, n, options), ConfigError);
  EXPECT_THROW(testPressureLeakWithout(x, r, box, std::vector<char>(3, 0), k, options), ConfigError);
}

}  // namespace
}  // namespace polydem::jamming
