// HGrid-specific tests; the property suite (property_test.cpp) runs both variants with default sizes.
#include "broadphase/hgrid.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <random>
#include <tuple>

#include "broadphase/brute_force.hpp"
#include "broadphase/parallel.hpp"
#include "core/errors.hpp"
#include "tests/support/scene.hpp"

namespace polydem::broadphase {
namespace {

std::vector<Pair> bruteForcePairs(const test::Scene& s, double skin) {
  BruteForce brute;
  brute.build(s.spheres(), s.box, skin);
  std::vector<Pair> pairs;
  brute.findPairs(s.spheres(), pairs);
  sortPairs(pairs);
  return pairs;
}

template <class Grid>
std::vector<Pair> gridPairs(Grid& grid, const test::Scene& s, double skin) {
  grid.build(s.spheres(), s.box, skin);
  grid.validate(s.spheres());
  std::vector<Pair> pairs;
  grid.findPairs(s.spheres(), pairs);
  sortPairs(pairs);
  return pairs;
}

HGridConfig sizes(std::vector<double> s) { return HGridConfig{std::move(s), CrossLevel::TopDown, "test"}; }

// Storage limits {dense, ranked}: hash tables only, ranked bitmaps only, dense where affordable, default.
constexpr std::array<std::array<double, 2>, 4> kStorage = {{{0.0, 0.0}, {0.0, 1000.0}, {1000.0, 0.0}, {8.0, 256.0}}};

// ---------------------------------------------------------------------------------------------------
// Worked example of Ogarko's thesis (Univ. Twente), Fig. 2.1 and eq. 2.12: s = (3, 8), B at
// (10.3, 14.4) with r = 4, C at (14, 14) with r = 1.5.

TEST(HGridWorkedExample, SearchBoxesOfEquation212) {
  const std::vector<double> s = {3.0, 8.0};
  EXPECT_EQ(hgrid::insertionLevel(s, 4.0, 0.0), 2);
  EXPECT_EQ(hgrid::insertionLevel(s, 1.5, 0.0), 1);  // 2 r == s_1 belongs to level 1
  EXPECT_EQ(hgrid::insertionLevel(s, 4.0 + 1e-12, 0.0), 0);
  EXPECT_EQ(hgrid::insertionLevel(s, 1.0, 1.0), 1);
  EXPECT_EQ(hgrid::insertionLevel(s, 1.0, 1.0 + 1e-9), 2);

  // TD search of B on level 1: beta = 4 + 1.5 = 5.5, cells (1, 2) .. (5, 6): 25 cells, not the
  // Fig. 2.1 caption's (1, 3) start, which contradicts eq. 2.12.
  const double betaB = hgrid::searchHalfWidth(4.0, 0.0, 3.0);
  EXPECT_DOUBLE_EQ(betaB, 5.5);
  const hgrid::CellRange b = hgrid::searchBox(Eigen::Vector3d(10.3, 14.4, 0.5), betaB, Eigen::Vector3d::Constant(3.0));
  EXPECT_EQ(b.lo[0], 1);
  EXPECT_EQ(b.lo[1], 2);
  EXPECT_EQ(b.hi[0], 5);
  EXPECT_EQ(b.hi[1], 6);
  // B itself sits in cell (1, 1) of level 2.
  EXPECT_EQ(static_cast<int>(std::floor(10.3 / 8.0)), 1);
  EXPECT_EQ(static_cast<int>(std::floor(14.4 / 8.0)), 1);

  // BU search of C on level 2: beta = 1.5 + 4 = 5.5, cells (1, 1) .. (2, 2).
  const double betaC = hgrid::searchHalfWidth(1.5, 0.0, 8.0);
  const hgrid::CellRange c = hgrid::searchBox(Eigen::Vector3d(14.0, 14.0, 0.5), betaC, Eigen::Vector3d::Constant(8.0));
  EXPECT_EQ(c.lo[0], 1);
  EXPECT_EQ(c.lo[1], 1);
  EXPECT_EQ(c.hi[0], 2);
  EXPECT_EQ(c.hi[1], 2);

  // The skin widens the box by half the skin: beta = r + skin/2 + s/2.
  EXPECT_DOUBLE_EQ(hgrid::searchHalfWidth(4.0, 0.2, 3.0), 5.6);
}

// The same example lifted to 3-D in a walled 24.3 x 24.3 x 3 box: level 1 has 8 x 8 x 1 cells of
// 3.0375, level 2 3 x 3 x 1 cells of 8.1, so the cell indices of the 2-D example are unchanged.
// A (r = 1.5) sits in cell (4, 2) of level 1, C in (4, 4), B in (1, 1) of level 2.
TEST(HGridWorkedExample, CountersOfTheLiftedExample) {
  test::Scene s;
  s.box = Box(Eigen::Vector3d(24.3, 24.3, 3.0), {Boundary::Wall, Boundary::Wall, Boundary::Wall});
  s.centre.resize(3, 3);
  s.centre.col(0) << 10.3, 14.4, 1.5;  // B
  s.centre.col(1) << 14.0, 14.0, 1.5;  // C
  s.centre.col(2) << 13.5, 7.5, 1.5;   // A
  s.radius = Eigen::Vector3d(4.0, 1.5, 1.5);

  HGridTopDown td;
  td.setConfig(sizes({3.0, 8.0}));
  td.setCounting(true);
  EXPECT_EQ(gridPairs(td, s, 0.0), (std::vector<Pair>{{0, 1}}));
  ASSERT_EQ(td.levelCount(), 2);
  EXPECT_EQ(td.levelInfo(1).cells, (std::array<int, 3>{8, 8, 1}));
  EXPECT_EQ(td.levelInfo(2).cells, (std::array<int, 3>{3, 3, 1}));
  EXPECT_EQ(td.levelOf(0), 2);
  EXPECT_EQ(td.levelOf(1), 1);
  // Level 2 (B): own cell 1 + 4 half-shell cells inside the walls + 25 box cells; tests A and C.
  EXPECT_EQ(td.levelCounters()[1].cellAccesses, 30u);
  EXPECT_EQ(td.levelCounters()[1].pairTests, 2u);
  // Level 1 (A, C): 1 + 4 each, no candidates (not neighbours).
  EXPECT_EQ(td.levelCounters()[0].cellAccesses, 10u);
  EXPECT_EQ(td.levelCounters()[0].pairTests, 0u);
  EXPECT_EQ(td.counters().cellAccesses, 40u);
  EXPECT_EQ(td.counters().pairTests, 2u);

  HGridBottomUp bu;
  bu.setConfig(sizes({3.0, 8.0}));
  bu.setCounting(true);
  EXPECT_EQ(gridPairs(bu, s, 0.0), (std::vector<Pair>{{0, 1}}));
  // Level 1: C scans (1,1)..(2,2) = 4 cells, A scans (0,0)..(2,1) = 6 cells; each finds B once.
  EXPECT_EQ(bu.levelCounters()[0].cellAccesses, (1u + 4u + 4u) + (1u + 4u + 6u));
  EXPECT_EQ(bu.levelCounters()[0].pairTests, 2u);
  EXPECT_EQ(bu.levelCounters()[1].cellAccesses, 5u);
  EXPECT_EQ(bu.levelCounters()[1].pairTests, 0u);
}

// ---------------------------------------------------------------------------------------------------
// Agreement with brute force for hand-set sizes.

struct HandCase {
  double omega;
  double packing;
  bool periodic;
  std::vector<double> cellSizes;  // in units of r_min = 1, before adding the skin
};

std::vector<HandCase> handCases() {
  return {
      {100.0, 0.3, true, {2.0, 7.0, 20.0, 55.0, 200.0}},  // non-doubling
      {100.0, 0.3, false, {2.0, 7.0, 20.0, 55.0, 200.0}},
      {100.0, 0.3, true, {200.0}},                              // one level: linked cell
      {100.0, 0.3, false, {2.0, 200.0}},                        // two levels
      {100.0, 0.3, true, {3.0, 3.5, 4.0, 90.0, 150.0, 400.0}},  // uneven, top level far above 2 r_max
      {100.0, 0.3, false, {1.0, 1.5, 2.5, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0, 201.0}},  // empty bottom levels
      {1000.0, 0.2, true, {2.0, 10.0, 100.0, 2000.0}},
      {1000.0, 0.2, false, {2.0, 10.0, 100.0, 2000.0}},
      {1000.0, 0.2, false, {2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0, 256.0, 512.0, 1024.0, 2000.0}},
      {1000.0, 0.2, true, {2.5, 31.0, 700.0, 2001.0}},
  };
}

TEST(HGridAgreement, UniformVolumeHandSetSizesMatchBruteForce) {
  for (const HandCase& c : handCases()) {
    for (std::uint64_t seed : {1u, 2u}) {
      const test::Scene scene = test::makeScene({.count = 3000,
                                                 .distribution = "uniform-volume",
                                                 .sizeRatio = c.omega,
                                                 .packing = c.packing,
                                                 .periodic = c.periodic,
                                                 .seed = seed});
      for (double skin : {0.0, 0.4}) {
        const auto expected = bruteForcePairs(scene, skin);
        ASSERT_GT(expected.size(), 0u);
        std::vector<double> s = c.cellSizes;
        for (double& v : s) v += skin;
        for (const auto& storage : kStorage) {
          SCOPED_TRACE(::testing::Message() << "omega " << c.omega << (c.periodic ? " periodic" : " walled") << " L "
                                            << s.size() << " top " << s.back() << " seed " << seed << " skin " << skin
                                            << " storage " << storage[0] << "/" << storage[1]);
          HGridTopDown td;
          td.setConfig(sizes(s));
          td.setStorageLimits(storage[0], storage[1]);
          EXPECT_EQ(gridPairs(td, scene, skin), expected) << td.describe();
          HGridBottomUp bu;
          bu.setConfig(sizes(s));
          bu.setStorageLimits(storage[0], storage[1]);
          EXPECT_EQ(gridPairs(bu, scene, skin), expected) << bu.describe();
          td.setAabbPrecheck(true);  // the default is off: the optional pre-check must agree too
          bu.setAabbPrecheck(true);
          EXPECT_EQ(gridPairs(td, scene, skin), expected);
          EXPECT_EQ(gridPairs(bu, scene, skin), expected);
        }
      }
    }
  }
}

// Few cells per axis: levels with 1 or 2 periodic cells (aliased stencil), top levels larger than
// the box, and anisotropic boxes with mixed boundaries.
TEST(HGridAgreement, CoarseLevelsAndThinBoxes) {
  struct ThinCase {
    Eigen::Vector3d lengths;
    std::array<Boundary, 3> boundaries;
    std::vector<double> cellSizes;
  };
  const std::vector<ThinCase> cases = {
      {{10.0, 7.0, 40.0}, {Boundary::Periodic, Boundary::Periodic, Boundary::Periodic}, {0.5, 2.4, 4.9}},
      {{10.0, 7.0, 40.0}, {Boundary::Periodic, Boundary::Wall, Boundary::Periodic}, {0.5, 2.4, 3.4, 60.0}},
      {{10.0, 10.0, 10.0}, {Boundary::Periodic, Boundary::Periodic, Boundary::Periodic}, {0.7, 3.4, 4.9, 11.0}},
      {{3.0, 3.0, 3.0}, {Boundary::Wall, Boundary::Wall, Boundary::Wall}, {0.5, 1.0, 2.0, 5.0}},
      {{5.2, 30.0, 5.2}, {Boundary::Periodic, Boundary::Wall, Boundary::Wall}, {0.5, 1.1, 2.6}},
  };
  for (const ThinCase& c : cases) {
    test::Scene s;
    s.box = Box(c.lengths, c.boundaries);
    const Index n = 1500;
    s.centre.resize(3, n);
    s.radius.resize(n);
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    for (Index i = 0; i < n; ++i) {
      const double pick = u01(rng);
      s.radius[i] = pick < 0.7 ? 0.2 : (pick < 0.9 ? 0.6 + 0.5 * u01(rng) : 1.2);
      for (int k = 0; k < 3; ++k) s.centre(k, i) = u01(rng) * c.lengths[k];
    }
    for (double skin : {0.0, 0.1}) {
      const auto expected = bruteForcePairs(s, skin);
      for (const auto& storage : kStorage) {
        SCOPED_TRACE(::testing::Message()
                     << s.box.describe() << " skin " << skin << " storage " << storage[0] << "/" << storage[1]);
        HGridTopDown td;
        td.setConfig(sizes(c.cellSizes));
        td.setStorageLimits(storage[0], storage[1]);
        EXPECT_EQ(gridPairs(td, s, skin), expected) << td.describe();
        HGridBottomUp bu;
        bu.setConfig(sizes(c.cellSizes));
        bu.setStorageLimits(storage[0], storage[1]);
        EXPECT_EQ(gridPairs(bu, s, skin), expected) << bu.describe();
      }
    }
  }
}

// Centres on a lattice of spacing 0.5 in a box of 12, with nominal sizes just below 1, 1.5, 2, 3, 4
// so that the snapped edges are exactly 1, 1.5, 2, 3 and 4: many centres sit on cell faces of every
// level, and radii in multiples of 0.25 make many gaps exactly 0 or exactly the skin.
TEST(HGridAgreement, CentresOnCellFacesOfEveryLevel) {
  const std::vector<double> nominal = {0.9999, 1.4999, 1.9999, 2.9999, 3.9999};
  const double radii[] = {0.25, 0.5, 0.75, 1.0, 1.25, 1.5};
  for (bool periodic : {true, false}) {
    test::Scene s;
    s.box = Box::cubic(12.0, periodic ? Boundary::Periodic : Boundary::Wall);
    const int m = periodic ? 24 : 25;  // walls: include centres exactly at L
    std::vector<Eigen::Vector3d> points;
    for (int z = 0; z < m; ++z)
      for (int y = 0; y < m; ++y)
        for (int x = 0; x < m; ++x) points.emplace_back(0.5 * x, 0.5 * y, 0.5 * z);
    std::mt19937_64 rng(periodic ? 3 : 4);
    std::shuffle(points.begin(), points.end(), rng);
    const Index n = 2500;
    s.centre.resize(3, n);
    s.radius.resize(n);
    for (Index i = 0; i < n; ++i) {
      s.centre.col(i) = points[static_cast<std::size_t>(i)];
      s.radius[i] = radii[i % 6];
    }
    for (double skin : {0.0, 0.25, 0.5}) {
      const auto expected = bruteForcePairs(s, skin);
      ASSERT_GT(expected.size(), 0u);
      for (const auto& storage : kStorage) {
        SCOPED_TRACE(::testing::Message() << (periodic ? "periodic" : "walled") << " skin " << skin << " storage "
                                          << storage[0] << "/" << storage[1]);
        HGridTopDown td;
        td.setConfig(sizes(nominal));
        td.setStorageLimits(storage[0], storage[1]);
        EXPECT_EQ(gridPairs(td, s, skin), expected);
        const double snapped[] = {1.0, 1.5, 2.0, 3.0, 4.0};
        for (int h = 1; h <= td.levelCount(); ++h) {
          EXPECT_DOUBLE_EQ(td.levelInfo(h).cellSize[0], snapped[h - 1]) << "level " << h;
        }
        HGridBottomUp bu;
        bu.setConfig(sizes(nominal));
        bu.setStorageLimits(storage[0], storage[1]);
        EXPECT_EQ(gridPairs(bu, s, skin), expected);
        // Exact touching on faces is where a careless AABB pre-check would drop pairs.
        td.setAabbPrecheck(true);
        bu.setAabbPrecheck(true);
        EXPECT_EQ(gridPairs(td, s, skin), expected);
        EXPECT_EQ(gridPairs(bu, s, skin), expected);
      }
    }
  }
}

TEST(HGridAgreement, DefaultSizesOnWidePowerLaw) {
  const test::Scene scene = test::makeScene({.count = 4000,
                                             .distribution = "uniform-volume",
                                             .sizeRatio = 50.0,
                                             .packing = 0.3,
                                             .periodic = false,
                                             .seed = 8});
  for (double skin : {0.0, 0.5}) {
    const auto expected = bruteForcePairs(scene, skin);
    HGridTopDown td;
    EXPECT_EQ(gridPairs(td, scene, skin), expected);
    HGridBottomUp bu;
    EXPECT_EQ(gridPairs(bu, scene, skin), expected);
  }
}

// ---------------------------------------------------------------------------------------------------
// Configuration

TEST(HGridConfiguration, DefaultSizesDoubleUpToTheLargestInteractionDiameter) {
  const auto c = hgrid::defaultConfig(1.0, 50.0, 0.1, CrossLevel::BottomUp);
  EXPECT_EQ(c.mode, CrossLevel::BottomUp);
  const std::vector<double> expected = {2.1, 4.2, 8.4, 16.8, 33.6, 67.2, 100.1};
  ASSERT_EQ(c.cellSizes.size(), expected.size());
  for (std::size_t h = 0; h < expected.size(); ++h) EXPECT_NEAR(c.cellSizes[h], expected[h], 1e-12);
  EXPECT_EQ(c.cellSizes.back(), 2.0 * 50.0 + 0.1);
  EXPECT_EQ(hgrid::defaultConfig(1.0, 1.0, 0.1, CrossLevel::TopDown).cellSizes, std::vector<double>{2.1});
  EXPECT_EQ(hgrid::defaultConfig(1.0, 2.0, 0.0, CrossLevel::TopDown).cellSizes, (std::vector<double>{2.0, 4.0}));

  const test::Scene mono = test::makeScene({.count = 500, .distribution = "mono", .packing = 0.3, .seed = 2});
  HGridTopDown td;
  td.build(mono.spheres(), mono.box, 0.2);
  EXPECT_EQ(td.levelCount(), 1);
  EXPECT_EQ(td.config().cellSizes, std::vector<double>{2.2});
  EXPECT_EQ(td.config().mode, CrossLevel::TopDown);
  EXPECT_NE(td.describe().find("hgrid-td L=1 sizes 2.2 (snapped"), std::string::npos) << td.describe();

  const test::Scene wide =
      test::makeScene({.count = 2000, .distribution = "uniform-volume", .sizeRatio = 30.0, .packing = 0.3, .seed = 2});
  HGridBottomUp bu;
  bu.build(wide.spheres(), wide.box, 0.2);
  EXPECT_EQ(bu.config().cellSizes,
            hgrid::defaultConfig(wide.radius.minCoeff(), wide.radius.maxCoeff(), 0.2, CrossLevel::BottomUp).cellSizes);
  EXPECT_EQ(bu.levelCount(), static_cast<int>(bu.config().cellSizes.size()));
}

TEST(HGridConfiguration, ExplicitSizesAreValidated) {
  HGridTopDown td;
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_THROW(td.setConfig(sizes({})), ConfigError);
  EXPECT_THROW(td.setConfig(sizes({1.0, -2.0})), ConfigError);
  EXPECT_THROW(td.setConfig(sizes({0.0, 2.0})), ConfigError);
  EXPECT_THROW(td.setConfig(sizes({1.0, std::nan("")})), ConfigError);
  EXPECT_THROW(td.setConfig(sizes({1.0, inf})), ConfigError);
  EXPECT_THROW(td.setConfig(sizes({1.0, 3.0, 2.0})), ConfigError);
  EXPECT_THROW(td.setConfig(sizes({1.0, 2.0, 2.0})), ConfigError);
  try {
    td.setConfig(sizes({1.0, 3.0, 2.0}));
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("increase strictly"), std::string::npos) << e.what();
  }

