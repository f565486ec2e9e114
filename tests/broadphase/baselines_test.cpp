// Backend-specific checks for the baseline broad phases (sweep and prune, CGAL box intersection,
// CGAL regular triangulation). Agreement with brute force on general scenes is the property suite's job.
#include <gtest/gtest.h>

#include <random>

#include "broadphase/brute_force.hpp"
#include "broadphase/registry.hpp"
#include "broadphase/sweep_and_prune.hpp"
#include "polydem/config.hpp"
#include "tests/support/scene.hpp"

#if POLYDEM_WITH_CGAL
#include "broadphase/cgal_box.hpp"
#include "broadphase/delaunay.hpp"
#endif

namespace polydem {
namespace {

using broadphase::Pair;

std::vector<Pair> pairsOf(const broadphase::BroadPhase& bp, const test::Scene& s) {
  std::vector<Pair> out;
  bp.findPairs(s.spheres(), out);
  broadphase::sortPairs(out);
  return out;
}

// Nudge every `stride`-th particle by up to `step` per axis, wrapping periodic axes (walls: clamp).
std::vector<Index> nudge(test::Scene& s, Index first, Index stride, double step, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-step, step);
  std::vector<Index> moved;
  for (Index i = first; i < s.spheres().count(); i += stride) {
    for (int k = 0; k < 3; ++k) {
      double x = s.centre(k, i) + u(rng);
      if (!s.box.periodic(k)) x = std::clamp(x, 0.0, s.box.length(k));
      s.centre(k, i) = x;
    }
    s.centre.col(i) = s.box.wrap(s.centre.col(i));
    moved.push_back(i);
  }
  return moved;
}

TEST(SweepAndPrune, InsertionSortRepairsOrderAfterSmallMoves) {
  for (bool periodic : {true, false}) {
    SCOPED_TRACE(periodic ? "periodic" : "walled");
    test::Scene s = test::makeScene(
        {.count = 3000, .distribution = "uniform-volume", .sizeRatio = 10.0, .packing = 0.3, .periodic = periodic});
    const double skin = 0.2;
    broadphase::SweepAndPrune sap;
    sap.build(s.spheres(), s.box, skin);
    EXPECT_FALSE(sap.lastSortWasInsertion());  // first build: full sort
    sap.validate(s.spheres());
    // Rebuilding unchanged positions reuses the order: nothing to shift.
    sap.build(s.spheres(), s.box, skin);
    EXPECT_TRUE(sap.lastSortWasInsertion());
    EXPECT_EQ(sap.lastSortShifts(), 0u);
    std::mt19937_64 rng(3);
    for (int round = 0; round < 4; ++round) {
      SCOPED_TRACE(::testing::Message() << "round " << round);
      const auto moved = nudge(s, round, 3, 0.05, rng);
      if (round % 2 == 0) {
        sap.update(s.spheres(), moved);
      } else {
        sap.build(s.spheres(), s.box, skin);  // same count: also insertion sort
      }
      EXPECT_TRUE(sap.lastSortWasInsertion());
      EXPECT_GT(sap.lastSortShifts(), 0u);
      EXPECT_LT(sap.lastSortShifts(), 3u * 3000u);  // nearly sorted: far below N^2
      sap.validate(s.spheres());
      EXPECT_EQ(pairsOf(sap, s), test::pairsFrom("brute", s, skin));
    }
  }
}

TEST(SweepAndPrune, ShuffledPositionsFallBackToFullSort) {
  test::Scene s = test::makeScene({.count = 2000, .distribution = "bi", .sizeRatio = 4.0, .packing = 0.3});
  broadphase::SweepAndPrune sap;
  sap.build(s.spheres(), s.box, 0.1);
  // Reverse the particle order: the old order is now maximally wrong.
  s.centre = s.centre.rowwise().reverse().eval();
  s.radius = s.radius.reverse().eval();
  sap.build(s.spheres(), s.box, 0.1);
  EXPECT_FALSE(sap.lastSortWasInsertion());
  sap.validate(s.spheres());
  EXPECT_EQ(pairsOf(sap, s), test::pairsFrom("brute", s, 0.1));
}

TEST(SweepAndPrune, BoxesStraddlingThePeriodicSweepFace) {
  // All particles near the x faces (the sweep axis, as x has the largest spread): pairs exist only
  // through the face, across the ghost boxes.
  test::Scene s;
  s.box = Box(Eigen::Vector3d(30.0, 6.0, 6.0), {Boundary::Periodic, Boundary::Periodic, Boundary::Wall});
  const Index n = 400;
  s.centre.resize(3, n);
  s.radius.resize(n);
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (Index i = 0; i < n; ++i) {
    s.radius[i] = i % 5 == 0 ? 1.2 : 0.15;
    const double x = 1.5 * u(rng);
    s.centre(0, i) = i % 2 ? x : 30.0 - x - 1e-9;
    s.centre(1, i) = 6.0 * u(rng) * 0.999;
    s.centre(2, i) = 6.0 * u(rng);
  }
  s.centre(0, 0) = 0.0;  // lower end exactly on the face after wrapping
  broadphase::SweepAndPrune sap;
  sap.build(s.spheres(), s.box, 0.3);
  EXPECT_EQ(sap.axis(), 0);
  const auto expected = test::pairsFrom("brute", s, 0.3);
  EXPECT_EQ(pairsOf(sap, s), expected);
  broadphase::BruteForce brute;
  brute.build(s.spheres(), s.box, 0.3);
  std::vector<Index> got, want;
  for (Index i = 0; i < n; i += 3) {
    sap.findNeighbours(s.spheres(), i, 0.3, got);
    brute.findNeighbours(s.spheres(), i, 0.3, want);
    ASSERT_EQ(got, want) << "particle " << i;
  }
}

TEST(Baselines, Capabilities) {
  EXPECT_TRUE(broadphase::makeBroadPhase("sap")->capabilities().complete);
  EXPECT_TRUE(broadphase::makeBroadPhase("sap")->capabilities().incremental);
#if POLYDEM_WITH_CGAL
  EXPECT_TRUE(broadphase::makeBroadPhase("cgal-box")->capabilities().complete);
  EXPECT_FALSE(broadphase::makeBroadPhase("cgal-box")->capabilities().incremental);
  EXPECT_TRUE(broadphase::makeBroadPhase("delaunay")->capabilities().complete);
  EXPECT_TRUE(broadphase::makeBroadPhase("delaunay")->capabilities().incremental);
#endif
}

#if POLYDEM_WITH_CGAL

// A few large spheres, each stuffed with small ones deep inside it: most small ones have an empty
// power cell (hidden points), and some coincide exactly
// (m = 1, 2: same centre and radius; m = 0: concentric and smaller).
test::Scene stuffedScene(bool periodic, std::uint64_t seed) {
  test::Scene s;
  s.box = Box::cubic(40.0, periodic ? Boundary::Periodic : Boundary::Wall);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 40.0), v(-1.0, 1.0);
  const Index bigs = 30, perBig = 20;
  const Index n = bigs * (1 + perBig);
  s.centre.resize(3, n);
  s.radius.resize(n);
  Index k = 0;
  for (Index b = 0; b < bigs; ++b) {
    Eigen::Vector3d c(u(rng), u(rng), u(rng));
    if (b < 4) c[0] = 0.5;  // near a face: images of hidden points
    s.centre.col(k) = c;
    s.radius[k++] = 4.0;
    for (Index m = 0; m < perBig; ++m) {
      const Eigen::Vector3d d = m < 3 ? Eigen::Vector3d::Zero() : Eigen::Vector3d(v(rng), v(rng), v(rng));
      s.centre.col(k) = periodic ? s.box.wrap(c + 2.0 * d) : (c + 2.0 * d).cwiseMax(0.0).cwiseMin(40.0);
      s.radius[k++] = m % 3 == 0 ? 0.05 : 0.3;
    }
  }
  return s;
}

