// Whole runs: energy and momentum of an elastic gas, identical trajectories for every broad-phase
// backend, for any skin and with or without spatial reordering (contact history carried by id).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "broadphase/registry.hpp"
#include "core/errors.hpp"
#include "core/interrupt.hpp"
#include "integrators/dem_simulation.hpp"
#include "integrators/initial_velocities.hpp"
#include "integrators/soft_compression.hpp"
#include "polydem/config.hpp"
#include "tests/integrators/dem_scenes.hpp"

namespace polydem::integrators {
namespace {

using contact::ContactModel;
using contact::ContactParameters;

ContactParameters linear(double e, double mu = 0.0, double k = 1e4) {
  ContactParameters cp;
  cp.stiffness = k;
  cp.restitution = e;
  cp.friction = mu;
  cp.tangentialDampingRatio = mu > 0.0 ? 0.5 : 0.0;
  return cp;
}

std::vector<double> alternating(int count, double a, double b) {
  std::vector<double> radii;
  for (int i = 0; i < count; ++i) radii.push_back(i % 2 ? a : b);
  return radii;
}

TEST(ElasticGas, EnergyDriftBelow1e4Over1e5StepsAndMomentumConserved) {
  Box box;
  ParticleStore p = test::latticeGas(alternating(27, 1.0, 1.5), 0.1, box, 3);
  const ContactParameters cp = linear(1.0);
  assignImpactVelocities(ContactModel(cp), p, 0.01, 11);
  DemSettings settings;
  settings.contact = cp;
  settings.stability.checkInterval = 1000;
  settings.stability.energyTolerance = 1e-4;
  DemSimulation sim(std::move(p), box, settings);
  ASSERT_TRUE(sim.conservative());
  EXPECT_EQ(sim.kernel().name, "linear+frictionless [no walls, gravity or damping]");
  double speedSum = 0.0;
  for (Index i = 0; i < sim.particles().count(); ++i) {
    speedSum += sim.particles().velocity().col(i).norm() / sim.particles().inverseMass()[i];
  }
  const Eigen::Vector3d p0 = sim.momentum();
  sim.advance(100'000);
  const double drift = std::abs(sim.energies().total() - sim.initialEnergy()) / sim.initialEnergy();
  EXPECT_LT(drift, 1e-4);
  EXPECT_LT((sim.momentum() - p0).norm(), 1e-13 * speedSum);
  EXPECT_GT(sim.rebuilds(), 20) << "the gas should have moved and collided";
}

/// A frictional, damped scene with walls on z and gravity: every feature of the general kernel.
DemSimulation frictionalScene(const std::string& backend, double skin, bool spatialSort, int threads = 1) {
  Box box;
  std::vector<double> radii;
  for (int i = 0; i < 216; ++i) radii.push_back(1.0 + 0.5 * ((i * 37) % 101) / 100.0);  // 1..1.5
  ParticleStore p =
      test::latticeGas(radii, 0.3, box, 5, true, {Boundary::Periodic, Boundary::Periodic, Boundary::Wall});
  const ContactParameters cp = linear(0.6, 0.4);
  assignImpactVelocities(ContactModel(cp), p, 0.05, 7);
  for (Index i = 0; i < p.count(); ++i) p.velocity()(2, i) -= 1.0;  // towards the floor
  DemSettings settings;
  settings.contact = cp;
  settings.broadPhase = backend;
  settings.skin = skin;
  settings.spatialSort = spatialSort;
  settings.gravity = Eigen::Vector3d(0.0, 0.0, -20.0);
  settings.viscousDamping = 0.01;
  settings.stability.checkInterval = 50;
  settings.threads = threads;
  return DemSimulation(std::move(p), box, settings);
}

TEST(Resume, RestoredStateContinuesBitForBit) {
  // Issue 15: a checkpoint (DemState) taken mid-run and restored in a fresh simulation gives the same
  // trajectory as the run that never stopped: friction springs, walls, gravity, damping, rebuilds.
  DemSimulation straight = frictionalScene("linked-cell", 0.1, true);
  DemSimulation first = frictionalScene("linked-cell", 0.1, true);
  straight.advance(400);
  first.advance(173);  // not a multiple of anything: mid-way between rebuilds and checks
  const DemState saved = first.state();
  EXPECT_GT(saved.pairKeys.size(), 0u);
  DemSimulation resumed = DemSimulation::restore(saved, first.settings());
  EXPECT_EQ(resumed.step(), 173);
  EXPECT_EQ(resumed.rebuilds(), first.rebuilds());
  EXPECT_EQ(resumed.dt(), first.dt());
  resumed.advance(227);
  EXPECT_EQ(resumed.step(), straight.step());
  EXPECT_TRUE(resumed.particles().position() == straight.particles().position());
  EXPECT_TRUE(resumed.particles().velocity() == straight.particles().velocity());
  EXPECT_TRUE(resumed.particles().angularVelocity() == straight.particles().angularVelocity());
  EXPECT_EQ(resumed.rebuilds(), straight.rebuilds());
  EXPECT_GT(resumed.pairHistory().activeCount(), 0u);
  EXPECT_TRUE(std::equal(resumed.pairHistory().allValues().begin(), resumed.pairHistory().allValues().end(),
                         straight.pairHistory().allValues().begin(), straight.pairHistory().allValues().end()));
  EXPECT_EQ(resumed.energies().total(), straight.energies().total());
  // Another broad phase rebuilds the same list from the saved build positions.
  DemSettings other = first.settings();
  other.broadPhase = "brute";
  DemSimulation viaBrute = DemSimulation::restore(saved, other);
  viaBrute.advance(227);
  EXPECT_TRUE(viaBrute.particles().position() == straight.particles().position());
}

TEST(Resume, InconsistentStateIsRefused) {
  DemSimulation sim = frictionalScene("linked-cell", 0.1, true);
  sim.advance(50);
  DemState bad = sim.state();
  bad.velocity.resize(3, 3);
  EXPECT_THROW(DemSimulation::restore(bad, sim.settings()), InputError);
  DemState keys = sim.state();
  ASSERT_FALSE(keys.pairKeys.empty());
  keys.pairKeys[0] ^= 1;
  EXPECT_THROW(DemSimulation::restore(keys, sim.settings()), InputError);
}

TEST(Guards, InterruptStopsAdvanceAtAStepBoundary) {
  DemSimulation sim = frictionalScene("linked-cell", 0.1, true);
  requestInterrupt(2);
  EXPECT_EQ(sim.advance(100, true), 1);
  EXPECT_EQ(sim.step(), 1);
  EXPECT_EQ(sim.advance(10), 10);  // without stopOnInterrupt the flag is not looked at
  clearInterrupt();
  EXPECT_EQ(sim.advance(5, true), 5);
}

TEST(Guards, ExplicitDtObeysTheStabilityRuleUnlessAllowed) {
  Box box;
  ParticleStore p = test::latticeGas(std::vector<double>(27, 1.0), 0.2, box, 3);
  DemSettings settings;
  settings.contact = linear(0.5);
  const double tc = DemSimulation(p, box, settings).timeStepChoice().contactDuration;
  settings.timeStep = tc / 4.0;
  try {
    DemSimulation sim(p, box, settings);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("run.dt"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("run.allow_unstable_dt"), std::string::npos) << e.what();
  }
  settings.allowUnstableDt = true;
  EXPECT_NO_THROW(DemSimulation(p, box, settings));
  settings.allowUnstableDt = false;
  settings.timeStep = tc / 5.0;
  EXPECT_NO_THROW(DemSimulation(p, box, settings));
}

TEST(Guards, GravityInAFullyPeriodicBoxIsRefused) {
  Box box;
  ParticleStore p = test::latticeGas(std::vector<double>(27, 1.0), 0.2, box, 3);
  DemSettings settings;
  settings.contact = linear(0.5);
  settings.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  try {
    DemSimulation sim(p, box, settings);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("fully periodic"), std::string::npos) << e.what();
  }
}

TEST(Guards, CoincidentParticlesAreReportedAsCoincident) {
  Box box;
  ParticleStore p = test::latticeGas(std::vector<double>(27, 1.0), 0.2, box, 3);
  p.position().col(5) = p.position().col(4);
  DemSettings settings;
  settings.contact = linear(0.5);
  try {
    DemSimulation sim(p, box, settings);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("coincident"), std::string::npos) << e.what();
  }
}

TEST(SameTrajectory, EveryCompleteBackendMatchesBruteForceBitForBit) {
  DemSimulation reference = frictionalScene("brute", 0.2, true);
  reference.advance(400);
  const contact::ContactStats stats = reference.contactStats();
  EXPECT_GT(stats.contacts, 20u);
  EXPECT_GT(stats.wallContacts, 5u);
  EXPECT_GT(reference.pairHistory().activeCount(), 0u);
  for (const std::string& name : broadphase::backendNames()) {
    if (!broadphase::makeBroadPhase(name)->capabilities().complete) continue;
    SCOPED_TRACE(name);
    DemSimulation sim = frictionalScene(name, 0.2, true);
    sim.advance(400);
    EXPECT_TRUE(sim.particles().position() == reference.particles().position());
    EXPECT_TRUE(sim.particles().velocity() == reference.particles().velocity());
    EXPECT_TRUE(sim.particles().angularVelocity() == reference.particles().angularVelocity());
  }
}

#if POLYDEM_WITH_OPENMP
TEST(SameTrajectory, ThreadCountDoesNotChangeTheTrajectory) {
  // The threaded force loop sums in the serial order and the kicks are per particle, so any
  // thread count reproduces the serial run bit for bit: frictional with walls, gravity and damping
  // (rotation, histories, wall contacts) and a frictionless periodic gas (the lean kernel).
  DemSimulation reference = frictionalScene("linked-cell", 0.1, true);
  reference.advance(400);
  EXPECT_GT(reference.pairHistory().activeCount(), 0u);
  for (int threads : {2, 3}) {
    SCOPED_TRACE(::testing::Message() << threads << " threads");
    DemSimulation sim = frictionalScene("linked-cell", 0.1, true, threads);
    sim.advance(400);
    EXPECT_EQ(sim.rebuilds(), reference.rebuilds());
    EXPECT_TRUE(sim.particles().position() == reference.particles().position());
    EXPECT_TRUE(sim.particles().velocity() == reference.particles().velocity());
    EXPECT_TRUE(sim.particles().angularVelocity() == reference.particles().angularVelocity());
  }
  Box box;
  ParticleStore p = test::latticeGas(alternating(343, 1.0, 1.6), 0.45, box, 4);
  DemSettings settings;
  settings.contact = linear(0.8);
  settings.skin = 0.05;
  assignImpactVelocities(ContactModel(settings.contact), p, 0.03, 5);
  DemSimulation serial(p, box, settings);
  settings.threads = 2;
  DemSimulation threaded(p, box, settings);
  serial.advance(500);
  threaded.advance(500);
  EXPECT_GT(serial.contactStats().contacts, 10u);
  EXPECT_GT(serial.rebuilds(), 3);
  EXPECT_TRUE(serial.particles().position() == threaded.particles().position());
  EXPECT_TRUE(serial.particles().velocity() == threaded.particles().velocity());
}
#else
TEST(SameTrajectory, ThreadsNeedAnOpenMPBuild) {
  EXPECT_THROW(frictionalScene("linked-cell", 0.1, true, 2), ConfigError);
}
#endif

// A step's closing half kick applied in the next step's opening pass runs the separate passes' operations in
// their order, so a run of single-step calls (never joined: each call's last step is not) gives the same bits as
// one call (joined on every step but the check steps and the last): frictionless with the predicted and the
// half-step dashpot velocity, frictional with rotation and springs, viscous damping, walls with gravity, on 1, 2
// and 3 threads, across rebuilds.
TEST(JoinedKicks, OnePassKicksEqualTheSeparatePasses) {
  struct Case {
    const char* name;
    double mu;
    double viscous;
    DashpotVelocity dashpot;
  };
  const Case cases[] = {{"frictionless, predicted", 0.0, 0.0, DashpotVelocity::Predicted},
                        {"frictionless, half step", 0.0, 0.0, DashpotVelocity::HalfStep},
                        {"friction and rotation", 0.4, 0.0, DashpotVelocity::Predicted},
                        {"viscous damping", 0.3, 0.5, DashpotVelocity::Predicted}};
  std::vector<int> threadCounts{1};
  if (POLYDEM_WITH_OPENMP) threadCounts = {1, 2, 3};
  for (const Case& c : cases) {
    for (int threads : threadCounts) {
      SCOPED_TRACE(::testing::Message() << c.name << ", " << threads << " threads");
      auto make = [&] {
        Box box;
        ParticleStore p = test::latticeGas(alternating(1000, 1.0, 1.7), 0.45, box, 9, c.mu > 0.0);
        DemSettings settings;
        settings.contact = linear(0.7, c.mu);
        settings.viscousDamping = c.viscous;
        settings.dashpotVelocity = c.dashpot;
        settings.skin = 0.05;
        settings.threads = threads;
        settings.stability.checkInterval = 37;
        assignImpactVelocities(ContactModel(settings.contact), p, 0.05, 6);
        return DemSimulation(std::move(p), box, settings);
      };
      DemSimulation joined = make();
      DemSimulation separate = make();
      joined.advance(300);
      for (int s = 0; s < 300; ++s) separate.advance(1);
      EXPECT_EQ(joined.times().joinedKicks, 300 - 1 - 300 / 37);  // all but the last and the check steps
      EXPECT_EQ(separate.times().joinedKicks, 0);
      EXPECT_GT(separate.rebuilds(), 3);
      EXPECT_GT(separate.contactStats().contacts, 50u);
      EXPECT_EQ(joined.rebuilds(), separate.rebuilds());
      EXPECT_TRUE(joined.particles().position() == separate.particles().position());
      EXPECT_TRUE(joined.particles().velocity() == separate.particles().velocity());
      if (c.mu > 0.0) {
        EXPECT_TRUE(joined.particles().angularVelocity() == separate.particles().angularVelocity());
        EXPECT_GT(separate.pairHistory().activeCount(), 0u);
        EXPECT_TRUE(std::equal(joined.pairHistory().allValues().begin(), joined.pairHistory().allValues().end(),
                               separate.pairHistory().allValues().begin(), separate.pairHistory().allValues().end()));
      }
      EXPECT_EQ(joined.energies().total(), separate.energies().total());
    }
  }
  // Walls, gravity, friction and damping (the frictional reference scene, check every 50 steps).
  DemSimulation joined = frictionalScene("linked-cell", 0.1, true);
  DemSimulation separate = frictionalScene("linked-cell", 0.1, true);
  joined.advance(200);
  for (int s = 0; s < 200; ++s) separate.advance(1);
  EXPECT_EQ(joined.times().joinedKicks, 200 - 1 - 3);
  EXPECT_GT(separate.contactStats().wallContacts, 0u);
  EXPECT_TRUE(joined.particles().position() == separate.particles().position());
  EXPECT_TRUE(joined.particles().velocity() == separate.particles().velocity());
  EXPECT_TRUE(joined.particles().angularVelocity() == separate.particles().angularVelocity());
}

/// A gas of `count` spheres (radii 1 and 2.5, so that HGrids have two levels), hot enough for frequent
/// rebuilds: large enough (> 4096) for the threaded grid builds, pair searches and CSR fill to run.
DemSimulation largeGas(Index count, const std::string& backend, int threads, bool friction) {
  Box box;
  const Boundary b = friction ? Boundary::Wall : Boundary::Periodic;
  ParticleStore p = test::latticeGas(alternating(count, 1.0, 2.5), 0.3, box, 21, friction, {b, b, b});
  DemSettings settings;
  settings.contact = linear(0.7, friction ? 0.4 : 0.0);
  settings.broadPhase = backend;
  settings.skin = 0.05;
  settings.threads = threads;
  settings.stability.checkInterval = 40;
  assignImpactVelocities(ContactModel(settings.contact), p, 0.05, 4);
  return DemSimulation(std::move(p), box, settings);
}

#if POLYDEM_WITH_OPENMP
TEST(SameTrajectory, ThreadedNeighbourListRebuildsDoNotChangeTheTrajectory) {
  // 5000 spheres: the broad phase's counting sorts and chunked pair search, and the CSR fill with atomic
  // counters, run on several threads at every rebuild, for the grid backends and auto.
  DemSimulation reference = largeGas(5000, "linked-cell", 1, false);
  reference.advance(80);
  EXPECT_GT(reference.rebuilds(), 4);
  EXPECT_GT(reference.contactStats().contacts, 10u);
  for (const auto& [backend, threads] : {std::pair{"linked-cell", 2}, std::pair{"linked-cell", 3},
                                         std::pair{"hgrid-bu", 3}, std::pair{"hgrid-td", 2}, std::pair{"auto", 3}}) {
    SCOPED_TRACE(::testing::Message() << backend << ", " << threads << " threads");
    DemSimulation sim = largeGas(5000, backend, threads, false);
    sim.advance(80);
    EXPECT_EQ(sim.rebuilds(), reference.rebuilds());
    EXPECT_TRUE(sim.particles().position() == reference.particles().position());
    EXPECT_TRUE(sim.particles().velocity() == reference.particles().velocity());
  }
  // Friction, rotation and walls (histories remapped after threaded rebuilds).
  DemSimulation walled = largeGas(5000, "linked-cell", 1, true);
  DemSimulation walledThreaded = largeGas(5000, "hgrid-bu", 3, true);
  walled.advance(80);
  walledThreaded.advance(80);
  EXPECT_GT(walled.pairHistory().activeCount(), 0u);
  EXPECT_GT(walled.contactStats().wallContacts, 0u);
  EXPECT_TRUE(walledThreaded.particles().position() == walled.particles().position());
  EXPECT_TRUE(walledThreaded.particles().angularVelocity() == walled.particles().angularVelocity());
}

TEST(VerletList, ThreadedBuildGivesTheSameListForEveryBackend) {
  Box box;
  std::vector<double> radii;
  for (int i = 0; i < 6000; ++i) radii.push_back(1.0 + 3.0 * ((i * 13) % 17) / 16.0);
  const ParticleStore p =
      test::latticeGas(radii, 0.3, box, 8, false, {Boundary::Periodic, Boundary::Wall, Boundary::Periodic});
  VerletList serial(broadphase::makeBroadPhase("linked-cell"), 3.0);
  serial.build(p.spheres(), box);
  ASSERT_GT(serial.list().pairCount(), 5000u);
  ASSERT_GT(serial.list().wallCount(), 10u);
  for (const std::string& name : broadphase::backendNames()) {
    if (!broadphase::makeBroadPhase(name)->capabilities().complete || name == "brute") continue;
    for (int threads : {2, 5}) {
      SCOPED_TRACE(::testing::Message() << name << ", " << threads << " threads");
      VerletList list(broadphase::makeBroadPhase(name), 3.0);
      list.setThreads(threads);
      list.build(p.spheres(), box);
      EXPECT_EQ(list.list().offset, serial.list().offset);
      EXPECT_EQ(list.list().neighbour, serial.list().neighbour);
      EXPECT_EQ(list.list().wallParticle, serial.list().wallParticle);
      EXPECT_EQ(list.list().wallFace, serial.list().wallFace);
    }
  }
  VerletList list(broadphase::makeBroadPhase("linked-cell"), 3.0);
  EXPECT_THROW(list.setThreads(0), ConfigError);
}
#endif

/// A hot frictional gas in a walled box (no periodic wrap, so thin and thick skins stay bit-identical) whose
/// storage order decays within a few tens of steps: coarse cells of 8 particles, measured every 25 steps.
DemSimulation driftingGas(const std::string& backend, double skin, ResortRule resort, int threads = 1,
                          bool spatialSort = true) {
  Box box;
  std::vector<double> radii;
  for (int i = 0; i < 1000; ++i) radii.push_back(1.0 + 0.5 * ((i * 37) % 101) / 100.0);
  ParticleStore p = test::latticeGas(radii, 0.25, box, 31, true, {Boundary::Wall, Boundary::Wall, Boundary::Wall});
  DemSettings settings;
  settings.contact = linear(0.8, 0.3);
  settings.broadPhase = backend;
  settings.skin = skin;
  settings.resort = resort;
  settings.threads = threads;
  settings.spatialSort = spatialSort;
  settings.stability.checkInterval = 50;
  settings.stability.maxOverlapFraction = 0.5;  // hot: Gaussian tails meet harder than the 8% rule
  assignImpactVelocities(ContactModel(settings.contact), p, 0.08, 5);
  return DemSimulation(std::move(p), box, settings);
}

constexpr ResortRule kEager{.interval = 25, .threshold = 0.05, .cellParticles = 8};

TEST(Resort, DecayedOrderIsRestoredAtFixedStepsWhateverTheSkinBackendOrThreads) {
  DemSimulation thin = driftingGas("linked-cell", 0.02, kEager);
  EXPECT_EQ(thin.orderDecay(), 0.0) << "the start is Morton-sorted";
  const double* positions = thin.particles().position().data();
  thin.advance(400);
  EXPECT_GT(thin.resorts(), 2);
  EXPECT_LE(thin.orderDecay(), kEager.threshold);  // step 400 is a measuring step
  EXPECT_EQ(thin.particles().position().data(), positions) << "re-sorting permutes in place";
  EXPECT_GT(thin.pairHistory().activeCount(), 0u);

  // The decision depends on the step and the state only: a thick skin (fewer rebuilds), another backend
  // and other thread counts re-sort at the same steps and give the same trajectory bit for bit.
  std::vector<std::pair<std::string, DemSimulation>> others;
  others.emplace_back("thick skin", driftingGas("linked-cell", 0.5, kEager));
  others.emplace_back("brute", driftingGas("brute", 0.02, kEager));
  others.emplace_back("hgrid-bu", driftingGas("hgrid-bu", 0.1, kEager));
#if POLYDEM_WITH_OPENMP
  others.emplace_back("3 threads", driftingGas("linked-cell", 0.02, kEager, 3));
#endif
  for (auto& [label, sim] : others) {
    SCOPED_TRACE(label);
    sim.advance(400);
    EXPECT_EQ(sim.resorts(), thin.resorts());
    EXPECT_TRUE(sim.particles().id() == thin.particles().id());
    EXPECT_TRUE(sim.particles().position() == thin.particles().position());
    EXPECT_TRUE(sim.particles().velocity() == thin.particles().velocity());
    EXPECT_TRUE(sim.particles().angularVelocity() == thin.particles().angularVelocity());
  }
  EXPECT_GT(thin.rebuilds(), others[0].second.rebuilds());

  // Without re-sorting the order decays. By id, the run agrees with the re-sorted one to round-off while
  // the hot gas has not yet amplified the changed rounding (any reordering changes the summation order).
  const ResortRule never{.interval = 0, .cellParticles = kEager.cellParticles};
  DemSimulation kept = driftingGas("linked-cell", 0.02, never);
  kept.advance(400);
  EXPECT_EQ(kept.resorts(), 0);
  EXPECT_GT(kept.orderDecay(), 3.0 * kEager.threshold);
  DemSimulation early = driftingGas("linked-cell", 0.02, kEager);
  DemSimulation earlyKept = driftingGas("linked-cell", 0.02, never);
  early.advance(60);
  earlyKept.advance(60);
  ASSERT_GT(early.resorts(), 0);
  const Eigen::Matrix3Xd a = test::positionsById(early.particles());
  const Eigen::Matrix3Xd b = test::positionsById(earlyKept.particles());
  EXPECT_LT((a - b).cwiseAbs().maxCoeff(), 1e-9 * early.box().length(0));

  // spatialSort = false keeps the given order: never re-sorted.
  DemSimulation unsorted = driftingGas("linked-cell", 0.02, kEager, 1, false);
  unsorted.advance(100);
  EXPECT_EQ(unsorted.resorts(), 0);
}

TEST(Resort, ResumedRunReSortsLikeTheUninterruptedOne) {
  DemSimulation straight = driftingGas("linked-cell", 0.1, kEager);
  DemSimulation first = driftingGas("linked-cell", 0.1, kEager);
  straight.advance(400);
  first.advance(187);
  ASSERT_GT(first.resorts(), 0);
  DemSimulation resumed = DemSimulation::restore(first.state(), first.settings());
  resumed.advance(213);
  EXPECT_EQ(first.resorts() + resumed.resorts(), straight.resorts());
  EXPECT_TRUE(resumed.particles().id() == straight.particles().id());
  EXPECT_TRUE(resumed.particles().position() == straight.particles().position());
  EXPECT_TRUE(resumed.particles().angularVelocity() == straight.particles().angularVelocity());
}

TEST(Resort, BadRulesAreRefused) {
  for (const ResortRule& bad : {ResortRule{.interval = -1}, ResortRule{.threshold = -0.1},
                                ResortRule{.threshold = std::nan("")}, ResortRule{.cellParticles = 0}}) {
    EXPECT_THROW(driftingGas("linked-cell", 0.1, bad), ConfigError);
  }
}

TEST(SameTrajectory, SkinChangesRebuildsButNotTheTrajectory) {
  // Forces are summed over the contacts of each canonical CSR row: candidates that are not in contact
  // add nothing, so a thin skin (many rebuilds, history remapped each time) and a thick one (few) give
  // bit-identical runs, which only holds if every frictional spring survives every rebuild.
  DemSimulation thin = frictionalScene("linked-cell", 0.02, true);
  DemSimulation thick = frictionalScene("linked-cell", 0.6, true);
  thin.advance(400);
  thick.advance(400);
  EXPECT_GT(thin.rebuilds(), 3 * thick.rebuilds());
  EXPECT_TRUE(thin.particles().position() == thick.particles().position());
  EXPECT_TRUE(thin.particles().angularVelocity() == thick.particles().angularVelocity());
}

TEST(SameTrajectory, SpatialReorderingKeepsTheContactHistory) {
  // Reordering changes the summation order (so agreement is to round-off, not bitwise) and puts the
  // history keys out of list order (the binary-search remap path).
  DemSimulation sorted = frictionalScene("linked-cell", 0.1, true);
  DemSimulation unsorted = frictionalScene("linked-cell", 0.1, false);
  sorted.advance(400);
  unsorted.advance(400);
  const Eigen::Matrix3Xd a = test::positionsById(sorted.particles());
  const Eigen::Matrix3Xd b = test::positionsById(unsorted.particles());
  EXPECT_LT((a - b).cwiseAbs().maxCoeff(), 1e-9 * sorted.box().length(0));
  const Eigen::Matrix3Xd va = test::velocitiesById(sorted.particles());
  const Eigen::Matrix3Xd vb = test::velocitiesById(unsorted.particles());
  EXPECT_LT((va - vb).cwiseAbs().maxCoeff(), 1e-7 * va.cwiseAbs().maxCoeff());
}

TEST(SameTrajectory, GeneralKernelMatchesTheSpecialisedOneWithoutFriction) {
  Box box;
  ParticleStore p = test::latticeGas(alternating(125, 1.0, 2.0), 0.3, box, 2, true);
  const ContactParameters cp = linear(0.8);
  assignImpactVelocities(ContactModel(cp), p, 0.01, 3);
  DemSettings settings;
  settings.contact = cp;
  DemSimulation lean(p, box, settings);
  settings.generalKernel = true;
  DemSimulation general(p, box, settings);
  EXPECT_NE(lean.kernel().name, general.kernel().name);
  lean.advance(300);
  general.advance(300);
  EXPECT_TRUE(lean.particles().position() == general.particles().position());
  EXPECT_TRUE(lean.particles().velocity() == general.particles().velocity());
}

TEST(VerletList, CsrRowsAreCanonicalForEveryBackend) {
  Box box;
  std::vector<double> radii;
  for (int i = 0; i < 300; ++i) radii.push_back(1.0 + 3.0 * ((i * 13) % 17) / 16.0);
  const ParticleStore p = test::latticeGas(radii, 0.3, box, 8);
  for (const std::string& name : broadphase::backendNames()) {
    if (!broadphase::makeBroadPhase(name)->capabilities().complete) continue;
    SCOPED_TRACE(name);
    VerletList list(broadphase::makeBroadPhase(name), 4.0);
    list.build(p.spheres(), box);
    EXPECT_NO_THROW(list.validate(p.spheres(), box));
    EXPECT_GT(list.list().pairCount(), 100u);
  }
}

// Two levels: a list cut from the outer candidates after the spheres moved (some across a periodic face,
// unwrapped) is the list a broad-phase build gives on the moved state, rows, order and walls, as long as the
// moves stay within the outer margin (outerDrift() <= outer - skin).
TEST(VerletList, RefinedListEqualsTheBuiltOne) {
  // 2600 spheres: enough rows for the threaded build to split them (3 threads: the outer list is counted and
  // filled in three parts); the refined list must not depend on it.
  for (const int threads : {1, 3}) {
    SCOPED_TRACE(threads);
    Box box;
    std::vector<double> radii;
    for (int i = 0; i < 2600; ++i) radii.push_back(1.0 + 3.0 * ((i * 13) % 17) / 16.0);
    ParticleStore p =
        test::latticeGas(radii, 0.45, box, 21, false, {Boundary::Periodic, Boundary::Wall, Boundary::Periodic});
    VerletList twoLevel(broadphase::makeBroadPhase("hgrid-td"), 1.0);
    twoLevel.setThreads(threads);
    twoLevel.setOuterSkin(3.0);
    const Eigen::Matrix3Xd built = p.position();
    twoLevel.build(p.spheres(), box);
    ASSERT_TRUE(twoLevel.twoLevel());
    EXPECT_EQ(twoLevel.outerDrift(p.position()), 0.0);
    std::uint64_t state = 99;
    auto uniform = [&] {
      state = state * 6364136223846793005ULL + 1442695040888963407ULL;
      return static_cast<double>(state >> 11) * 0x1.0p-53;
    };
    for (int round = 0; round < 3; ++round) {
      SCOPED_TRACE(round);
      for (Index i = 0; i < p.count(); ++i) {
        for (int k = 0; k < 3; ++k) {
          double& x = p.position()(k, i);
          const double moved = built(k, i) + 1.1 * (uniform() - 0.5);  // |dx| < 0.96: two < 2 = outer - skin
          x = built(k, i);
          if (box.periodic(k) || (moved - p.radius()[i] > 0.0 && moved + p.radius()[i] < box.length(k))) x = moved;
        }
      }
      ASSERT_LE(twoLevel.outerDrift(p.position()), 2.0);
      twoLevel.refine(p.spheres(), box);
      ParticleStore wrapped = p;
      for (Index i = 0; i < p.count(); ++i) wrapped.position().col(i) = box.wrap(p.position().col(i));
      VerletList oneLevel(broadphase::makeBroadPhase("linked-cell"), 1.0);
      oneLevel.build(wrapped.spheres(), box);
      EXPECT_GT(oneLevel.list().pairCount(), 300u);
      EXPECT_GT(oneLevel.list().wallCount(), 10u);
      EXPECT_EQ(twoLevel.list().offset, oneLevel.list().offset);
      EXPECT_EQ(twoLevel.list().neighbour, oneLevel.list().neighbour);
      EXPECT_EQ(twoLevel.list().wallParticle, oneLevel.list().wallParticle);
      EXPECT_EQ(twoLevel.list().wallFace, oneLevel.list().wallFace);
    }
    EXPECT_EQ(twoLevel.builds(), 1);
    EXPECT_EQ(twoLevel.refines(), 3);
    VerletList one(broadphase::makeBroadPhase("linked-cell"), 1.0);
    EXPECT_THROW(one.setOuterSkin(0.9), ConfigError);
    EXPECT_THROW(one.setOuterSkin(std::nan("")), ConfigError);
    one.build(p.spheres(), box);
    EXPECT_THROW(one.refine(p.spheres(), box), std::logic_error);
  }
}

TEST(VerletList, RebuildsWhenSomeParticleMovedHalfTheSkin) {
  ParticleStore p(1, Features{});
  p.radius() << 1.0;
  p.position().col(0) << 5.0, 5.0, 5.0;
  p.velocity().col(0) << 1.0, 0.0, 0.0;
  DemSettings settings;
  settings.contact = linear(1.0);
  settings.skin = 0.45;
  settings.timeStep = 0.01;
  settings.allowUnstableDt = true;  // issue 15: an explicit dt above t_c,min / 5 needs the opt-out
  DemSimulation sim(std::move(p), Box::cubic(10.0, Boundary::Periodic), settings);
  EXPECT_EQ(sim.rebuilds(), 1);
  sim.advance(100);  // 1.0 travelled: rebuilds after 0.23, 0.46, 0.69, 0.92 (skin / 2 = 0.225)
  EXPECT_EQ(sim.rebuilds(), 1 + 4);
  sim.advance(1000);  // crosses the periodic boundary: wrapped at rebuilds, never far outside
  const double x = sim.particles().position()(0, 0);
  EXPECT_GE(x, 0.0);
  EXPECT_LT(x, 10.0 + 0.225);
}

}  // namespace
}  // namespace polydem::integrators