  // The top level must hold the largest interaction diameter 2 r_max + skin.
  test::Scene s;
  s.box = Box::cubic(20.0, Boundary::Periodic);
  s.centre = Eigen::Matrix3Xd::Constant(3, 2, 5.0);
  s.centre(0, 1) = 8.0;
  s.radius = Eigen::Vector2d(0.5, 2.0);
  td.setConfig(sizes({1.0, 4.0}));
  EXPECT_NO_THROW(td.build(s.spheres(), s.box, 0.0));
  try {
    td.build(s.spheres(), s.box, 0.1);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("cell size s_L = 4 is smaller than the largest interaction diameter 2 r_max + skin = 4.1"),
              std::string::npos)
        << what;
  }
  // The mode always follows the backend type.
  HGridBottomUp bu;
  bu.setConfig(sizes({1.0, 4.5}));
  bu.build(s.spheres(), s.box, 0.1);
  EXPECT_EQ(bu.config().mode, CrossLevel::BottomUp);
  EXPECT_EQ(bu.config().cellSizes, (std::vector<double>{1.0, 4.5}));
}

TEST(HGridConfiguration, ConfiguratorIsCalledWhenNoExplicitSizes) {
  const test::Scene scene =
      test::makeScene({.count = 2000, .distribution = "uniform-volume", .sizeRatio = 20.0, .packing = 0.3, .seed = 5});
  const double skin = 0.3;
  const double top = 2.0 * scene.radius.maxCoeff() + skin;
  int calls = 0;
  HGridBottomUp bu;
  bu.setConfigurator([&](const SphereView& spheres, const Box& box, double s, CrossLevel mode) {
    ++calls;
    EXPECT_EQ(spheres.count(), 2000);
    EXPECT_EQ(box, scene.box);
    EXPECT_EQ(s, skin);
    EXPECT_EQ(mode, CrossLevel::BottomUp);
    return HGridConfig{{3.0, 9.0, 20.0}, CrossLevel::TopDown, "test optimiser"};  // misses r_max = 20
  });
  const auto expected = bruteForcePairs(scene, skin);
  EXPECT_EQ(gridPairs(bu, scene, skin), expected);
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(bu.config().cellSizes, (std::vector<double>{3.0, 9.0, 20.0, top}));  // lenient: top level added
  EXPECT_EQ(bu.config().mode, CrossLevel::BottomUp);
  EXPECT_NE(bu.describe().find("added top level"), std::string::npos) << bu.describe();
  EXPECT_NE(bu.describe().find("test optimiser"), std::string::npos) << bu.describe();

  // An explicit config wins over the configurator; clearConfig() hands control back.
  bu.setConfig(sizes({2.5, top}));
  EXPECT_EQ(gridPairs(bu, scene, skin), expected);
  EXPECT_EQ(calls, 1);
  bu.clearConfig();
  EXPECT_EQ(gridPairs(bu, scene, skin), expected);
  EXPECT_EQ(calls, 2);

  // No spheres: nothing to configure, the configurator is not asked.
  test::Scene empty;
  empty.box = scene.box;
  empty.centre.resize(3, 0);
  empty.radius.resize(0);
  EXPECT_TRUE(gridPairs(bu, empty, skin).empty());
  EXPECT_EQ(calls, 2);

  // Invalid sizes from the configurator are a ConfigError.
  bu.setConfigurator([](const SphereView&, const Box&, double, CrossLevel) { return sizes({5.0, 4.0}); });
  EXPECT_THROW(bu.build(scene.spheres(), scene.box, skin), ConfigError);
}

