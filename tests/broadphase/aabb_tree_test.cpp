// Dynamic AABB tree specifics beyond the property suite: incremental update() against a fresh build,
// fat boxes (moves inside them cost nothing), AVL balance and the node pool under long move sequences.
#include "broadphase/aabb_tree.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "broadphase/brute_force.hpp"
#include "broadphase/registry.hpp"
#include "tests/support/scene.hpp"

namespace polydem {
namespace {

using broadphase::AabbTree;
using broadphase::Pair;

std::vector<Pair> pairsOf(const broadphase::BroadPhase& bp, const test::Scene& s) {
  std::vector<Pair> out;
  bp.findPairs(s.spheres(), out);
  broadphase::sortPairs(out);
  return out;
}

TEST(AabbTree, IsIncremental) {
  EXPECT_TRUE(broadphase::makeBroadPhase("aabb-tree")->capabilities().incremental);
  EXPECT_TRUE(broadphase::makeBroadPhase("aabb-tree")->capabilities().complete);
}

TEST(AabbTree, UpdateOfAMovedSubsetMatchesAFreshBuild) {
  for (bool periodic : {true, false}) {
    test::Scene scene = test::makeScene({.count = 3000,
                                         .distribution = "uniform-volume",
                                         .sizeRatio = 50.0,
                                         .packing = 0.3,
                                         .periodic = periodic,
                                         .seed = 12});
    const double skin = 0.4 * scene.minRadius();
    AabbTree tree;
    tree.build(scene.spheres(), scene.box, skin);
    tree.validate(scene.spheres());
    const int builtHeight = tree.height();
    std::mt19937_64 rng(21);
    std::uniform_real_distribution<double> step(-1.0, 1.0);
    for (int round = 0; round < 8; ++round) {
      // 10% of the spheres, displacements up to 2 skins: some stay in their fat box, some leave it.
      std::vector<Index> moved;
      for (Index i = round; i < scene.spheres().count(); i += 10) {
        for (int k = 0; k < 3; ++k) {
          double x = scene.centre(k, i) + 2.0 * skin * step(rng);
          if (!periodic) x = std::clamp(x, 0.0, scene.box.length(k));
          scene.centre(k, i) = x;
        }
        scene.centre.col(i) = scene.box.wrap(scene.centre.col(i));
        moved.push_back(i);
      }
      tree.update(scene.spheres(), moved);
      SCOPED_TRACE(::testing::Message() << (periodic ? "periodic" : "walls") << " round " << round << ": "
                                        << tree.describe());
      tree.validate(scene.spheres());
      AabbTree fresh;
      fresh.build(scene.spheres(), scene.box, skin);
      EXPECT_EQ(pairsOf(tree, scene), pairsOf(fresh, scene));
    }
    EXPECT_EQ(pairsOf(tree, scene), test::pairsFrom("brute", scene, skin));
    EXPECT_GT(tree.reinsertions(), 0u);
    EXPECT_LT(tree.reinsertions(), 8u * 300u);  // moves inside the fat box are free
    EXPECT_GT(tree.rotations(), 0u);
    EXPECT_LE(tree.height(), builtHeight + 3);
  }
}

TEST(AabbTree, MovesInsideTheFatBoxAreFree) {
  test::Scene scene =
      test::makeScene({.count = 500, .distribution = "bi", .sizeRatio = 4.0, .packing = 0.3, .seed = 2});
  const double skin = 0.5 * scene.minRadius();
  AabbTree tree;
  tree.build(scene.spheres(), scene.box, skin);
  std::vector<Index> moved;
  for (Index i = 0; i < scene.spheres().count(); i += 3) {
    scene.centre(1, i) = std::min(scene.centre(1, i) + 0.4 * skin, scene.box.length(1) * 0.9999);
    moved.push_back(i);
  }
  tree.update(scene.spheres(), moved);
  tree.validate(scene.spheres());
  EXPECT_EQ(tree.reinsertions(), 0u);
  EXPECT_EQ(pairsOf(tree, scene), test::pairsFrom("brute", scene, skin));
}

TEST(AabbTree, StaysBalancedAndReusesItsNodesOverLongMoveSequences) {
  // Every sphere moves far, repeatedly, with wrap-around: the worst case for an incremental tree.
  test::Scene scene =
      test::makeScene({.count = 2000, .distribution = "uniform-volume", .sizeRatio = 10.0, .packing = 0.2, .seed = 4});
  for (double skin : {0.0, 0.3 * scene.minRadius()}) {
    AabbTree tree;
    tree.build(scene.spheres(), scene.box, skin);
    std::size_t bytes = 0;  // after the first round: query scratch is sized on first use
    std::mt19937_64 rng(8);
    std::uniform_real_distribution<double> jump(-0.2, 0.2);
    std::vector<Index> moved;
    for (Index i = 0; i < scene.spheres().count(); ++i) moved.push_back(i);
    for (int round = 0; round < 10; ++round) {
      for (Index i : moved) {
        for (int k = 0; k < 3; ++k) scene.centre(k, i) += jump(rng) * scene.box.length(k);
        scene.centre.col(i) = scene.box.wrap(scene.centre.col(i));
      }
      tree.update(scene.spheres(), moved);
      tree.validate(scene.spheres());  // includes the AVL balance of every node
      std::vector<Pair> pairs;
      tree.findPairs(scene.spheres(), pairs);
      if (round == 0) bytes = tree.memoryBytes();
    }
    // AVL height bound: h < 1.4405 log2(N + 2).
    EXPECT_LT(tree.height(), 1.4405 * std::log2(scene.spheres().count() + 2.0));
    EXPECT_EQ(tree.memoryBytes(), bytes) << "the node pool should be reused";
    EXPECT_EQ(pairsOf(tree, scene), test::pairsFrom("brute", scene, skin));
  }
}

TEST(AabbTree, NeighboursAfterUpdatesMatchBruteForce) {
  test::Scene scene =
      test::makeScene({.count = 1200, .distribution = "uniform-volume", .sizeRatio = 100.0, .packing = 0.3, .seed = 9});
  const double skin = 0.5 * scene.minRadius();
  AabbTree tree;
  tree.build(scene.spheres(), scene.box, skin);
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> step(-1.0, 1.0);
  std::vector<Index> moved;
  for (Index i = 0; i < scene.spheres().count(); i += 4) {
    for (int k = 0; k < 3; ++k) scene.centre(k, i) += skin * step(rng);
    scene.centre.col(i) = scene.box.wrap(scene.centre.col(i));
    moved.push_back(i);
  }
  tree.update(scene.spheres(), moved);
  broadphase::BruteForce brute;
  brute.build(scene.spheres(), scene.box, skin);
  std::vector<Index> got, expected;
  for (Index i = 0; i < scene.spheres().count(); i += 3) {
    for (double reach : {0.0, skin}) {
      tree.findNeighbours(scene.spheres(), i, reach, got);
      brute.findNeighbours(scene.spheres(), i, reach, expected);
      ASSERT_EQ(got, expected) << "particle " << i << " reach " << reach;
    }
  }
}

}  // namespace
}  // namespace polydem
