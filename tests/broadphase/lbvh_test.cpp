// LBVH specifics beyond the property suite: leaf sizes, duplicate Morton keys, refit and the rebuild
// rule, exact periodic images at a box of exactly two cut-offs, steady-state buffers.
#include "broadphase/lbvh.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "broadphase/brute_force.hpp"
#include "core/errors.hpp"
#include "tests/support/scene.hpp"

namespace polydem {
namespace {

using broadphase::Lbvh;
using broadphase::Pair;

std::vector<Pair> pairsOf(const broadphase::BroadPhase& bp, const test::Scene& s) {
  std::vector<Pair> out;
  bp.findPairs(s.spheres(), out);
  broadphase::sortPairs(out);
  return out;
}

TEST(Lbvh, EveryLeafSizeMatchesBruteForce) {
  for (bool periodic : {true, false}) {
    const test::Scene scene = test::makeScene({.count = 2500,
                                               .distribution = "uniform-volume",
                                               .sizeRatio = 100.0,
                                               .packing = 0.3,
                                               .periodic = periodic,
                                               .seed = 8});
    const double skin = 0.2 * scene.minRadius();
    const auto expected = test::pairsFrom("brute", scene, skin);
    ASSERT_GT(expected.size(), 0u);
    for (int leaf : {1, 2, 3, 4, 8, 32}) {
      SCOPED_TRACE(::testing::Message() << "leaf " << leaf << (periodic ? " periodic" : " walls"));
      Lbvh bvh;
      bvh.setLeafSize(leaf);
      bvh.build(scene.spheres(), scene.box, skin);
      bvh.validate(scene.spheres());
      EXPECT_EQ(pairsOf(bvh, scene), expected);
    }
  }
  Lbvh bvh;
  EXPECT_THROW(bvh.setLeafSize(0), ConfigError);
  EXPECT_THROW(bvh.setRebuildFactor(1.0), ConfigError);
  EXPECT_THROW(bvh.setRebuildFactor(std::nan("")), ConfigError);
}

TEST(Lbvh, DuplicateKeysGiveABalancedTree) {
  // Every centre in one Morton cell: Karras' index tie-break must still give a tree of depth ~ log2 M.
  test::Scene s;
  s.box = Box::cubic(100.0, Boundary::Periodic);
  const Index n = 1024;
  s.centre = Eigen::Matrix3Xd::Constant(3, n, 50.0);
  s.radius = Eigen::VectorXd::Constant(n, 1.0);
  for (Index i = 0; i < n; ++i) s.centre(0, i) += 1e-9 * (i % 7);  // below the Morton resolution
  Lbvh bvh;
  bvh.setLeafSize(1);
  bvh.build(s.spheres(), s.box, 0.0);
  bvh.validate(s.spheres());
  EXPECT_LE(bvh.depth(), 11);
  std::vector<Pair> pairs;
  bvh.findPairs(s.spheres(), pairs);
  EXPECT_EQ(pairs.size(), static_cast<std::size_t>(n) * (n - 1) / 2);
}

TEST(Lbvh, RefitMatchesFreshBuildAndRebuildsWhenQualityDecays) {
  test::Scene scene =
      test::makeScene({.count = 3000, .distribution = "bi", .sizeRatio = 10.0, .packing = 0.3, .seed = 5});
  const double skin = 0.3 * scene.minRadius();
  Lbvh bvh;
  bvh.build(scene.spheres(), scene.box, skin);
  EXPECT_EQ(bvh.rebuilds(), 1u);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> small(-0.05, 0.05);
  for (int round = 0; round < 6; ++round) {
    std::vector<Index> moved;
    for (Index i = round; i < scene.spheres().count(); i += 10) {
      for (int k = 0; k < 3; ++k) scene.centre(k, i) += small(rng) * scene.minRadius();
      scene.centre.col(i) = scene.box.wrap(scene.centre.col(i));
      moved.push_back(i);
    }
    bvh.update(scene.spheres(), moved);
    bvh.validate(scene.spheres());
    Lbvh fresh;
    fresh.build(scene.spheres(), scene.box, skin);
    EXPECT_EQ(pairsOf(bvh, scene), pairsOf(fresh, scene)) << "round " << round;
  }
  EXPECT_EQ(bvh.rebuilds(), 1u) << "small moves should only refit: " << bvh.describe();
  EXPECT_GE(bvh.qualityRatio(), 1.0);

  // Scatter every sphere: the refitted boxes overlap wildly, and the rule rebuilds.
  std::uniform_real_distribution<double> anywhere(0.0, 1.0);
  std::vector<Index> all(static_cast<std::size_t>(scene.spheres().count()));
  for (Index i = 0; i < scene.spheres().count(); ++i) {
    all[static_cast<std::size_t>(i)] = i;
    for (int k = 0; k < 3; ++k) scene.centre(k, i) = anywhere(rng) * scene.box.length(k) * 0.999;
  }
  Lbvh refitOnly;
  refitOnly.setRebuildFactor(std::numeric_limits<double>::infinity());
  refitOnly.build(scene.spheres(), scene.box, skin);
  bvh.update(scene.spheres(), all);
  EXPECT_EQ(bvh.rebuilds(), 2u);
  EXPECT_DOUBLE_EQ(bvh.qualityRatio(), 1.0);
  const auto expected = test::pairsFrom("brute", scene, skin);
  EXPECT_EQ(pairsOf(bvh, scene), expected);

  // Never rebuilding stays exact, only slower.
  for (Index i = 0; i < scene.spheres().count(); ++i) {
    for (int k = 0; k < 3; ++k) scene.centre(k, i) = anywhere(rng) * scene.box.length(k) * 0.999;
  }
  refitOnly.update(scene.spheres(), all);
  EXPECT_EQ(refitOnly.rebuilds(), 1u);
  EXPECT_GT(refitOnly.qualityRatio(), 1.5);
  refitOnly.validate(scene.spheres());
  EXPECT_EQ(pairsOf(refitOnly, scene), test::pairsFrom("brute", scene, skin));
}

TEST(Lbvh, FloatNodeBoxesLoseNoPairFarFromTheOrigin) {
  // Node boxes are floats: at coordinates near 1e6 one float step (1/16) is 6 radii, so bounds that
  // were rounded to nearest instead of outward would drop pairs at a gap of exactly the skin.
  const double r = 0.01, skin = 0.002, length = 1.0e6;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (Boundary boundary : {Boundary::Periodic, Boundary::Wall}) {
    // Periodic: pairs across the face at L; walls: every centre inside.
    std::uniform_real_distribution<double> near(length - 3.0, boundary == Boundary::Periodic ? length : length - 1.0);
    test::Scene s;
    s.box = Box::cubic(length, boundary);
    const Index chains = 400;
    s.centre.resize(3, 2 * chains);
    s.radius = Eigen::VectorXd::Constant(2 * chains, r);
    for (Index c = 0; c < chains; ++c) {
      Eigen::Vector3d a(near(rng), near(rng), near(rng)), d(unit(rng), unit(rng), unit(rng));
      d.normalize();
      // Partner at a gap 2% inside the skin or 2% beyond it.
      const Eigen::Vector3d b = a + d * (2.0 * r + skin * (c % 2 == 0 ? 0.98 : 1.02));
      s.centre.col(2 * c) = s.box.wrap(a);
      s.centre.col(2 * c + 1) = s.box.wrap(b);
    }
    const auto expected = test::pairsFrom("brute", s, skin);
    ASSERT_GE(expected.size(), 200u);
    for (int leaf : {1, 4}) {
      Lbvh bvh;
      bvh.setLeafSize(leaf);
      bvh.build(s.spheres(), s.box, skin);
      bvh.validate(s.spheres());
      EXPECT_EQ(pairsOf(bvh, s), expected) << "leaf " << leaf;
    }
  }
}

TEST(Lbvh, PeriodicBoxOfExactlyTwoCutoffsReportsEachPairOnce) {
  // L = 2 (2 r_max + skin): a sphere can be reached through two images of the query at once.
  test::Scene s;
  s.box = Box::cubic(4.0, Boundary::Periodic);
  const Index n = 60;
  s.centre.resize(3, n);
  s.radius = Eigen::VectorXd::Constant(n, 0.5);
  std::mt19937_64 rng(2);
  std::uniform_int_distribution<int> grid(0, 7);
  for (Index i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) s.centre(k, i) = 0.5 * grid(rng);  // many separations of exactly L / 2
  }
  for (double skin : {0.0, 1.0}) {
    for (int leaf : {1, 4}) {
      Lbvh bvh;
      bvh.setLeafSize(leaf);
      bvh.build(s.spheres(), s.box, skin);
      EXPECT_EQ(pairsOf(bvh, s), test::pairsFrom("brute", s, skin)) << "skin " << skin << " leaf " << leaf;
      broadphase::BruteForce brute;
      brute.build(s.spheres(), s.box, skin);
      std::vector<Index> got, expected;
      for (Index i = 0; i < n; ++i) {
        bvh.findNeighbours(s.spheres(), i, skin, got);
        brute.findNeighbours(s.spheres(), i, skin, expected);
        ASSERT_EQ(got, expected) << "particle " << i;
      }
    }
  }
}

TEST(Lbvh, SteadyStateKeepsItsBuffers) {
  test::Scene scene =
      test::makeScene({.count = 4000, .distribution = "uniform-volume", .sizeRatio = 20.0, .packing = 0.3, .seed = 6});
  const double skin = 0.2 * scene.minRadius();
  Lbvh bvh;
  std::vector<Pair> pairs;
  std::vector<Index> neighbours;
  bvh.build(scene.spheres(), scene.box, skin);
  bvh.findPairs(scene.spheres(), pairs);
  pairs.reserve(2 * pairs.size());
  neighbours.reserve(1000);
  const std::size_t bytes = bvh.memoryBytes();
  const Pair* data = pairs.data();
  std::vector<Index> moved = {1, 50, 900, 3999};
  for (int round = 0; round < 5; ++round) {
    for (Index i : moved) scene.centre(0, i) = scene.box.wrap(scene.centre.col(i) + Eigen::Vector3d(1e-3, 0, 0))[0];
    bvh.update(scene.spheres(), moved);
    bvh.findPairs(scene.spheres(), pairs);
    bvh.findNeighbours(scene.spheres(), 7, skin, neighbours);
    bvh.build(scene.spheres(), scene.box, skin);
  }
  EXPECT_EQ(bvh.memoryBytes(), bytes);
  EXPECT_EQ(pairs.data(), data);
  EXPECT_GT(bytes, 0u);
  EXPECT_NE(bvh.describe().find("lbvh"), std::string::npos);
}

}  // namespace
}  // namespace polydem