// ---------------------------------------------------------------------------------------------------
// Counters: the cost model's T_ca and T_cd per level (thesis eqs. 2.20-2.30), recomputed independently.

struct LevelCount {
  std::uint64_t cellAccesses = 0, pairTests = 0;
};

template <class Grid>
std::vector<LevelCount> expectedCounts(const Grid& grid, const test::Scene& s, double skin, bool topDown) {
  const int levels = grid.levelCount();
  const SphereView sp = s.spheres();
  const Index n = sp.count();
  // Occupancy of every cell of every level.
  std::map<std::tuple<int, std::int64_t, std::int64_t, std::int64_t>, std::uint64_t> occupancy;
  std::vector<bool> occupied(static_cast<std::size_t>(levels) + 1, false);
  auto cellOf = [&](int h, const Eigen::Vector3d& x) {
    const auto info = grid.levelInfo(h);
    std::array<std::int64_t, 3> c;
    for (int k = 0; k < 3; ++k) c[k] = std::min<std::int64_t>(info.cells[k] - 1, std::floor(x[k] / info.cellSize[k]));
    return c;
  };
  for (Index i = 0; i < n; ++i) {
    const int h = grid.levelOf(i);
    const auto c = cellOf(h, sp.centre.col(i));
    ++occupancy[{h, c[0], c[1], c[2]}];
    occupied[static_cast<std::size_t>(h)] = true;
  }
  auto count = [&](int h, std::int64_t x, std::int64_t y, std::int64_t z) -> std::uint64_t {
    const auto info = grid.levelInfo(h);
    const std::int64_t w[3] = {x, y, z};
    std::int64_t c[3];
    for (int k = 0; k < 3; ++k) c[k] = ((w[k] % info.cells[k]) + info.cells[k]) % info.cells[k];  // periodic
    const auto it = occupancy.find({h, c[0], c[1], c[2]});
    return it == occupancy.end() ? 0 : it->second;
  };
  std::vector<LevelCount> out(static_cast<std::size_t>(levels));
  std::map<std::tuple<int, std::int64_t, std::int64_t, std::int64_t>, bool> ownDone;
  for (Index i = 0; i < n; ++i) {
    const int h = grid.levelOf(i);
    LevelCount& lc = out[static_cast<std::size_t>(h - 1)];
    const auto c = cellOf(h, sp.centre.col(i));
    // Own cell: one look-up per sphere; the m (m - 1) / 2 pairs once per cell.
    lc.cellAccesses += 1;
    if (!ownDone[{h, c[0], c[1], c[2]}]) {
      ownDone[{h, c[0], c[1], c[2]}] = true;
      const std::uint64_t m = count(h, c[0], c[1], c[2]);
      lc.pairTests += m * (m - 1) / 2;
    }
    // Half shell: 13 look-ups per sphere.
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          if (!(dz > 0 || (dz == 0 && dy > 0) || (dz == 0 && dy == 0 && dx > 0))) continue;
          lc.cellAccesses += 1;
          lc.pairTests += count(h, c[0] + dx, c[1] + dy, c[2] + dz);
        }
    // Cross-level boxes: floor((x + beta) / s) - floor((x - beta) / s) + 1 cells per axis.
    for (int j = 1; j <= levels; ++j) {
      if (!occupied[static_cast<std::size_t>(j)] || (topDown ? j >= h : j <= h)) continue;
      const auto info = grid.levelInfo(j);
      const double beta = sp.radius[i] + 0.5 * skin + 0.5 * info.nominalSize;
      std::int64_t lo[3], hi[3];
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::floor((sp.centre(k, i) - beta) / info.cellSize[k]);
        hi[k] = std::floor((sp.centre(k, i) + beta) / info.cellSize[k]);
        EXPECT_LT(hi[k] - lo[k] + 1, info.cells[k]) << "test scene must not wrap a search box onto itself";
      }
      lc.cellAccesses += static_cast<std::uint64_t>((hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1));
      for (std::int64_t z = lo[2]; z <= hi[2]; ++z)
        for (std::int64_t y = lo[1]; y <= hi[1]; ++y)
          for (std::int64_t x = lo[0]; x <= hi[0]; ++x) lc.pairTests += count(j, x, y, z);
    }
  }
  return out;
}