TEST(CgalBox, PeriodicImagesNearFacesOnly) {
  test::Scene s;
  s.box = Box(Eigen::Vector3d(10.0, 12.0, 9.0), {Boundary::Periodic, Boundary::Periodic, Boundary::Periodic});
  s.centre.resize(3, 9);
  s.radius = Eigen::VectorXd::Constant(9, 0.5);
  for (int c = 0; c < 8; ++c) s.centre.col(c) << ((c & 1) ? 9.8 : 0.2), ((c & 2) ? 11.8 : 0.2), ((c & 4) ? 8.8 : 0.2);
  s.centre.col(8) << 5.0, 6.0, 4.5;  // far from every face: no image
  broadphase::CgalBox cgal;
  cgal.build(s.spheres(), s.box, 0.0);
  EXPECT_EQ(cgal.imageCount(), 8 * 7);  // every corner sphere: 7 images
  const auto pairs = pairsOf(cgal, s);
  EXPECT_EQ(pairs.size(), 28u);
  EXPECT_EQ(pairs, test::pairsFrom("brute", s, 0.0));

  s.box = Box::cubic(12.0, Boundary::Wall);
  cgal.build(s.spheres(), s.box, 0.0);
  EXPECT_EQ(cgal.imageCount(), 0);
  EXPECT_TRUE(pairsOf(cgal, s).empty());
}

