// The property suite every broad-phase backend runs through: identical pair sets to brute force on
// random and adversarial inputs. A new backend joins by being listed in broadphase/registry.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "broadphase/brute_force.hpp"
#include "broadphase/pair_chunks.hpp"
#include "broadphase/registry.hpp"
#include "core/errors.hpp"
#include "polydem/config.hpp"
#include "tests/support/scene.hpp"

namespace polydem {
namespace {

using broadphase::Pair;

std::vector<std::string> allBackends() {
  std::vector<std::string> names = broadphase::backendNames();
  names.push_back("auto");
  return names;
}

std::vector<Pair> run(std::string_view backend, const test::Scene& s, double skin) {
  return test::pairsFrom(backend, s, skin);
}

struct RandomCase {
  std::string distribution;
  double sizeRatio;
  double packing;
  bool periodic;
  Index count;
};

std::vector<RandomCase> randomCases() {
  return {
      {"mono", 1.0, 0.55, true, 2000},
      {"mono", 1.0, 0.05, false, 2000},
      {"mono", 1.0, 0.30, false, 1500},
      {"bi", 10.0, 0.40, true, 2000},
      {"bi", 10.0, 0.40, false, 2000},
      {"uniform-radius", 50.0, 0.3, true, 2000},
      {"uniform-volume", 10.0, 0.50, true, 3000},
      {"uniform-volume", 100.0, 0.30, true, 3000},
      {"uniform-volume", 100.0, 0.30, false, 3000},
      {"uniform-volume", 1000.0, 0.20, false, 3000},
      {"uniform-volume", 1000.0, 0.05, true, 2000},
      {"power-law", 30.0, 0.35, true, 2000},
      {"log-normal", 20.0, 0.30, true, 2000},
  };
}

class BackendProperty : public ::testing::TestWithParam<std::string> {};

TEST_P(BackendProperty, RandomScenesMatchBruteForce) {
  const std::string backend = GetParam();
  for (const RandomCase& c : randomCases()) {
    for (std::uint64_t seed : {1u, 2u}) {
      const test::Scene scene = test::makeScene({.count = c.count,
                                                 .distribution = c.distribution,
                                                 .sizeRatio = c.sizeRatio,
                                                 .packing = c.packing,
                                                 .periodic = c.periodic,
                                                 .seed = seed});
      for (double skinFactor : {0.0, 0.3}) {
        SCOPED_TRACE(::testing::Message()
                     << c.distribution << " omega " << c.sizeRatio << " nu " << c.packing
                     << (c.periodic ? " periodic" : " walled") << " seed " << seed << " skin " << skinFactor);
        const double skin = skinFactor * scene.minRadius();
        const auto expected = run("brute", scene, skin);
        if (c.packing > 0.1) {
          ASSERT_GT(expected.size(), 0u) << "scene should have contacts";
        }
        EXPECT_EQ(run(backend, scene, skin), expected);
      }
    }
  }
}

TEST_P(BackendProperty, EmptySingleAndTwoParticles) {
  const std::string backend = GetParam();
  for (bool periodic : {true, false}) {
    test::Scene s;
    s.box = Box::cubic(10.0, periodic ? Boundary::Periodic : Boundary::Wall);
    s.centre.resize(3, 0);
    s.radius.resize(0);
    EXPECT_TRUE(run(backend, s, 0.1).empty());

    s.centre = Eigen::Matrix3Xd::Constant(3, 1, 5.0);
    s.radius = Eigen::VectorXd::Constant(1, 1.0);
    EXPECT_TRUE(run(backend, s, 0.1).empty());

    s.centre.resize(3, 2);
    s.centre.col(0) << 1.0, 1.0, 1.0;
    s.centre.col(1) << 2.5, 1.0, 1.0;
    s.radius = Eigen::VectorXd::Constant(2, 0.75);  // touching exactly: gap 0
    EXPECT_EQ(run(backend, s, 0.0), (std::vector<Pair>{{0, 1}}));
    s.radius = Eigen::VectorXd::Constant(2, 0.5);  // gap 0.5 > skin
    EXPECT_TRUE(run(backend, s, 0.25).empty());
    EXPECT_EQ(run(backend, s, 0.5), (std::vector<Pair>{{0, 1}}));  // gap == skin counts
  }
}

TEST_P(BackendProperty, CoincidentCentresAndAllInOneCell) {
  const std::string backend = GetParam();
  test::Scene s;
  s.box = Box::cubic(40.0, Boundary::Periodic);
  const Index n = 300;
  s.centre.resize(3, n);
  s.radius.resize(n);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(20.0, 21.0);
  for (Index i = 0; i < n; ++i) {
    s.radius[i] = i % 3 == 0 ? 0.01 : 0.4;
    for (int k = 0; k < 3; ++k) s.centre(k, i) = i < 10 ? 20.5 : u(rng);  // ten coincident centres
  }
  EXPECT_EQ(run(backend, s, 0.0), run("brute", s, 0.0));
  EXPECT_EQ(run(backend, s, 0.05), run("brute", s, 0.05));
}

// Spheres on a lattice whose spacing equals the contact distance, so centres sit exactly on cell
// faces of any grid whose cell edge divides the spacing, and many gaps are exactly 0 or exactly the skin.
TEST_P(BackendProperty, LatticeOnCellFacesWithExactTouching) {
  const std::string backend = GetParam();
  for (bool periodic : {true, false}) {
    for (double spacing : {1.0, 2.0, 0.5}) {
      test::Scene s;
      const int m = 8;
      s.box = Box::cubic(m * spacing, periodic ? Boundary::Periodic : Boundary::Wall);
      s.centre.resize(3, m * m * m);
      s.radius.resize(m * m * m);
      Index n = 0;
      for (int z = 0; z < m; ++z)
        for (int y = 0; y < m; ++y)
          for (int x = 0; x < m; ++x) {
            s.centre.col(n) << x * spacing, y * spacing, z * spacing;
            s.radius[n] = ((x + y + z) % 4 == 0) ? 0.25 * spacing : 0.5 * spacing;
            ++n;
          }
      for (double skin : {0.0, 0.25 * spacing, 0.5 * spacing}) {
        SCOPED_TRACE(::testing::Message() << "spacing " << spacing << " skin " << skin << " periodic " << periodic);
        const auto expected = run("brute", s, skin);
        ASSERT_GT(expected.size(), 0u);
        EXPECT_EQ(run(backend, s, skin), expected);
      }
    }
  }
}

TEST_P(BackendProperty, PeriodicImagesAcrossEveryFace) {
  const std::string backend = GetParam();
  test::Scene s;
  s.box = Box(Eigen::Vector3d(10.0, 12.0, 9.0), {Boundary::Periodic, Boundary::Periodic, Boundary::Periodic});
  s.centre.resize(3, 8);
  s.radius = Eigen::VectorXd::Constant(8, 0.5);
  // Corner particles: each touches the others only through periodic images.
  Index n = 0;
  for (int c = 0; c < 8; ++c) {
    s.centre.col(n++) << ((c & 1) ? 9.8 : 0.2), ((c & 2) ? 11.8 : 0.2), ((c & 4) ? 8.8 : 0.2);
  }
  const auto expected = run("brute", s, 0.0);
  EXPECT_EQ(expected.size(), 28u);  // all 8 corners are mutually within reach through images
  EXPECT_EQ(run(backend, s, 0.0), expected);
}

TEST_P(BackendProperty, MixedBoundariesAndThinBoxes) {
  const std::string backend = GetParam();
  // Boxes with one or two cells per axis on some axes (few cells than the stencil).
  for (const Eigen::Vector3d& lengths :
       {Eigen::Vector3d(4.5, 30.0, 30.0), Eigen::Vector3d(5.0, 5.0, 40.0), Eigen::Vector3d(2.0, 2.0, 2.0)}) {
    for (const auto boundaries : {std::array{Boundary::Periodic, Boundary::Wall, Boundary::Periodic},
                                  std::array{Boundary::Wall, Boundary::Wall, Boundary::Wall}}) {
      if (lengths.minCoeff() < 4.4 && boundaries[0] == Boundary::Periodic) continue;
      test::Scene s;
      s.box = Box(lengths, boundaries);
      const Index n = 400;
      s.centre.resize(3, n);
      s.radius.resize(n);
      std::mt19937_64 rng(11);
      for (Index i = 0; i < n; ++i) {
        s.radius[i] = (i % 7 == 0) ? 1.0 : 0.2;
        for (int k = 0; k < 3; ++k) {
          s.centre(k, i) = std::uniform_real_distribution<double>(0.0, lengths[k])(rng);
        }
      }
      SCOPED_TRACE(::testing::Message() << "box " << s.box.describe());
      EXPECT_EQ(run(backend, s, 0.1), run("brute", s, 0.1));
    }
  }
}

TEST_P(BackendProperty, NeighbourQueriesMatchBruteForce) {
  const std::string backend = GetParam();
  const test::Scene scene =
      test::makeScene({.count = 1500, .distribution = "uniform-volume", .sizeRatio = 20.0, .packing = 0.3, .seed = 3});
  const double skin = 0.5 * scene.minRadius();
  auto bp = broadphase::makeBroadPhase(backend);
  broadphase::BruteForce brute;
  bp->build(scene.spheres(), scene.box, skin);
  brute.build(scene.spheres(), scene.box, skin);
  std::vector<Index> got, expected;
  for (Index i = 0; i < scene.spheres().count(); i += 7) {
    for (double reach : {0.0, 0.5 * skin, skin}) {
      bp->findNeighbours(scene.spheres(), i, reach, got);
      brute.findNeighbours(scene.spheres(), i, reach, expected);
      ASSERT_EQ(got, expected) << "particle " << i << " reach " << reach;
    }
  }
}

TEST_P(BackendProperty, UpdateAfterSmallMovesMatchesRebuild) {
  const std::string backend = GetParam();
  test::Scene scene =
      test::makeScene({.count = 1500, .distribution = "bi", .sizeRatio = 5.0, .packing = 0.3, .seed = 4});
  const double skin = 0.2;
  auto bp = broadphase::makeBroadPhase(backend);
  bp->build(scene.spheres(), scene.box, skin);
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> step(-0.3, 0.3);
  std::vector<Pair> got;
  for (int round = 0; round < 5; ++round) {
    std::vector<Index> moved;
    for (Index i = round; i < scene.spheres().count(); i += 5) {
      for (int k = 0; k < 3; ++k) scene.centre(k, i) += step(rng);
      scene.centre.col(i) = scene.box.wrap(scene.centre.col(i));
      moved.push_back(i);
    }
    bp->update(scene.spheres(), moved);
    bp->findPairs(scene.spheres(), got);
    broadphase::sortPairs(got);
    EXPECT_EQ(got, run("brute", scene, skin)) << "round " << round;
  }
}

TEST_P(BackendProperty, RejectsBadInput) {
  const std::string backend = GetParam();
  auto bp = broadphase::makeBroadPhase(backend);
  test::Scene s;
  s.box = Box::cubic(10.0, Boundary::Periodic);
  s.centre = Eigen::Matrix3Xd::Constant(3, 2, 5.0);
  s.radius = Eigen::VectorXd::Constant(2, 1.0);
  s.radius[1] = -1.0;
  EXPECT_THROW(bp->build(s.spheres(), s.box, 0.0), ConfigError);
  s.radius[1] = 1.0;
  s.centre(1, 1) = std::nan("");
  EXPECT_THROW(bp->build(s.spheres(), s.box, 0.0), ConfigError);
  s.centre(1, 1) = 11.0;  // outside
  EXPECT_THROW(bp->build(s.spheres(), s.box, 0.0), ConfigError);
  s.centre(1, 1) = 5.0;
  s.radius[1] = 2.6;  // 2 r_max = 5.2 > L / 2 on a periodic axis
  EXPECT_THROW(bp->build(s.spheres(), s.box, 0.0), ConfigError);
  s.radius[1] = 1.0;
  EXPECT_THROW(bp->build(s.spheres(), s.box, -0.1), ConfigError);
  EXPECT_NO_THROW(bp->build(s.spheres(), s.box, 0.1));
}

// The input scan runs without branches first and names the particle only when something is bad; at the
// edges of the valid ranges it must answer as the per-particle checks do (messages name the particle).
TEST_P(BackendProperty, RejectsBadInputAtTheEdgesOfTheValidRanges) {
  const std::string backend = GetParam();
  const double inf = std::numeric_limits<double>::infinity();
  struct Edge {
    int axis;  // -1: the radius
    double value;
    bool walls;  // the axis is walled (else periodic)
    bool valid;
  };
  const std::vector<Edge> edges = {
      {-1, 0.0, false, false},
      {-1, inf, false, false},
      {-1, std::nan(""), false, false},
      {-1, 0.01, false, true},
      {0, 10.0, false, false},
      {0, 10.0, true, true},
      {0, std::nextafter(10.0, 11.0), true, false},
      {1, -0.0, false, true},
      {1, -1e-300, false, false},
      {2, inf, true, false},
      {2, -inf, false, false},
      {2, std::nextafter(10.0, 0.0), false, true},
  };
  for (const Edge& e : edges) {
    SCOPED_TRACE(::testing::Message() << "axis " << e.axis << " value " << e.value
                                      << (e.walls ? " walls" : " periodic"));
    test::Scene s;
    s.box = Box({10.0, 10.0, 10.0}, {e.walls ? Boundary::Wall : Boundary::Periodic, Boundary::Periodic,
                                     e.walls ? Boundary::Wall : Boundary::Periodic});
    s.centre = Eigen::Matrix3Xd::Constant(3, 3, 5.0);
    s.centre(0, 0) = 1.0;
    s.centre(0, 2) = 9.0;
    s.radius = Eigen::VectorXd::Constant(3, 0.5);
    if (e.axis < 0) {
      s.radius[1] = e.value;
    } else {
      s.centre(e.axis, 1) = e.value;
    }
    auto bp = broadphase::makeBroadPhase(backend);
    if (e.valid) {
      EXPECT_NO_THROW(bp->build(s.spheres(), s.box, 0.0));
    } else {
      try {
        bp->build(s.spheres(), s.box, 0.0);
        ADD_FAILURE() << "accepted";
      } catch (const ConfigError& error) {
        EXPECT_NE(std::string(error.what()).find("particle 1"), std::string::npos) << error.what();
      }
    }
  }
}

// Threads (BroadPhase::setThreads): the threaded grid builds and searches report the serial pairs in the
// serial order, chunk by chunk, and brute force's pair set. The scenes are large enough (> 4096 spheres)
// for the parallel counting sorts, the chunked searches and the parallel input scan to run.
struct ThreadedCase {
  test::SceneSpec spec;
  double skinFactor;
};

std::vector<ThreadedCase> threadedCases() {
  return {
      {{.count = 6000, .distribution = "mono", .packing = 0.5, .periodic = true, .seed = 11}, 0.2},
      {{.count = 6000,
        .distribution = "uniform-volume",
        .sizeRatio = 10.0,
        .packing = 0.4,
        .periodic = true,
        .seed = 12},
       0.1},
      {{.count = 5000, .distribution = "bi", .sizeRatio = 8.0, .packing = 0.35, .periodic = false, .seed = 13}, 0.3},
      {{.count = 5000,
        .distribution = "uniform-volume",
        .sizeRatio = 100.0,
        .packing = 0.3,
        .periodic = false,
        .seed = 14},
       0.1},
  };
}

/// Brute force's pairs of threadedCases()[k], computed once per process.
const std::vector<Pair>& brutePairs(std::size_t k) {
  static std::vector<std::vector<Pair>> cache(threadedCases().size());
  static std::vector<bool> done(threadedCases().size(), false);
  if (!done[k]) {
    const ThreadedCase c = threadedCases()[k];
    const test::Scene scene = test::makeScene(c.spec);
    cache[k] = run("brute", scene, c.skinFactor * scene.minRadius());
    done[k] = true;
  }
  return cache[k];
}

TEST_P(BackendProperty, ThreadedBuildsFindTheSerialPairsInTheSerialOrder) {
  const std::string backend = GetParam();
  // Brute force is the reference below and has no threaded build: its O(N^2) runs would only cost time.
  if (backend == "brute") GTEST_SKIP() << "the reference itself";
  const std::vector<ThreadedCase> cases = threadedCases();
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const test::Scene scene = test::makeScene(cases[k].spec);
    const double skin = cases[k].skinFactor * scene.minRadius();
    SCOPED_TRACE(::testing::Message() << cases[k].spec.distribution << " omega " << cases[k].spec.sizeRatio
                                      << (cases[k].spec.periodic ? " periodic" : " walled"));
    auto serial = broadphase::makeBroadPhase(backend);
    serial->build(scene.spheres(), scene.box, skin);
    std::vector<Pair> expected;
    serial->findPairs(scene.spheres(), expected);
    // Backends without a threaded build run serially whatever setThreads says: one check is enough.
    const bool threadedBackend =
        backend == "linked-cell" || backend == "hgrid-td" || backend == "hgrid-bu" || backend == "auto";
    const std::vector<int> threadCounts = threadedBackend ? std::vector<int>{2, 3, 8} : std::vector<int>{3};
    for (int threads : threadCounts) {
      SCOPED_TRACE(::testing::Message() << threads << " threads");
      auto bp = broadphase::makeBroadPhase(backend);
      bp->setThreads(threads);
      EXPECT_EQ(bp->threads(), threads);
      bp->build(scene.spheres(), scene.box, skin);
      std::vector<Pair> got;
      bp->findPairs(scene.spheres(), got);
      EXPECT_EQ(got, expected);  // same pairs in the same (backend) order
      broadphase::PairChunks chunks;
      bp->findPairChunks(scene.spheres(), chunks);
      std::vector<Pair> joined;
      chunks.concatenate(joined);
      EXPECT_EQ(joined, expected);
      if (!threadedBackend) continue;
      if (POLYDEM_WITH_OPENMP) {
        EXPECT_GT(chunks.size(), 1u) << "a threaded backend should search in chunks here";
      }
      bp->build(scene.spheres(), scene.box, skin);  // a rebuild reuses the buffers: same answer
      bp->findPairs(scene.spheres(), got);
      EXPECT_EQ(got, expected);
    }
    broadphase::sortPairs(expected);
    EXPECT_EQ(expected, brutePairs(k));
  }
}

TEST_P(BackendProperty, ThreadedBuildRejectsBadInputLikeTheSerialOne) {
  const std::string backend = GetParam();
  test::Scene scene =
      test::makeScene({.count = 5000, .distribution = "mono", .packing = 0.3, .periodic = true, .seed = 15});
  scene.radius[4321] = -1.0;
  scene.centre(0, 2222) = std::nan("");  // the first bad particle is named, whichever thread finds one
  std::string serialMessage, threadedMessage;
  auto serial = broadphase::makeBroadPhase(backend);
  try {
    serial->build(scene.spheres(), scene.box, 0.1);
  } catch (const ConfigError& e) {
    serialMessage = e.what();
  }
  auto bp = broadphase::makeBroadPhase(backend);
  bp->setThreads(3);
  try {
    bp->build(scene.spheres(), scene.box, 0.1);
  } catch (const ConfigError& e) {
    threadedMessage = e.what();
  }
  EXPECT_NE(serialMessage.find("particle 2222"), std::string::npos) << serialMessage;
  EXPECT_EQ(threadedMessage, serialMessage);
  EXPECT_THROW(bp->setThreads(0), ConfigError);
  EXPECT_THROW(bp->setThreads(-2), ConfigError);
}

TEST_P(BackendProperty, ThreadedBuildThenUpdateMatchesBruteForce) {
  // Event-driven use: a threaded build followed by serial update()s of moved spheres.
  const std::string backend = GetParam();
  test::Scene scene =
      test::makeScene({.count = 5000, .distribution = "bi", .sizeRatio = 4.0, .packing = 0.3, .seed = 16});
  const double skin = 0.2;
  auto bp = broadphase::makeBroadPhase(backend);
  bp->setThreads(2);
  bp->build(scene.spheres(), scene.box, skin);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> step(-0.3, 0.3);
  std::vector<Index> moved;
  for (Index i = 0; i < scene.spheres().count(); i += 9) {
    for (int k = 0; k < 3; ++k) scene.centre(k, i) += step(rng);
    scene.centre.col(i) = scene.box.wrap(scene.centre.col(i));
    moved.push_back(i);
  }
  bp->update(scene.spheres(), moved);
  std::vector<Pair> got;
  bp->findPairs(scene.spheres(), got);
  broadphase::sortPairs(got);
  EXPECT_EQ(got, run("linked-cell", scene, skin));
}

INSTANTIATE_TEST_SUITE_P(AllBackends, BackendProperty, ::testing::ValuesIn(allBackends()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           std::string name = info.param;
                           for (char& ch : name) {
                             if (ch == '-') ch = '_';
                           }
                           return name;
                         });

TEST(Registry, UnknownNameListsValidOnes) {
  try {
    broadphase::makeBroadPhase("octree");
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("linked-cell"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace polydem