TEST(HGridCounters, MatchThePerSphereCostModelDefinitions) {
  // Random overlapping centres in a periodic box (the cost model's ensemble), every level occupied and
  // at least 3 cells wide, so each sphere makes exactly 1 + 13 same-level look-ups.
  const test::Scene scene =
      test::makeScene({.count = 6000, .distribution = "uniform-volume", .sizeRatio = 10.0, .packing = 0.3, .seed = 21});
  const double skin = 0.2;
  // The second set puts only the smallest ~1% of the spheres on level 1, so Top-Down boxes there have
  // more cells than the level has occupied cells (the grid then tests occupied cells against the box).
  for (const std::vector<double>& s :
       {std::vector<double>{2.5, 4.0, 7.0, 12.0, 20.2}, std::vector<double>{2.21, 4.0, 7.0, 12.0, 20.2}})
    for (bool topDown : {true, false}) {
      for (const auto& storage : kStorage) {
        SCOPED_TRACE(::testing::Message()
                     << (topDown ? "TD" : "BU") << " storage " << storage[0] << "/" << storage[1] << " s_1 " << s[0]);
        std::vector<Pair> counted, plain;
        std::vector<LevelCount> expected;
        std::vector<Counters> got;
        Counters total;
        auto run = [&](auto& grid) {
          grid.setConfig(sizes(s));
          grid.setStorageLimits(storage[0], storage[1]);
          grid.build(scene.spheres(), scene.box, skin);
          grid.findPairs(scene.spheres(), plain);
          EXPECT_EQ(grid.counters().cellAccesses, 0u);  // counting off: nothing counted
          grid.setCounting(true);
          grid.findPairs(scene.spheres(), counted);
          for (int h = 1; h <= grid.levelCount(); ++h) ASSERT_GT(grid.levelInfo(h).spheres, 0) << "level " << h;
          expected = expectedCounts(grid, scene, skin, topDown);
          got = grid.levelCounters();
          total = grid.counters();
        };
        if (topDown) {
          HGridTopDown g;
          run(g);
        } else {
          HGridBottomUp g;
          run(g);
        }
        EXPECT_EQ(counted, plain);
        ASSERT_EQ(got.size(), expected.size());
        Counters sum;
        for (std::size_t h = 0; h < got.size(); ++h) {
          EXPECT_EQ(got[h].cellAccesses, expected[h].cellAccesses) << "level " << h + 1;
          EXPECT_EQ(got[h].pairTests, expected[h].pairTests) << "level " << h + 1;
          sum.cellAccesses += got[h].cellAccesses;
          sum.pairTests += got[h].pairTests;
        }
        EXPECT_EQ(sum.cellAccesses, total.cellAccesses);
        EXPECT_EQ(sum.pairTests, total.pairTests);
        EXPECT_GE(total.pairTests, counted.size());
      }
    }
}