TEST(CgalBox, MixedBoundariesAndNeighbourQueries) {
  test::Scene s = test::makeScene({.count = 2000, .distribution = "uniform-volume", .sizeRatio = 30.0, .packing = 0.3});
  s.box = Box(s.box.lengths(), {Boundary::Wall, Boundary::Periodic, Boundary::Periodic});
  broadphase::CgalBox cgal;
  const double skin = 0.5;
  cgal.build(s.spheres(), s.box, skin);
  EXPECT_GT(cgal.imageCount(), 0);
  EXPECT_EQ(pairsOf(cgal, s), test::pairsFrom("brute", s, skin));
  broadphase::BruteForce brute;
  brute.build(s.spheres(), s.box, skin);
  std::vector<Index> got, want;
  for (Index i = 0; i < 2000; i += 11) {
    cgal.findNeighbours(s.spheres(), i, 0.25, got);
    brute.findNeighbours(s.spheres(), i, 0.25, want);
    ASSERT_EQ(got, want) << "particle " << i;
  }
}

TEST(Delaunay, HiddenPointsOfHeavilyOverlappingSpheres) {
  for (bool periodic : {true, false}) {
    for (std::uint64_t seed : {1u, 2u}) {
      SCOPED_TRACE(::testing::Message() << (periodic ? "periodic" : "walled") << " seed " << seed);
      const test::Scene s = stuffedScene(periodic, seed);
      for (double skin : {0.0, 0.05, 0.3}) {
        broadphase::Delaunay d;
        d.build(s.spheres(), s.box, skin);
        EXPECT_GT(d.stats().hidden, 100);  // most stuffed spheres are hidden
        EXPECT_GE(d.stats().layers, 3);    // coincident duplicates need a third layer
        EXPECT_TRUE(d.validate());
        EXPECT_EQ(pairsOf(d, s), test::pairsFrom("brute", s, skin)) << "skin " << skin << ": " << d.describe();
      }
    }
  }
}

TEST(Delaunay, ExplicitPeriodicImagesAreDescribed) {
  const test::Scene s = test::makeScene({.count = 500, .distribution = "mono", .packing = 0.2});
  broadphase::Delaunay d;
  d.build(s.spheres(), s.box, 0.1);
  EXPECT_GT(d.stats().images, 0);
  EXPECT_NE(d.describe().find("images"), std::string::npos) << d.describe();
  EXPECT_EQ(d.stats().hidden, 0);  // equal weights: nothing hidden
}

TEST(Delaunay, MoveUpdateMatchesBruteForceAndRebuild) {
  for (bool periodic : {true, false}) {
    SCOPED_TRACE(periodic ? "periodic" : "walled");
    test::Scene s = test::makeScene({.count = 2000, .distribution = "mono", .packing = 0.3, .periodic = periodic});
    const double skin = 0.3;
    broadphase::Delaunay d;
    d.build(s.spheres(), s.box, skin);
    ASSERT_EQ(d.stats().layers, 1);
    std::mt19937_64 rng(12);
    for (int round = 0; round < 5; ++round) {
      SCOPED_TRACE(::testing::Message() << "round " << round);
      // Tiny steps mostly keep the combinatorics (relocation in place), large ones need CGAL move().
      const auto moved = nudge(s, round, 10, round % 2 ? 0.4 : 0.01, rng);
      d.update(s.spheres(), moved);
      EXPECT_TRUE(d.validate());
      EXPECT_EQ(pairsOf(d, s), test::pairsFrom("brute", s, skin));
    }
    EXPECT_EQ(d.stats().moves, 5u) << d.describe();
    EXPECT_EQ(d.stats().rebuilds, 0u);
    EXPECT_GT(d.stats().inPlace, 0u) << d.describe();
    EXPECT_GT(d.stats().cgalMoves, 0u) << d.describe();
    // Moving most particles rebuilds instead.
    const auto moved = nudge(s, 0, 1, 0.1, rng);
    d.update(s.spheres(), moved);
    EXPECT_EQ(d.stats().rebuilds, 1u);
    EXPECT_EQ(pairsOf(d, s), test::pairsFrom("brute", s, skin));
  }
}

TEST(Delaunay, UpdateWithHiddenPointsRebuilds) {
  test::Scene s = stuffedScene(true, 3);
  broadphase::Delaunay d;
  d.build(s.spheres(), s.box, 0.1);
  std::mt19937_64 rng(4);
  const auto moved = nudge(s, 0, 50, 0.2, rng);
  d.update(s.spheres(), moved);
  EXPECT_EQ(d.stats().rebuilds, 1u);
  EXPECT_EQ(pairsOf(d, s), test::pairsFrom("brute", s, 0.1));
}

#endif  // POLYDEM_WITH_CGAL

}  // namespace
}  // namespace polydem