namespace polydem::integrators {
namespace {

TEST(SoftCompression, ReachesTheTargetWithSmallOverlapsAndKeepsTheSizeShape) {
  Box box;
  std::vector<double> radii;
  for (int i = 0; i < 300; ++i) radii.push_back(1.0 + (i % 3) * 0.5);  // 1, 1.5, 2
  ParticleStore p = test::latticeGas(radii, 0.3, box, 12);
  const double ratioBefore = p.radius().maxCoeff() / p.radius().minCoeff();
  DemSettings settings;
  settings.contact.stiffness = 1e4;
  settings.contact.restitution = 0.5;
  CompressionSettings c;
  c.targetPacking = 0.55;
  c.growthRate = 1e-2;
  c.relaxedOverlap = 0.02;
  const CompressionResult r = softCompress(p, box, settings, c);
  EXPECT_NEAR(r.packingFraction, 0.55, 1e-9);
  EXPECT_LT(r.maxOverlapRatio, 0.02);
  EXPECT_NEAR(p.radius().maxCoeff() / p.radius().minCoeff(), ratioBefore, 1e-12);
  EXPECT_EQ(p.velocity().cwiseAbs().maxCoeff(), 0.0);
  EXPECT_GT(r.growthSteps, 0);
  // The compressed state starts a run without complaint.
  settings.stability.checkInterval = 10;
  DemSimulation sim(p, box, settings);
  EXPECT_NO_THROW(sim.advance(200));
}

TEST(SoftCompression, ResumedFromItsStateContinuesBitForBit) {
  // Issue 15: a compression checkpointed mid-growth and mid-relaxation (DemState + CompressionProgress)
  // ends in exactly the state of the uninterrupted one.
  Box box;
  std::vector<double> radii;
  for (int i = 0; i < 200; ++i) radii.push_back(1.0 + (i % 3) * 0.5);
  const ParticleStore start = test::latticeGas(radii, 0.3, box, 12, true);
  DemSettings settings;
  settings.contact = linear(0.5, 0.3);
  settings.gravity = Eigen::Vector3d(0.0, 0.0, -1.0);  // dropped by the compression (the box is periodic)
  CompressionSettings c;
  c.targetPacking = 0.5;
  c.growthRate = 1e-2;
  c.relaxedOverlap = 0.005;
  SoftCompression straight(start, box, settings, c);
  while (straight.advance()) {
  }
  ASSERT_TRUE(straight.result().reachedTarget) << straight.result().reason;
  ASSERT_GT(straight.progress().relaxSteps, 0);
  for (std::int64_t stopAt : {std::int64_t{140}, straight.progress().growthSteps + 100}) {
    SCOPED_TRACE(stopAt);
    SoftCompression first(start, box, settings, c);
    while (first.progress().steps < stopAt && first.advance()) {
    }
    SoftCompression resumed(first.simulation().state(), settings, c, first.progress());
    while (resumed.advance()) {
    }
    EXPECT_EQ(resumed.progress().steps, straight.progress().steps);
    EXPECT_TRUE(resumed.particles().position() == straight.particles().position());
    EXPECT_TRUE(resumed.particles().radius() == straight.particles().radius());
    EXPECT_TRUE(resumed.particles().inverseMass() == straight.particles().inverseMass());
    EXPECT_EQ(resumed.result().maxOverlapRatio, straight.result().maxOverlapRatio);
  }
}

TEST(SoftCompression, TargetAboveJammingIsReported) {
  Box box;
  ParticleStore p = test::latticeGas(std::vector<double>(64, 1.0), 0.3, box, 12);
  DemSettings settings;
  settings.contact.stiffness = 1e4;
  settings.contact.restitution = 0.5;
  CompressionSettings c;
  c.targetPacking = 0.8;  // far above random close packing of spheres
  c.growthRate = 2e-2;
  c.maxSteps = 20'000;
  settings.stability.maxOverlapFraction = 10.0;
  // Issue 15: no exception any more (the state is worth writing, marked): the result says why.
  const CompressionResult r = softCompress(p, box, settings, c);
  EXPECT_FALSE(r.reachedTarget);
  EXPECT_FALSE(r.interrupted);
  EXPECT_LT(r.packingFraction, 0.8);
  EXPECT_NE(r.reason.find("above jamming"), std::string::npos) << r.reason;
}

}  // namespace
}  // namespace polydem::integrators