// Mean cross-level box width per axis is 2 beta / s' + 1 (thesis eqs. 2.57-2.64 with the skin and snapping).
TEST(HGridCounters, MeanSearchBoxWidthPerAxis) {
  std::mt19937_64 rng(3);
  const double s = 1.7, beta = 2.3;
  std::uniform_real_distribution<double> u(0.0, s);
  double sum = 0.0;
  const int samples = 100000;
  for (int i = 0; i < samples; ++i) {
    const auto r = hgrid::searchBox(Eigen::Vector3d::Constant(10.0 * s + u(rng)), beta, Eigen::Vector3d::Constant(s));
    sum += static_cast<double>(r.hi[0] - r.lo[0] + 1);
  }
  EXPECT_NEAR(sum / samples, 2.0 * beta / s + 1.0, 0.005 * (2.0 * beta / s + 1.0));
}

// ---------------------------------------------------------------------------------------------------
// Neighbour queries, incremental updates, memory

TEST(HGridQueries, NeighboursMatchBruteForceOnBothVariants) {
  const test::Scene scene = test::makeScene({.count = 2000,
                                             .distribution = "uniform-volume",
                                             .sizeRatio = 60.0,
                                             .packing = 0.3,
                                             .periodic = true,
                                             .seed = 6});
  const double skin = 0.6;
  BruteForce brute;
  brute.build(scene.spheres(), scene.box, skin);
  HGridTopDown td;
  td.setConfig(sizes({2.6, 5.0, 13.0, 40.0, 121.0}));
  td.build(scene.spheres(), scene.box, skin);
  HGridBottomUp bu;
  bu.build(scene.spheres(), scene.box, skin);
  std::vector<Index> got, expected;
  for (Index i = 0; i < scene.spheres().count(); i += 3) {
    for (double reach : {0.0, 0.3, skin}) {
      brute.findNeighbours(scene.spheres(), i, reach, expected);
      td.findNeighbours(scene.spheres(), i, reach, got);
      ASSERT_EQ(got, expected) << "td particle " << i << " reach " << reach;
      bu.findNeighbours(scene.spheres(), i, reach, got);
      ASSERT_EQ(got, expected) << "bu particle " << i << " reach " << reach;
    }
  }
  EXPECT_THROW(td.findNeighbours(scene.spheres(), 0, 2.0 * skin, got), ConfigError);
}

