// FIRE minimisation (integrators/fire_minimiser.hpp): known minima, the stopping rule, independence of the
// broad phase, refusal of laws it does not apply to.
#include "integrators/fire_minimiser.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>

#include "broadphase/registry.hpp"
#include "core/errors.hpp"
#include "integrators/fire_descent.hpp"
#include "polydem/config.hpp"
#include "tests/integrators/minimise_scenes.hpp"

namespace polydem::integrators {
namespace {

using test::harmonicSettings;
using test::randomSoftStart;

// Two overlapping spheres in a large periodic box: the minimum is any separated state, energy exactly 0.
TEST(FireMinimiser, OverlappingPairSeparatesToZeroEnergy) {
  for (const auto normal : {contact::NormalModel::Linear, contact::NormalModel::Hertz}) {
    ParticleStore p(2, Features{});
    p.radius() << 0.5, 0.3;
    p.position().col(0) << 5.0, 5.0, 5.0;
    p.position().col(1) << 5.6, 5.1, 5.0;  // overlap 0.8 - 0.608 = 0.19
    p.setMassesFromDensity(1.0);
    p.id() = {0, 1};
    MinimiserSettings s = harmonicSettings();
    s.contact.normal = normal;
    if (normal == contact::NormalModel::Hertz) s.contact.scaling = contact::StiffnessScaling::Constant;
    FireMinimiser m(std::move(p), Box::cubic(10.0, Boundary::Periodic), s);
    EXPECT_GT(m.measure().energy, 0.0);
    const FireResult r = m.minimise();
    EXPECT_TRUE(r.converged);
    EXPECT_EQ(r.stopReason, "no contacts");
    EXPECT_EQ(r.last.energy, 0.0);
    EXPECT_EQ(r.last.contacts, 0u);
    EXPECT_LT(r.iterations, 1000);
  }
}

// A sphere squeezed between two walls closer than its diameter: the minimum is the centre of the gap
// (both wall forces equal), energy 2 x 1/2 k r (r - L/2)^2 for the linear law with R_eff = r.
TEST(FireMinimiser, SphereBetweenWallsFindsTheMiddle) {
  ParticleStore p(1, Features{});
  p.radius() << 1.0;
  p.position().col(0) << 3.0, 3.0, 0.8;  // walls at z = 0 and z = 1.8: overlaps 0.8 / 0.0 -> 0.1 each
  p.setMassesFromDensity(1.0);
  p.id() = {0};
  const Box box({6.0, 6.0, 1.8}, {Boundary::Periodic, Boundary::Periodic, Boundary::Wall});
  MinimiserSettings s = harmonicSettings();
  s.fire.forceTolerance = 1e-12;
  FireMinimiser m(std::move(p), box, s);
  const FireResult r = m.minimise();
  ASSERT_TRUE(r.converged) << r.stopReason;
  EXPECT_NEAR(m.particles().position()(2, 0), 0.9, 1e-12);
  EXPECT_NEAR(r.last.energy, 2.0 * 0.5 * 1.0 * 0.1 * 0.1, 1e-14);
  EXPECT_EQ(r.last.wallContacts, 2u);
  EXPECT_LE(r.last.residual, 1e-12);
}

// A dense random start: converges to the stated residual, the energy falls, forces balance.
TEST(FireMinimiser, DenseStartConvergesToTheTolerance) {
  auto start = randomSoftStart(256, 0.72, 3);
  MinimiserSettings s = harmonicSettings();
  FireMinimiser m(std::move(start.particles), start.box, s);
  const double e0 = m.measure().energy;
  const FireResult r = m.minimise();
  ASSERT_TRUE(r.converged) << r.stopReason << " residual " << r.last.residual;
  EXPECT_EQ(r.stopReason, "converged");
  EXPECT_LE(r.last.residual, s.fire.forceTolerance);
  EXPECT_LT(r.last.energy, e0);
  EXPECT_GT(r.last.contacts, 600u);  // jammed well above phi_J ~ 0.64: z > 6
  // Net force: zero to round-off (the forces are pairwise opposite).
  EXPECT_LT(m.particles().force().rowwise().sum().norm(), 1e-12 * r.last.meanContactForce * 256);
}

// Budget spent: not converged, the residual reached is reported.
TEST(FireMinimiser, IterationBudgetIsReported) {
  auto start = randomSoftStart(128, 0.7, 5);
  MinimiserSettings s = harmonicSettings();
  s.fire.maxIterations = 10;
  FireMinimiser m(std::move(start.particles), start.box, s);
  const FireResult r = m.minimise();
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.stopReason, "iteration budget");
  EXPECT_EQ(r.iterations, 10);
  EXPECT_GT(r.last.residual, s.fire.forceTolerance);
}

// The phase split of a call accounts for its wall time: every part >= 0, list builds timed when some were
// made, and the parts add up to the call as timed from outside (within the time of the timer calls).
// A tolerance below round-off (1e-15 of the mean contact force; the floor is eps L / delta ~ 1e-13 here):
// FIRE ends at the round-off floor, says so and reports the residual it reached, instead of spending the
// iteration budget (the code before ran to the budget and reported "not converged").
TEST(FireMinimiser, ToleranceBelowRoundOffEndsAtTheFloor) {
  auto start = randomSoftStart(300, 0.7, 3);
  MinimiserSettings s = harmonicSettings();
  s.fire.forceTolerance = 1e-15;
  s.fire.maxIterations = 300000;
  FireMinimiser m(std::move(start.particles), start.box, s);
  const FireResult r = m.minimise();
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(r.stopReason, "round-off floor");
  EXPECT_LT(r.iterations, s.fire.maxIterations);
  EXPECT_LE(r.last.stepUlps, 1.0);
  EXPECT_GT(r.last.residual, s.fire.forceTolerance);
  EXPECT_LT(r.last.residual, 1e-10);  // a minimum to round-off, not a state stopped early
  // A reachable tolerance still ends on the tolerance.
  s.fire.forceTolerance = 1e-9;
  auto again = randomSoftStart(300, 0.7, 3);
  FireMinimiser m2(std::move(again.particles), again.box, s);
  EXPECT_EQ(m2.minimise().stopReason, "converged");
}

TEST(FireMinimiser, PhaseSecondsAddUpToTheCall) {
  auto start = randomSoftStart(512, 0.72, 7);
  MinimiserSettings s = harmonicSettings();
  s.skin = 0.01;  // small: the lists are rebuilt during the run
  FireMinimiser m(std::move(start.particles), start.box, s);
  const auto t0 = std::chrono::steady_clock::now();
  const FireResult r = m.minimise();
  const double outside = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_GT(r.rebuilds, 0);
  EXPECT_GT(r.seconds.broadPhase, 0.0);
  EXPECT_GT(r.seconds.force, 0.0);
  EXPECT_GE(r.seconds.update, 0.0);
  EXPECT_GT(r.seconds.measure, 0.0);  // the start and the stop are measured
  EXPECT_LE(r.seconds.total(), outside);
  EXPECT_GT(r.seconds.total(), 0.5 * outside);
}

// The Verlet list is never stale: at every FIRE step, and right after a radius growth, the forces equal
// those of a minimiser built afresh on the same state (a new list and a new force pass). A pair left out of
// the list while it overlaps shows as a force difference of the size of a contact force. Two scenes: the
// worst case of the rebuild rule, two spheres driven head-on (A-B and C-D overlap, so B and C, just more than
// a skin apart, close their gap at the sum of the two largest displacements), and a dense size mixture.
TEST(FireMinimiser, ListsNeverMissAContact) {
  MinimiserSettings s = harmonicSettings();
  s.spatialSort = false;  // the fresh minimiser keeps the order, so forces compare index by index
  s.fire.progressInterval = 1;
  auto staleness = [&](const FireMinimiser& m) {
    ParticleStore p = m.particles();
    FireMinimiser again(std::move(p), m.box(), s);
    const double scale = again.particles().force().cwiseAbs().maxCoeff();
    return (m.particles().force() - again.particles().force()).cwiseAbs().maxCoeff() / scale;
  };
  auto check = [&](const test::SoftStart& start, int steps, double rMax) {
    s.fire.maxIterations = steps;
    FireMinimiser m(start.particles, start.box, s);
    double worst = 0.0;
    std::int64_t checked = 0;
    const FireResult r = m.minimise([&](const MinimiserReport&) {
      worst = std::max(worst, staleness(m));
      ++checked;
    });
    EXPECT_EQ(checked, r.iterations);
    EXPECT_GT(r.rebuilds, 1);                       // rebuilt along the way, not only at the start
    EXPECT_GT(r.rebuilds - r.broadPhaseBuilds, 0);  // and some lists were cut from the outer candidates
    EXPECT_LE(worst, 1e-9);
    // Radii grown by 0.4 skin (of the largest sphere) after some steps: the growth and the displacements
    // since the last build together decide whether the list still holds every contact.
    for (int k = 1; k <= 40; ++k) {
      SCOPED_TRACE(k);
      s.fire.maxIterations = k;
      FireMinimiser grown(start.particles, start.box, s);
      grown.minimise();
      grown.scaleRadii(1.0 + 0.4 * s.skin / rMax);
      EXPECT_LE(staleness(grown), 1e-9);
    }
  };
  {
    SCOPED_TRACE("head-on");
    s.skin = 0.05;
    test::SoftStart line{ParticleStore(4, Features{}), Box::cubic(20.0, Boundary::Periodic)};
    line.particles.radius().setConstant(0.5);
    const double x[4] = {5.0, 5.8, 5.8 + 1.0 + 1.2 * s.skin, 5.8 + 1.8 + 1.2 * s.skin};
    for (int i = 0; i < 4; ++i) line.particles.position().col(i) << x[i], 10.0, 10.0;
    line.particles.setMassesFromDensity(1.0);
    line.particles.id() = {0, 1, 2, 3};
    check(line, 200, 0.5);
  }
  {
    SCOPED_TRACE("mixture");
    s.skin = 0.02;
    std::vector<double> radii(400);
    for (std::size_t i = 0; i < radii.size(); ++i) radii[i] = 0.25 + 0.5 * static_cast<double>(i % 11) / 10.0;
    check(randomSoftStart(static_cast<Index>(radii.size()), 0.70, 13, radii), 600, 0.75);
  }
}

// The minimised state is bit-identical for every complete broad phase: the Verlet list is in canonical
// order, so every backend gives the same force sums and the same FIRE trajectory.
TEST(FireMinimiser, BitIdenticalForEveryBroadPhase) {
  const auto reference = [] {
    auto start = randomSoftStart(200, 0.70, 11);
    FireMinimiser m(std::move(start.particles), start.box, harmonicSettings("brute"));
    const FireResult r = m.minimise();
    EXPECT_TRUE(r.converged);
    return std::make_pair(m.particles().position(), r.iterations);
  }();
  for (const std::string& name : broadphase::backendNames()) {
    SCOPED_TRACE(name);
    auto start = randomSoftStart(200, 0.70, 11);
    FireMinimiser m(std::move(start.particles), start.box, harmonicSettings(name));
    const FireResult r = m.minimise();
    EXPECT_EQ(r.iterations, reference.second);
    ASSERT_EQ(m.particles().position().size(), reference.first.size());
    EXPECT_EQ(std::memcmp(m.particles().position().data(), reference.first.data(),
                          sizeof(double) * static_cast<std::size_t>(reference.first.size())),
              0);
  }
}

// The minimiser's passes run over chunks of 4096 particles, shared out among the threads, with the chunks' sums
// added in chunk order: 9000 spheres (three chunks, the last one short) minimised on 1, 2 and 3 threads give the
// same bytes and the same count, for FIRE and for conjugate gradients. Fails if a chunk's sums are added in the
// order the threads finish.
TEST(FireMinimiser, ThreadCountLeavesTheResultUnchanged) {
  for (const auto method : {MinimiserMethod::Fire, MinimiserMethod::ConjugateGradient}) {
    SCOPED_TRACE(methodName(method));
    const auto run = [method](int threads) {
      auto start = randomSoftStart(9000, 0.70, 4);
      MinimiserSettings s = harmonicSettings("linked-cell");
      s.method = method;
      s.threads = threads;
      if (!POLYDEM_WITH_OPENMP && threads > 1) {  // a build without OpenMP refuses threads, naming the key
        EXPECT_THROW(FireMinimiser(start.particles, start.box, s), ConfigError);
        return std::make_pair(Eigen::Matrix3Xd(), std::int64_t{-1});
      }
      FireMinimiser m(std::move(start.particles), start.box, s);
      m.fireSettings().maxIterations = 400;
      const FireResult r = m.minimise();
      return std::make_pair(Eigen::Matrix3Xd(m.particles().position()), r.iterations);
    };
    const auto reference = run(1);
    EXPECT_EQ(reference.second, 400);
    for (const int threads : {2, 3}) {
      SCOPED_TRACE(threads);
      const auto other = run(threads);
      if (!POLYDEM_WITH_OPENMP) continue;
      EXPECT_EQ(other.second, reference.second);
      EXPECT_EQ(std::memcmp(other.first.data(), reference.first.data(),
                            sizeof(double) * static_cast<std::size_t>(reference.first.size())),
                0);
    }
  }
}

TEST(FireMinimiser, RefusesFrictionAndDashpots) {
  auto start = randomSoftStart(10, 0.3, 1);
  MinimiserSettings s = harmonicSettings();
  s.contact.friction = 0.5;
  EXPECT_THROW(FireMinimiser(start.particles, start.box, s), ConfigError);
  s.contact.friction = 0.0;
  s.contact.restitution = 0.5;
  EXPECT_THROW(FireMinimiser(start.particles, start.box, s), ConfigError);
  s.contact.restitution = 1.0;
  s.fire.forceTolerance = -1.0;
  EXPECT_THROW(FireMinimiser(start.particles, start.box, s), ConfigError);
}

}  // namespace
}  // namespace polydem::integrators

