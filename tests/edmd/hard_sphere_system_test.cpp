// The event-driven engine: closed-form 2- and 3-sphere cases, periodic wrap, walls, conservation laws,
// invariants under growth, backend independence, the watchdog and input checks.
#include "edmd/hard_sphere_system.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "core/errors.hpp"
#include "core/initial_configuration.hpp"
#include "edmd/compression.hpp"
#include "edmd/kinematics.hpp"

namespace polydem::edmd {
namespace {

Eigen::Matrix3Xd columns(std::initializer_list<Eigen::Vector3d> list) {
  Eigen::Matrix3Xd m(3, static_cast<Eigen::Index>(list.size()));
  Eigen::Index k = 0;
  for (const auto& v : list) m.col(k++) = v;
  return m;
}

Eigen::Matrix3Xd randomVelocities(Index n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  Eigen::Matrix3Xd v(3, n);
  for (Index i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) v(k, i) = normal(rng);
  const Eigen::Vector3d mean = v.rowwise().mean();
  v.colwise() -= mean;
  return v;
}

// Random sequential addition of n spheres (radii from `radii`, or mono radius 1).
Configuration randomPacking(Index n, double phi, std::uint64_t seed, std::vector<double> radii = {},
                            std::array<Boundary, 3> boundaries = {Boundary::Periodic, Boundary::Periodic,
                                                                  Boundary::Periodic}) {
  PackingRequest request;
  request.radii = radii.empty() ? std::vector<double>(static_cast<std::size_t>(n), 1.0) : radii;
  request.packingFraction = phi;
  request.seed = seed;
  request.boundaries = boundaries;
  return randomSequentialAddition(request);
}

EventCounts runUntil(HardSphereSystem& system, double time) { return system.run(1'000'000'000, time - system.time()); }

TEST(HardSphereSystem, TwoSpheresHeadOn) {
  // Radii 0.5 at x = 2 and 5 closing at 2: gap 2, contact at t = 1; equal masses swap velocities.
  const Box box = Box::cubic(10.0, Boundary::Periodic);
  HardSphereSystem system(box, columns({{2, 5, 5}, {5, 5, 5}}), Eigen::Vector2d(0.5, 0.5),
                          columns({{1, 0, 0}, {-1, 0, 0}}));
  const Event first = system.nextEvent();
  // The first event may be a neighbourhood exit or check; run to just past the collision.
  (void)first;
  const EventCounts c = system.run(1);
  EXPECT_EQ(c.collisions, 1);
  EXPECT_NEAR(system.time(), 1.0, 1e-14);
  const Eigen::Matrix3Xd v = system.velocities();
  EXPECT_NEAR(v(0, 0), -1.0, 1e-14);
  EXPECT_NEAR(v(0, 1), 1.0, 1e-14);
  const Eigen::Matrix3Xd x = system.positions();
  EXPECT_NEAR(x(0, 1) - x(0, 0), 1.0, 1e-14);
  system.validate();
}

TEST(HardSphereSystem, TwoGrowingSpheresAtRest) {
  // Radii 0.5 growing at the relative rate g: contact when (1 + g t) = 3, t = 2/g. At rest, the growth
  // alone closes the gap at sd = g (0.5 + 0.5); the elastic rule sends them apart with surface speed sd,
  // i.e. each centre at sd (relative speed 2 sd).
  const double g = 0.25;
  const Box box = Box::cubic(12.0, Boundary::Periodic);
  HardSphereSystem system(box, columns({{3, 6, 6}, {6, 6, 6}}), Eigen::Vector2d(0.5, 0.5),
                          Eigen::Matrix3Xd::Zero(3, 2));
  system.setGrowthRate(g);
  const EventCounts c = system.run(1);
  ASSERT_EQ(c.collisions, 1);
  EXPECT_NEAR(system.time(), 2.0 / g, 1e-12);
  const double sd = g * 1.0;
  const Eigen::Matrix3Xd v = system.velocities();
  EXPECT_NEAR(v(0, 0), -sd, 1e-14);
  EXPECT_NEAR(v(0, 1), sd, 1e-14);
  // Radii at contact: 1.5 each.
  EXPECT_NEAR(system.radii()[0], 1.5, 1e-14);
  system.validate();
}

TEST(HardSphereSystem, ThreeSphereCradle) {
  // A (x = 1) moves at 1 towards B (x = 3) and C (x = 5), radii 0.5: A hits B at t = 1, B hits C at t = 2;
  // then only C moves, at 1.
  const Box box = Box::cubic(20.0, Boundary::Periodic);
  HardSphereSystem system(box, columns({{1, 10, 10}, {3, 10, 10}, {5, 10, 10}}), Eigen::Vector3d(0.5, 0.5, 0.5),
                          columns({{1, 0, 0}, {0, 0, 0}, {0, 0, 0}}));
  system.run(1);
  EXPECT_NEAR(system.time(), 1.0, 1e-14);
  system.run(1);
  EXPECT_NEAR(system.time(), 2.0, 1e-14);
  const Eigen::Matrix3Xd v = system.velocities();
  EXPECT_NEAR(v(0, 0), 0.0, 1e-14);
  EXPECT_NEAR(v(0, 1), 0.0, 1e-14);
  EXPECT_NEAR(v(0, 2), 1.0, 1e-14);
  // Nothing else happens: C flies off (periodically it would come back after 20 - ... at t = 2 + 13).
  runUntil(system, 10.0);
  EXPECT_EQ(system.counts().collisions, 2);
  system.validate();
}

TEST(HardSphereSystem, CollisionThroughThePeriodicBoundary) {
  // x = 0.6 moving down and x = 9.4 moving up in a box of 10: gap through the boundary 0.2, closing at 2.
  const Box box = Box::cubic(10.0, Boundary::Periodic);
  HardSphereSystem system(box, columns({{0.6, 5, 5}, {9.4, 5, 5}}), Eigen::Vector2d(0.5, 0.5),
                          columns({{-1, 0, 0}, {1, 0, 0}}));
  system.run(1);
  EXPECT_NEAR(system.time(), 0.1, 1e-14);
  EXPECT_NEAR(system.velocities()(0, 0), 1.0, 1e-14);
  // Positions stay wrapped into [0, L).
  runUntil(system, 7.3);
  const Eigen::Matrix3Xd x = system.positions();
  EXPECT_TRUE((x.array() >= 0.0).all() && (x.array() < 10.0).all());
  system.validate();
}

TEST(HardSphereSystem, HardWalls) {
  // One sphere of radius 0.5 between walls at 0 and 4 along x: bounces every (4 - 1) / 1 = 3.
  const Box box(Eigen::Vector3d(4.0, 10.0, 10.0), {Boundary::Wall, Boundary::Periodic, Boundary::Periodic});
  HardSphereSystem system(box, columns({{2, 5, 5}}), Eigen::VectorXd::Constant(1, 0.5), columns({{1, 0, 0}}));
  runUntil(system, 1.5 + 3.0 * 10 + 0.1);
  EXPECT_EQ(system.counts().wallCollisions, 11);
  EXPECT_NEAR(std::abs(system.velocities()(0, 0)), 1.0, 1e-14);
  EXPECT_NEAR(system.kineticEnergy(), 0.5 * system.masses()[0], 1e-14);
  // A sphere may not start through a wall.
  EXPECT_THROW(HardSphereSystem(box, columns({{0.2, 5, 5}}), Eigen::VectorXd::Constant(1, 0.5), columns({{1, 0, 0}})),
               ConfigError);
}

TEST(HardSphereSystem, WallsContainAGrowingGas) {
  const Configuration c = randomPacking(150, 0.3, 4, {}, {Boundary::Wall, Boundary::Wall, Boundary::Periodic});
  HardSphereSystem system(c.box, c.position, c.radius, randomVelocities(150, 4));
  system.setGrowthRate(0.002);
  for (int block = 0; block < 10; ++block) {
    system.run(3000);
    system.validate(1e-10);
    system.setThermalSpeed(1.0);
  }
  EXPECT_GT(system.counts().wallCollisions, 0);
  EXPECT_GT(system.packingFraction(), 0.33);
  const Eigen::Matrix3Xd x = system.positions();
  const Eigen::VectorXd r = system.radii();
  for (Index i = 0; i < 150; ++i) {
    for (int k = 0; k < 2; ++k) {
      EXPECT_GE(x(k, i) - r[i], -1e-12);
      EXPECT_GE(c.box.length(k) - x(k, i) - r[i], -1e-12);
    }
  }
}

TEST(HardSphereSystem, ConservesEnergyAndMomentumWithoutGrowth) {
  const Index n = 300;
  const Configuration c = randomPacking(n, 0.3, 11);
  HardSphereSystem system(c.box, c.position, c.radius, randomVelocities(n, 11));
  const double k0 = system.kineticEnergy();
  const Eigen::Vector3d p0 = system.momentum();
  const EventCounts counts = system.run(200'000);
  EXPECT_EQ(counts.collisions, 200'000);
  EXPECT_GT(counts.exits, 0);
  system.validate(1e-12);
  // Tracked and recomputed energy both conserved to round-off.
  EXPECT_NEAR(system.kineticEnergy() / k0, 1.0, 1e-12);
  system.synchronise();
  EXPECT_NEAR(system.kineticEnergy() / k0, 1.0, 1e-12);
  EXPECT_LT((system.momentum() - p0).norm(), 1e-11 * std::sqrt(2.0 * k0 * n));
  EXPECT_LT(system.maxOverlapSeen(), 1e-13);
}

TEST(HardSphereSystem, EventTimesNeverDecrease) {
  const Index n = 200;
  const Configuration c = randomPacking(n, 0.3, 5);
  HardSphereSystem system(c.box, c.position, c.radius, randomVelocities(n, 5));
  system.setGrowthRate(0.01);
  double last = system.time();
  for (int k = 0; k < 50'000; ++k) {
    ASSERT_TRUE(system.step());
    ASSERT_GE(system.time(), last);
    last = system.time();
    if (k % 10'000 == 0) system.validate(1e-10);
  }
}

TEST(HardSphereSystem, PolydisperseGrowthKeepsInvariants) {
  // Uniform-volume-like radii 1..5, fast growth, global rebuilds and exits: all invariants hold.
  const Index n = 400;
  std::vector<double> radii(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) radii[static_cast<std::size_t>(i)] = 1.0 / std::sqrt(1.0 - 0.96 * (i + 0.5) / n);
  const Configuration c = randomPacking(n, 0.3, 9, radii);
  HardSphereSystem system(c.box, c.position, c.radius, randomVelocities(n, 9));
  const Eigen::VectorXd r0 = system.radii();
  system.setGrowthRate(0.05);
  for (int block = 0; block < 20; ++block) {
    system.run(5000);
    system.validate(1e-10);
    system.setThermalSpeed(1.0);
  }
  EXPECT_GT(system.counts().rebuilds, 1);
  EXPECT_GT(system.packingFraction(), 0.4);
  // Growth keeps the size distribution's shape: every radius scaled by the same factor.
  const Eigen::VectorXd ratio = system.radii().array() / r0.array();
  EXPECT_NEAR(ratio.maxCoeff() / ratio.minCoeff(), 1.0, 1e-12);
}

TEST(HardSphereSystem, TrajectoryIndependentOfBroadPhase) {
  const Index n = 250;
  const Configuration c = randomPacking(n, 0.3, 21);
  const Eigen::Matrix3Xd v = randomVelocities(n, 21);
  Eigen::Matrix3Xd reference;
  for (const char* backend : {"hgrid-td", "linked-cell", "brute", "hgrid-bu"}) {
    SCOPED_TRACE(backend);
    SystemOptions options;
    options.broadPhase = backend;
    HardSphereSystem system(c.box, c.position, c.radius, v, options);
    system.setGrowthRate(0.003);
    for (int block = 0; block < 5; ++block) {
      system.run(4000);
      system.setThermalSpeed(1.0);
    }
    if (reference.size() == 0) {
      reference = system.positions();
    } else {
      EXPECT_EQ(system.positions(), reference);
    }
  }
}

// The exit index (SystemOptions::exitIndex) answers every neighbourhood exit and the later global rebuilds:
// any complete backend gives the same sorted lists, so the same trajectory bit for bit, on a wide size
// distribution (many exits) with growth (several global rebuilds).
TEST(HardSphereSystem, TrajectoryIndependentOfExitIndex) {
  const Index n = 300;
  std::vector<double> radii(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) radii[static_cast<std::size_t>(i)] = 1.0 / std::sqrt(1.0 - 0.96 * (i + 0.5) / n);
  const Configuration c = randomPacking(n, 0.3, 23, radii);
  const Eigen::Matrix3Xd v = randomVelocities(n, 23);
  Eigen::Matrix3Xd reference;
  std::int64_t referenceExits = 0;
  for (const char* backend : {"hgrid-dynamic", "brute", "linked-cell", "hgrid-td", "lbvh"}) {
    SCOPED_TRACE(backend);
    SystemOptions options;
    options.exitIndex = backend;
    HardSphereSystem system(c.box, c.position, c.radius, v, options);
    system.setGrowthRate(0.01);
    for (int block = 0; block < 4; ++block) {
      system.run(3000);
      system.setThermalSpeed(1.0);
    }
    if (reference.size() == 0) {
      reference = system.positions();
      referenceExits = system.counts().exits;
      EXPECT_GT(system.counts().rebuilds, 1);
      EXPECT_GT(referenceExits, 100);  // the exits are exercised
    } else {
      EXPECT_EQ(system.positions(), reference);
      EXPECT_EQ(system.counts().exits, referenceExits);
    }
  }
}

TEST(HardSphereSystem, UnknownExitIndexIsAConfigError) {
  const Configuration c = randomPacking(50, 0.2, 3);
  SystemOptions options;
  options.exitIndex = "no-such-backend";
  EXPECT_THROW(HardSphereSystem(c.box, c.position, c.radius, randomVelocities(50, 3), options), ConfigError);
}

// Brute-force reference EDMD: every particle at one common time, the next collision found by testing
// all N^2/2 pairs with the same kinematics (kinematics.hpp) and the same collision rule, no neighbour
// lists, no heap, no lazy invalidation. Radii O_k(t) = O_k(0) (1 + g t), masses ~ O^3, periodic cube.
struct ReferenceCollision {
  Index i, j;
  double time;
};
std::vector<ReferenceCollision> bruteForceCollisions(const Configuration& c, Eigen::Matrix3Xd v, double g,
                                                     int collisions) {
  const Index n = static_cast<Index>(c.radius.size());
  const double length = c.box.length(0);
  Eigen::Matrix3Xd x = c.position;
  const Eigen::VectorXd mass = c.radius.array().cube();
  double t = 0.0;
  std::vector<ReferenceCollision> out;
  auto separation = [&](Index i, Index j, double r[3], double u[3]) {
    for (int k = 0; k < 3; ++k) {
      r[k] = x(k, i) - x(k, j);
      r[k] -= length * std::round(r[k] / length);
      u[k] = v(k, i) - v(k, j);
    }
  };
  while (static_cast<int>(out.size()) < collisions) {
    double best = kNever;
    Index bi = -1, bj = -1;
    for (Index i = 0; i < n; ++i) {
      for (Index j = i + 1; j < n; ++j) {
        double r[3], u[3];
        separation(i, j, r, u);
        const double s0 = c.radius[i] + c.radius[j];
        const double sd = g * s0;
        const double tau = pairCollisionDelay(contactQuadratic(r, u, s0 + sd * t, sd), approachRate(r, u, sd) < 0.0);
        if (tau < best) {
          best = tau;
          bi = i;
          bj = j;
        }
      }
    }
    if (bi < 0) break;
    x += best * v;
    t += best;
    double r[3], u[3];
    separation(bi, bj, r, u);
    const double sd = g * (c.radius[bi] + c.radius[bj]);
    const double dist = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    const double reduced = mass[bi] * mass[bj] / (mass[bi] + mass[bj]);
    const double impulse = collisionImpulse(approachRate(r, u, sd), reduced, 1e-10);
    for (int k = 0; k < 3; ++k) {
      v(k, bi) += impulse / mass[bi] * r[k] / dist;
      v(k, bj) -= impulse / mass[bj] * r[k] / dist;
    }
    out.push_back({bi, bj, t});
  }
  return out;
}

TEST(HardSphereSystem, CollisionSequenceMatchesBruteForceReference) {
  // Exactness of the optimised event loop (neighbour lists, exits, lazy invalidation, prefetching, the
  // heap): the first collisions of a small polydisperse system, with and without growth, are the
  // reference's pairs in the reference's order at the same times. Hard-sphere dynamics is chaotic, so the
  // run is short (~5 collisions per particle) and times agree to 1e-9 relative, not to the last bit.
  const Index n = 64;
  std::vector<double> radii(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) radii[static_cast<std::size_t>(i)] = 0.6 + 0.8 * (i + 0.5) / n;
  const Configuration c = randomPacking(n, 0.35, 31, radii);
  const Eigen::Matrix3Xd v = randomVelocities(n, 31);
  for (double g : {0.0, 0.02}) {
    SCOPED_TRACE(g);
    const int collisions = 160;
    const std::vector<ReferenceCollision> reference = bruteForceCollisions(c, v, g, collisions);
    ASSERT_EQ(static_cast<int>(reference.size()), collisions);
    HardSphereSystem system(c.box, c.position, c.radius, v);
    system.setGrowthRate(g);
    int matched = 0;
    double worst = 0.0;
    while (matched < collisions) {
      const std::int64_t before = system.counts().collisions;
      ASSERT_TRUE(system.step());
      if (system.counts().collisions == before) continue;
      const CollisionRecord& got = system.lastCollision();
      const ReferenceCollision& want = reference[static_cast<std::size_t>(matched)];
      ASSERT_EQ(got.i, want.i) << "collision " << matched;
      ASSERT_EQ(got.j, want.j) << "collision " << matched;
      worst = std::max(worst, std::abs(got.time - want.time) / want.time);
      ++matched;
    }
    EXPECT_LT(worst, 1e-9);
    EXPECT_GT(system.counts().exits, 0);  // the neighbour-list machinery took part
    system.validate(1e-12);
  }
}

// Compare the engine's next `collisions` binary collisions with the brute-force reference started from
// the engine's synchronised state (growth g from now on). Returns the worst relative time difference.
double matchBruteForceFrom(HardSphereSystem& system, double g, int collisions) {
  system.setGrowthRate(g);  // synchronises: radii and positions below are those at the clock origin
  const Configuration now{system.box(), system.positions(), system.radii()};
  const std::vector<ReferenceCollision> reference = bruteForceCollisions(now, system.velocities(), g, collisions);
  EXPECT_EQ(static_cast<int>(reference.size()), collisions);
  const double t0 = system.time();
  int matched = 0;
  double worst = 0.0;
  while (matched < static_cast<int>(reference.size())) {
    const std::int64_t before = system.counts().collisions;
    if (!system.step()) break;
    if (system.counts().collisions == before) continue;
    const CollisionRecord& got = system.lastCollision();
    const ReferenceCollision& want = reference[static_cast<std::size_t>(matched)];
    EXPECT_EQ(got.i, want.i) << "collision " << matched;
    EXPECT_EQ(got.j, want.j) << "collision " << matched;
    if (got.i != want.i || got.j != want.j) return 1.0;
    worst = std::max(worst, std::abs((got.time - t0) - want.time) / want.time);
    ++matched;
  }
  EXPECT_EQ(matched, collisions);
  return worst;
}

// Uniform radius in [0.5, 4] (size ratio 7.97: three classes of the skin rule).
std::vector<double> wideRadii(Index n) {
  std::vector<double> radii(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) radii[static_cast<std::size_t>(i)] = 0.5 + 3.5 * (i + 0.5) / n;
  return radii;
}

TEST(HardSphereSystem, CollisionSequenceMatchesBruteForceWithAdaptedClassSkins) {
  // Exactness with the size-class skins of a wide distribution (issue 24): once the class floors have
  // moved away from their start (skins no longer those of one floor), the next collisions, with and
  // without growth, are still the reference's pairs in its order at its times.
  const Index n = 120;
  const Configuration c = randomPacking(n, 0.3, 41, wideRadii(n));
  HardSphereSystem system(c.box, c.position, c.radius, randomVelocities(n, 41));
  const std::vector<SkinClass> initial = system.skinClasses();
  ASSERT_EQ(initial.size(), 3u);
  for (int block = 0; block < 30; ++block) {
    system.run(10 * std::int64_t{n});
    system.synchronise();
  }
  const std::vector<SkinClass> adapted = system.skinClasses();
  int moved = 0;
  for (std::size_t k = 0; k < adapted.size(); ++k) moved += adapted[k].floor != initial[k].floor;
  EXPECT_GT(moved, 0);
  for (double g : {0.0, 0.02}) {
    SCOPED_TRACE(g);
    const std::int64_t exits = system.counts().exits;
    // The pairs and their order are the exact test; the times of two independent computations drift apart at
    // round-off amplified by the chaos of the 300 collisions per sphere before (1.0e-9 relative on the
    // trajectory since equal event times pop in particle order, session 31; the tolerance was 1e-9).
    EXPECT_LT(matchBruteForceFrom(system, g, 200), 1e-8);
    EXPECT_GT(system.counts().exits, exits);  // the neighbour-list machinery took part
    system.validate(1e-12);
  }
}

// Uniform radius, size ratio 40, at phi 0.35 (N = 1500): the small and mid-size spheres fly far through the
// pores of the large ones. Exits and work per collision (pair predictions + exitWork x exits, the engine's own
// cost model) over 3 blocks of 2 collisions per particle, after 6 such blocks in which the skins settle.
struct SettledCost {
  double exits, work;
};
SettledCost settledCostOfAWideMixture(const SystemOptions& options) {
  const Index n = 1500;
  std::vector<double> radii(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) radii[static_cast<std::size_t>(i)] = 1.0 + 39.0 * (i + 0.5) / n;
  const Configuration c = randomPacking(n, 0.35, 5, radii);
  HardSphereSystem system(c.box, c.position, c.radius, maxwellBoltzmannVelocities(c.radius, 5), options);
  for (int block = 0; block < 6; ++block) {
    system.run(2 * std::int64_t{n});
    system.synchronise();
  }
  const EventCounts before = system.counts();
  const std::int64_t pairs = system.pairPredictions();
  for (int block = 0; block < 3; ++block) {
    system.run(2 * std::int64_t{n});
    system.synchronise();
  }
  const EventCounts d = system.counts() - before;
  const double collisions = static_cast<double>(d.collisions);
  system.validate(1e-10);
  return {static_cast<double>(d.exits) / collisions,
          (static_cast<double>(system.pairPredictions() - pairs) + options.exitWork * static_cast<double>(d.exits)) /
              collisions};
}

TEST(HardSphereSystem, ClassSkinsCutExitsOfAWideDistribution) {
  // Deterministic counters (issue 24). One skin floor for all sizes leaves the mid-size spheres, fast and
  // flying far through the pores of the large ones, with the capped skin of the large ones: several exits per
  // collision. One floor per size class cuts the exits and the work per collision.
  SystemOptions globalFloor, classFloors;
  globalFloor.classSkins = false;
  classFloors.classSkins = true;
  const SettledCost global = settledCostOfAWideMixture(globalFloor), perClass = settledCostOfAWideMixture(classFloors);
  RecordProperty("exits_per_collision_global", std::to_string(global.exits));
  RecordProperty("exits_per_collision_class", std::to_string(perClass.exits));
  std::printf("exits per collision: global %.3f class %.3f; work per collision: global %.1f class %.1f\n", global.exits,
              perClass.exits, global.work, perClass.work);
  // Measured when written: exits 1.56 against 0.87 per collision, work 237 against 145; with the neighbourhood
  // lead (session 16) in both: exits 1.29 against 0.745, work 192 against 118.
  EXPECT_GT(global.exits, 1.0);
  EXPECT_LT(perClass.exits, 0.7 * global.exits);
  EXPECT_LT(perClass.work, 0.8 * global.work);
}

TEST(HardSphereSystem, ExitLeadCutsExitsAndKeepsTheCollisionSequence) {
  // Neighbourhoods re-centred ahead of the sphere (SystemOptions::exitLead): on a wide, dilute mixture the
  // small spheres fly farther than their room between collisions, and a lead cuts their exits; the lists
  // still hold every pair whose neighbourhoods overlap, so the collision sequence is the brute-force one.
  SystemOptions leadOff, leadOn;
  leadOff.exitLead = 0.0;
  leadOn.exitLead = 0.9;
  const double without = settledCostOfAWideMixture(leadOff).exits, with = settledCostOfAWideMixture(leadOn).exits;
  std::printf("exits per collision: lead 0 %.3f, lead up to 0.9 %.3f\n", without, with);
  // Measured when written: 0.872 against 0.745.
  EXPECT_LT(with, 0.92 * without);

  // Exactness with the lead active (size ratio 8, phi 0.3; the lead changes the exit count, so it took part).
  const Index m = 120;
  const Configuration d = randomPacking(m, 0.3, 41, wideRadii(m));
  std::int64_t exitsWithout = 0;
  for (const double lead : {0.0, 0.9}) {
    SCOPED_TRACE(lead);
    SystemOptions options;
    options.exitLead = lead;
    HardSphereSystem system(d.box, d.position, d.radius, randomVelocities(m, 41), options);
    for (int block = 0; block < 10; ++block) {
      system.run(10 * std::int64_t{m});
      system.synchronise();
    }
    if (lead == 0.0) {
      exitsWithout = system.counts().exits;
    } else {
      EXPECT_NE(system.counts().exits, exitsWithout);
    }
    for (double g : {0.0, 0.02}) {
      SCOPED_TRACE(g);
      const std::int64_t exits = system.counts().exits;
      EXPECT_LT(matchBruteForceFrom(system, g, 200), 1e-9);
      EXPECT_GT(system.counts().exits, exits);
      system.validate(1e-12);
    }
  }
}

TEST(HardSphereSystem, NarrowDistributionsHaveOneSkinClass) {
  // Size ratio < 2: one class, so SystemOptions::classSkins changes nothing (bit for bit).
  const Index n = 250;
  std::vector<double> radii(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) radii[static_cast<std::size_t>(i)] = 1.0 + 0.9 * (i % 10) / 9.0;
  const Configuration c = randomPacking(n, 0.35, 12, radii);
  Eigen::Matrix3Xd reference;
  std::int64_t exits = -1;
  for (bool classSkins : {true, false}) {
    SystemOptions options;
    options.classSkins = classSkins;
    HardSphereSystem system(c.box, c.position, c.radius, randomVelocities(n, 12), options);
    EXPECT_EQ(system.skinClasses().size(), 1u);
    system.setGrowthRate(0.003);
    for (int block = 0; block < 5; ++block) {
      system.run(4000);
      system.setThermalSpeed(1.0);
    }
    if (reference.size() == 0) {
      reference = system.positions();
      exits = system.counts().exits;
    } else {
      EXPECT_EQ(system.positions(), reference);
      EXPECT_EQ(system.counts().exits, exits);
    }
  }
}

TEST(HardSphereSystem, PressureMatchesCarnahanStarling) {
  // Monodisperse fluid at phi = 0.45: Z_CS = (1 + phi + phi^2 - phi^3) / (1 - phi)^3 = 9.385.
  const Index n = 500;
  const Configuration c = randomPacking(n, 0.3, 13);
  HardSphereSystem system(c.box, c.position, c.radius, randomVelocities(n, 13));
  CompressionOptions options;
  options.schedule = {{1e-2}};
  options.targetPackingFraction = 0.45;
  const CompressionResult r = compress(system, options);
  EXPECT_EQ(r.stopReason, "packing fraction");
  EXPECT_NEAR(system.packingFraction(), 0.45, 1e-12);
  runAtFixedDensity(system, 50);  // equilibrate
  const EquilibriumRun eq = runAtFixedDensity(system, 400);
  const double phi = 0.45;
  const double cs = (1 + phi + phi * phi - phi * phi * phi) / std::pow(1 - phi, 3);
  EXPECT_NEAR(eq.pressure / cs, 1.0, 0.02);
}

TEST(HardSphereSystem, WatchdogNamesTheParticle) {
  const Index n = 100;
  const Configuration c = randomPacking(n, 0.3, 3);
  SystemOptions options;
  options.watchdogFactor = 0.0;
  options.watchdogSlack = 5;  // absurdly tight: any particle with more than 5 collisions trips it
  HardSphereSystem system(c.box, c.position, c.radius, randomVelocities(n, 3), options);
  try {
    system.run(10'000);
    FAIL() << "expected SimulationError";
  } catch (const SimulationError& e) {
    EXPECT_NE(std::string(e.what()).find("watchdog: particle"), std::string::npos) << e.what();
  }
}

// A system rebuilt from a saved state (constructed in the caller's numbering, then restoreState) continues
// bit for bit: the engine's part of checkpoint/resume. Polydisperse, growing, with resorting and skin
// adaptation on, and saved between global rebuilds (the neighbourhoods carry exit history).
TEST(HardSphereSystem, RestoredStateContinuesBitForBit) {
  std::vector<double> radii(300);
  for (std::size_t i = 0; i < radii.size(); ++i) radii[i] = 1.0 + 2.0 * static_cast<double>(i % 7) / 6.0;
  const Configuration c = randomPacking(300, 0.35, 4, radii);
  SystemOptions options;
  options.resortInterval = 3.0;
  HardSphereSystem a(c.box, c.position, c.radius, randomVelocities(300, 5), options);
  a.setGrowthRate(1e-3);
  a.run(300 * 7);
  const SystemState saved = a.saveState();
  EXPECT_EQ(a.count(), 300);
  // Caller-order arrays from the internal-order state.
  Eigen::Matrix3Xd x(3, 300), v(3, 300);
  Eigen::VectorXd r(300);
  for (std::size_t i = 0; i < 300; ++i) {
    const Index e = static_cast<Index>(saved.external[i]);
    for (std::size_t k = 0; k < 3; ++k) {
      x(static_cast<Index>(k), e) = saved.position[3 * i + k];
      v(static_cast<Index>(k), e) = saved.velocity[3 * i + k];
    }
    r[e] = saved.radius[i];
  }
  HardSphereSystem b(c.box, x, r, v, options);
  b.restoreState(saved);
  b.validate(1e-12);
  for (int block = 0; block < 4; ++block) {
    a.run(300 * 5);
    b.run(300 * 5);
    a.setThermalSpeed(1.0);
    b.setThermalSpeed(1.0);
  }
  const Eigen::Matrix3Xd xa = a.positions(), xb = b.positions();
  const Eigen::Matrix3Xd va = a.velocities(), vb = b.velocities();
  EXPECT_EQ(xa, xb);
  EXPECT_EQ(va, vb);
  EXPECT_EQ(a.radii(), b.radii());
  EXPECT_EQ(a.time(), b.time());
  EXPECT_EQ(a.counts().collisions, b.counts().collisions);
  EXPECT_EQ(a.counts().exits, b.counts().exits);
  EXPECT_EQ(a.counts().rebuilds, b.counts().rebuilds);
  EXPECT_EQ(a.skinFloor(), b.skinFloor());
  EXPECT_EQ(a.pressureWindow().virial, b.pressureWindow().virial);
  // Radii 1..3: two size classes, whose floors and counters travel with the state.
  ASSERT_EQ(a.skinClasses().size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(a.skinClasses()[k].floor, b.skinClasses()[k].floor);
    EXPECT_EQ(a.skinClasses()[k].exits, b.skinClasses()[k].exits);
    EXPECT_EQ(a.skinClasses()[k].scans, b.skinClasses()[k].scans);
  }

  SystemState broken = saved;
  broken.external[0] = broken.external[1];
  EXPECT_THROW(b.restoreState(broken), InputError);
  broken = saved;
  broken.radius.pop_back();
  EXPECT_THROW(b.restoreState(broken), InputError);
  broken = saved;
  broken.classCounters.pop_back();
  EXPECT_THROW(b.restoreState(broken), InputError);
  broken = saved;
  broken.classSkinFloor.push_back(1.0);
  broken.classCounters.resize(broken.classCounters.size() + 8, 0);
  EXPECT_THROW(b.restoreState(broken), InputError);
}

TEST(HardSphereSystem, RejectsBadInput) {
  const Box box = Box::cubic(10.0, Boundary::Periodic);
  // Overlap.
  EXPECT_THROW(
      HardSphereSystem(box, columns({{2, 5, 5}, {2.9, 5, 5}}), Eigen::Vector2d(0.5, 0.5), Eigen::Matrix3Xd::Zero(3, 2)),
      ConfigError);
  // A sphere wider than a quarter of the box: periodic images would be ambiguous.
  EXPECT_THROW(
      HardSphereSystem(box, columns({{5, 5, 5}}), Eigen::VectorXd::Constant(1, 2.6), Eigen::Matrix3Xd::Zero(3, 1)),
      ConfigError);
  // Size mismatch and bad radius.
  EXPECT_THROW(HardSphereSystem(box, columns({{5, 5, 5}}), Eigen::Vector2d(0.5, 0.5), Eigen::Matrix3Xd::Zero(3, 1)),
               ConfigError);
  EXPECT_THROW(
      HardSphereSystem(box, columns({{5, 5, 5}}), Eigen::VectorXd::Constant(1, -1.0), Eigen::Matrix3Xd::Zero(3, 1)),
      ConfigError);
  // The neighbourhood lead outside [0, 0.9] (a lead of 1 would put the sphere on its neighbourhood's surface).
  for (const double lead : {-0.1, 0.95, std::nan("")}) {
    SystemOptions options;
    options.exitLead = lead;
    EXPECT_THROW(HardSphereSystem(box, columns({{5, 5, 5}}), Eigen::VectorXd::Constant(1, 0.5),
                                  Eigen::Matrix3Xd::Zero(3, 1), options),
                 ConfigError)
        << lead;
  }
  // Touching within round-off is fine.
  EXPECT_NO_THROW(
      HardSphereSystem(box, columns({{2, 5, 5}, {3, 5, 5}}), Eigen::Vector2d(0.5, 0.5), Eigen::Matrix3Xd::Zero(3, 2)));
}

}  // namespace
}  // namespace polydem::edmd