TEST(HGridUpdate, MovesWithinAndAcrossCellsUseTheOverflow) {
  for (bool periodic : {true, false}) {
    test::Scene scene = test::makeScene({.count = 3000,
                                         .distribution = "uniform-volume",
                                         .sizeRatio = 20.0,
                                         .packing = 0.3,
                                         .periodic = periodic,
                                         .seed = 12});
    const double skin = 0.4;
    HGridTopDown td;
    HGridBottomUp bu;
    td.build(scene.spheres(), scene.box, skin);
    bu.build(scene.spheres(), scene.box, skin);
    BruteForce brute;
    std::mt19937_64 rng(periodic ? 1 : 2);
    std::uniform_int_distribution<Index> pick(0, scene.spheres().count() - 1);
    std::uniform_real_distribution<double> step(-1.5, 1.5);
    std::vector<Pair> got;
    std::vector<Index> neighbours, expectedNeighbours;
    for (int round = 0; round < 40; ++round) {
      std::vector<Index> moved;
      for (int k = 0; k < 4; ++k) {
        const Index i = pick(rng);
        Eigen::Vector3d x = scene.centre.col(i) + Eigen::Vector3d(step(rng), step(rng), step(rng));
        if (periodic) {
          x = scene.box.wrap(x);
        } else {
          x = x.cwiseMax(0.0).cwiseMin(scene.box.lengths());
        }
        scene.centre.col(i) = x;
        moved.push_back(i);
      }
      if (round % 10 == 3) moved.push_back(moved.front());  // a sphere listed twice
      td.update(scene.spheres(), moved);
      bu.update(scene.spheres(), moved);
      td.validate(scene.spheres());
      bu.validate(scene.spheres());
      const auto expected = bruteForcePairs(scene, skin);
      td.findPairs(scene.spheres(), got);
      sortPairs(got);
      ASSERT_EQ(got, expected) << "td round " << round;
      bu.findPairs(scene.spheres(), got);
      sortPairs(got);
      ASSERT_EQ(got, expected) << "bu round " << round;
      brute.build(scene.spheres(), scene.box, skin);
      for (Index i : moved) {
        brute.findNeighbours(scene.spheres(), i, skin, expectedNeighbours);
        td.findNeighbours(scene.spheres(), i, skin, neighbours);
        ASSERT_EQ(neighbours, expectedNeighbours) << "round " << round << " particle " << i;
      }
    }
    EXPECT_GT(td.overflowCount(), 0);  // 160 moves of up to 1.5: many cross a cell, none triggered a rebuild
    EXPECT_NE(td.describe().find("overflow"), std::string::npos);

    // Moving (nearly) every sphere to another cell overflows the overflow: the index is rebuilt.
    std::vector<Index> all(3000);
    for (Index i = 0; i < 3000; ++i) all[static_cast<std::size_t>(i)] = i;
    HGridTopDown fresh;
    fresh.build(scene.spheres(), scene.box, skin);
    for (Index i = 0; i < 3000; ++i) {
      const Eigen::Vector3d x = scene.centre.col(i);
      scene.centre.col(i) =
          periodic ? scene.box.wrap(x + scene.box.lengths() / 3.0) : Eigen::Vector3d(scene.box.lengths() - x);
    }
    fresh.update(scene.spheres(), all);
    fresh.validate(scene.spheres());
    EXPECT_EQ(fresh.overflowCount(), 0);
    fresh.findPairs(scene.spheres(), got);
    sortPairs(got);
    EXPECT_EQ(got, bruteForcePairs(scene, skin));
  }
}