// A centre outside a walled box is named by its cause: the net force before the step pointing out of the box
// (contacts press the particle through the soft wall) or into it (the step overshot).
TEST(FireMinimiser, CentreOutsideAWallNamesItsCause) {
  using polydem::integrators::fire::leftWallMessage;
  const std::string pressedLow = leftWallMessage(7, 0.5, 1, -0.01, 20.0, -3.0);
  EXPECT_NE(pressedLow.find("particle id 7 (r = 0.5) was pressed through the -y wall (y = 0) by its contacts"),
            std::string::npos)
      << pressedLow;
  EXPECT_NE(pressedLow.find("start from a lower --phi0"), std::string::npos) << pressedLow;
  const std::string pressedHigh = leftWallMessage(8, 1.0, 2, 20.25, 20.0, 2.0);
  EXPECT_NE(pressedHigh.find("pressed through the +z wall (z = 20)"), std::string::npos) << pressedHigh;
  EXPECT_NE(pressedHigh.find("0.25 beyond the wall"), std::string::npos) << pressedHigh;
  const std::string overshotLow = leftWallMessage(9, 0.5, 0, -0.125, 20.0, 4.0);
  EXPECT_NE(overshotLow.find("was carried through the -x wall (x = 0) by its velocity: the net force on it pointed "
                             "into the box"),
            std::string::npos)
      << overshotLow;
  EXPECT_NE(overshotLow.find("Lower --dt-max-factor"), std::string::npos) << overshotLow;
  EXPECT_EQ(overshotLow.find("pressed"), std::string::npos) << overshotLow;
  const std::string overshotHigh = leftWallMessage(9, 0.5, 0, 20.5, 20.0, -1.0);
  EXPECT_NE(overshotHigh.find("carried through the +x wall (x = 20) by its velocity"), std::string::npos)
      << overshotHigh;
}
