#include "broadphase/linked_cell.hpp"

#include <gtest/gtest.h>

#include "tests/support/scene.hpp"

namespace polydem::broadphase {
namespace {

TEST(LinkedCell, CellsHoldTheCutoffAndDivideTheBox) {
  const test::Scene s = test::makeScene({.count = 5000, .distribution = "mono", .packing = 0.4, .seed = 1});
  LinkedCell lc;
  lc.build(s.spheres(), s.box, 0.2);
  for (int k = 0; k < 3; ++k) {
    EXPECT_GE(lc.cellSize()[k], 2.0 * 1.0 + 0.2);
    EXPECT_NEAR(lc.cellSize()[k] * lc.cellsPerAxis()[k], s.box.length(k), 1e-12);
    // Largest whole number of cells: one more would be narrower than the cutoff.
    EXPECT_LT(s.box.length(k) / (lc.cellsPerAxis()[k] + 1), 2.2);
  }
  lc.validate(s.spheres());
}

TEST(LinkedCell, CellCountIsCappedForDiluteSystems) {
  test::Scene s;
  s.box = Box::cubic(1000.0, Boundary::Wall);
  s.centre = Eigen::Matrix3Xd::Constant(3, 10, 500.0);
  s.radius = Eigen::VectorXd::Constant(10, 0.5);
  LinkedCell lc;
  lc.build(s.spheres(), s.box, 0.0);
  const auto& c = lc.cellsPerAxis();
  EXPECT_LE(static_cast<double>(c[0]) * c[1] * c[2], 64.0);
  EXPECT_LT(lc.memoryBytes(), 4096u);
}

TEST(LinkedCell, TwoCellPeriodicAxisUsesDeduplicatedStencil) {
  // Box 4.5 wide, cutoff 2.1: two cells along x, whose forward and backward neighbours coincide.
  test::Scene s;
  s.box = Box::cubic(4.5, Boundary::Periodic);
  s.centre.resize(3, 2);
  s.centre.col(0) << 0.5, 2.0, 2.0;
  s.centre.col(1) << 3.0, 2.0, 2.0;  // 2.5 apart directly, 2.0 through the image
  s.radius = Eigen::VectorXd::Constant(2, 1.0);
  LinkedCell lc;
  lc.build(s.spheres(), s.box, 0.1);
  EXPECT_EQ(lc.cellsPerAxis(), (std::array<int, 3>{2, 2, 2}));
  std::vector<Pair> pairs;
  lc.findPairs(s.spheres(), pairs);
  EXPECT_EQ(pairs, (std::vector<Pair>{{0, 1}}));  // exactly once
}

TEST(LinkedCell, CountersMatchCellStructure) {
  const test::Scene s = test::makeScene({.count = 2000, .distribution = "mono", .packing = 0.3, .seed = 2});
  LinkedCell lc;
  lc.setCounting(true);
  lc.build(s.spheres(), s.box, 0.0);
  std::vector<Pair> pairs;
  lc.findPairs(s.spheres(), pairs);
  EXPECT_GE(lc.counters().pairTests, pairs.size());
  const auto& c = lc.cellsPerAxis();
  EXPECT_GE(lc.counters().cellAccesses, static_cast<std::uint64_t>(c[0]) * c[1] * c[2]);
}

TEST(LinkedCell, IncrementalUpdateKeepsStorageValid) {
  test::Scene s = test::makeScene({.count = 500, .distribution = "mono", .packing = 0.2, .seed = 3});
  LinkedCell lc;
  lc.build(s.spheres(), s.box, 0.1);
  std::vector<Index> moved = {3, 7, 11};
  for (Index i : moved) s.centre(0, i) = s.box.wrap(s.centre.col(i) + Eigen::Vector3d(1e-3, 0, 0))[0];
  lc.update(s.spheres(), moved);
  lc.validate(s.spheres());
  for (Index i : moved) s.centre(0, i) = s.box.wrap(s.centre.col(i) + Eigen::Vector3d(3.0, 0, 0))[0];
  lc.update(s.spheres(), moved);  // crosses cells: full re-sort
  lc.validate(s.spheres());
}

}  // namespace
}  // namespace polydem::broadphase

namespace polydem::broadphase {
namespace {

TEST(LinkedCell, ThreadedBuildGivesTheSerialIndex) {
  // The per-part counting sort must place every sphere in the slot the serial sort gives it: same
  // validate()d storage, same pairs in the same order, for several thread counts and rebuilds.
  const test::Scene s =
      test::makeScene({.count = 10000, .distribution = "bi", .sizeRatio = 3.0, .packing = 0.4, .seed = 21});
  LinkedCell serial;
  serial.build(s.spheres(), s.box, 0.1);
  std::vector<Pair> expected;
  serial.findPairs(s.spheres(), expected);
  for (int threads : {2, 4, 7}) {
    SCOPED_TRACE(threads);
    LinkedCell lc;
    lc.setThreads(threads);
    for (int round = 0; round < 2; ++round) {
      lc.build(s.spheres(), s.box, 0.1);
      EXPECT_NO_THROW(lc.validate(s.spheres()));
      std::vector<Pair> got;
      lc.findPairs(s.spheres(), got);
      EXPECT_EQ(got, expected);
    }
  }
}

}  // namespace
}  // namespace polydem::broadphase