TEST(HGridUpdate, RejectsCentresOutsideTheBox) {
  test::Scene s = test::makeScene({.count = 100, .distribution = "mono", .packing = 0.2, .seed = 1});
  HGridTopDown td;
  td.build(s.spheres(), s.box, 0.1);
  s.centre(0, 5) = s.box.length(0) + 1.0;
  const std::vector<Index> moved = {5};
  EXPECT_THROW(td.update(s.spheres(), moved), ConfigError);
}

TEST(HGridMemory, DiluteHugeBoxStaysLinearInN) {
  test::Scene s;
  s.box = Box::cubic(1.0e6, Boundary::Wall);
  const Index n = 50;
  s.centre.resize(3, n);
  s.radius.resize(n);
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(0.0, 1.0e6);
  for (Index i = 0; i < n; ++i) {
    s.radius[i] = i % 2 ? 0.01 : 5.0;
    for (int k = 0; k < 3; ++k) s.centre(k, i) = i < 10 ? 500.0 + i * 0.005 : u(rng);
  }
  for (const auto& storage : kStorage) {
    HGridTopDown td;
    td.setStorageLimits(storage[0], storage[1]);
    EXPECT_EQ(gridPairs(td, s, 0.001), bruteForcePairs(s, 0.001));
    EXPECT_LT(td.memoryBytes(), 64u * 1024u) << td.describe();
    HGridBottomUp bu;
    bu.setStorageLimits(storage[0], storage[1]);
    EXPECT_EQ(gridPairs(bu, s, 0.001), bruteForcePairs(s, 0.001));
  }
}

// A grid that is only built and searched (a DEM run) holds no state of update(); the first update() after a
// build makes it (home slots and cells, overflow links: at least 16 bytes per sphere), later builds keep its
// buffers, and the updates after every rebuild find the pairs brute force finds.
TEST(HGridMemory, UpdateStateOnlyWhenUpdating) {
  test::Scene scene =
      test::makeScene({.count = 4000, .distribution = "uniform-volume", .sizeRatio = 10.0, .packing = 0.3, .seed = 21});
  const double skin = 0.1 * scene.minRadius();
  HGridTopDown td;
  td.build(scene.spheres(), scene.box, skin);
  const std::size_t buildOnly = td.memoryBytes();
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> step(-0.3, 0.3);
  std::vector<Index> moved;
  for (int round = 0; round < 3; ++round) {
    moved.clear();
    for (Index i = 0; i < scene.radius.size(); i += 7) {
      for (int k = 0; k < 3; ++k) {
        const double L = scene.box.length(k);
        scene.centre(k, i) = std::fmod(scene.centre(k, i) + step(rng) * scene.radius[i] + L, L);
      }
      moved.push_back(i);
    }
    td.update(scene.spheres(), moved);
    td.validate(scene.spheres());
    std::vector<Pair> pairs;
    td.findPairs(scene.spheres(), pairs);
    sortPairs(pairs);
    EXPECT_EQ(pairs, bruteForcePairs(scene, skin)) << "round " << round;
    EXPECT_GE(td.memoryBytes(), buildOnly + 16 * static_cast<std::size_t>(scene.radius.size()));
    td.build(scene.spheres(), scene.box, skin);  // the next update() prepares again
    td.validate(scene.spheres());
  }
}

TEST(HGridMemory, SteadyStateRebuildsReuseBuffers) {
  const test::Scene scene =
      test::makeScene({.count = 5000, .distribution = "uniform-volume", .sizeRatio = 30.0, .packing = 0.3, .seed = 9});
  HGridTopDown td;
  std::vector<Pair> pairs;
  td.build(scene.spheres(), scene.box, 0.1);
  td.findPairs(scene.spheres(), pairs);
  const std::size_t bytes = td.memoryBytes();
  const std::size_t capacity = pairs.capacity();
  for (int k = 0; k < 3; ++k) {
    td.build(scene.spheres(), scene.box, 0.1);
    td.findPairs(scene.spheres(), pairs);
  }
  EXPECT_EQ(td.memoryBytes(), bytes);
  EXPECT_EQ(pairs.capacity(), capacity);
}

}  // namespace
}  // namespace polydem::broadphase

namespace polydem::broadphase {
namespace {

TEST(HGridMemory, ThreadedRebuildsReuseBuffersAndKeepTheIndex) {
  // Threads: per-part histograms, search tasks and pair chunks are sized at the first build and reused;
  // the index itself is the serial one (validate() and the same pairs in the same order).
  const test::Scene scene =
      test::makeScene({.count = 9000, .distribution = "uniform-volume", .sizeRatio = 30.0, .packing = 0.3, .seed = 9});
  HGridTopDown serial;
  std::vector<Pair> expected;
  serial.build(scene.spheres(), scene.box, 0.1);
  serial.findPairs(scene.spheres(), expected);
  HGridTopDown td;
  td.setThreads(3);
  std::vector<Pair> pairs;
  td.build(scene.spheres(), scene.box, 0.1);
  td.findPairs(scene.spheres(), pairs);
  EXPECT_NO_THROW(td.validate(scene.spheres()));
  EXPECT_EQ(pairs, expected);
  const std::size_t bytes = td.memoryBytes();
  for (int k = 0; k < 3; ++k) {
    td.build(scene.spheres(), scene.box, 0.1);
    td.findPairs(scene.spheres(), pairs);
  }
  EXPECT_EQ(td.memoryBytes(), bytes);
  EXPECT_EQ(pairs, expected);
}

}  // namespace
}  // namespace polydem::broadphase

namespace polydem::broadphase {
namespace {

// One thread: the dense levels' counting sort needs no histogram beside the cell-start array, and the
// list of occupied cells grows by an eighth, not by doubling. Uniform volume, size ratio 50, packing 0.6
// (7 levels by doubling, 5 of them dense): the grid holds 105 bytes per sphere; 129 with a bucket-sized histogram
// and a doubled cell list.
TEST(HGridMemory, SerialBuildHoldsNoSortScratchAndFewSpareCells) {
  const test::Scene scene =
      test::makeScene({.count = 20000, .distribution = "uniform-volume", .sizeRatio = 50.0, .packing = 0.6, .seed = 4});
  HGridTopDown td;
  td.build(scene.spheres(), scene.box, 0.1 * scene.minRadius());
  td.validate(scene.spheres());
  EXPECT_LT(static_cast<double>(td.memoryBytes()) / 20000.0, 112.0) << td.describe();
}

TEST(ParallelCountingSort, OneThreadIsStableAndUsesNoScratch) {
  const std::size_t n = 5000, buckets = 20000;
  std::mt19937_64 rng(3);
  std::vector<Index> bucket(n);
  for (auto& b : bucket) b = static_cast<Index>(rng() % buckets);
  std::vector<Index> start(buckets + 1), order(n, -1), scratch;
  parallel::stableCountingSort(
      1, n, buckets, 7, [&](std::size_t i) { return bucket[i]; }, start.data(), scratch,
      [&](std::size_t i, Index slot) { order[static_cast<std::size_t>(slot - 7)] = static_cast<Index>(i); });
  EXPECT_TRUE(scratch.empty());
  std::vector<Index> expected(n);
  std::iota(expected.begin(), expected.end(), 0);
  std::stable_sort(expected.begin(), expected.end(), [&](Index a, Index b) { return bucket[a] < bucket[b]; });
  EXPECT_EQ(order, expected);
  for (std::size_t b = 0; b < buckets; ++b) {
    const auto count = static_cast<Index>(std::count(bucket.begin(), bucket.end(), static_cast<Index>(b)));
    ASSERT_EQ(start[b + 1] - start[b], count) << "bucket " << b;
  }
  EXPECT_EQ(start[0], 7);
  EXPECT_EQ(start[buckets], static_cast<Index>(7 + n));
}

}  // namespace
}  // namespace polydem::broadphase
