// The automatic time step, the stability checker, and extreme scenes that must run stably.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "core/errors.hpp"
#include "integrators/dem_simulation.hpp"
#include "integrators/initial_velocities.hpp"
#include "tests/integrators/dem_scenes.hpp"

namespace polydem::integrators {
namespace {

using contact::ContactModel;
using contact::ContactParameters;
using ::testing::HasSubstr;

ContactParameters linear(double k, double e) {
  ContactParameters cp;
  cp.stiffness = k;
  cp.restitution = e;
  return cp;
}

std::string simulationError(DemSimulation& sim, std::int64_t steps) {
  try {
    sim.advance(steps);
  } catch (const SimulationError& e) {
    return e.what();
  }
  return "no error";
}

TEST(TimeStep, SmallestPairSetsDtAndIsNamed) {
  ParticleStore p(4, Features{});
  p.radius() << 3.0, 1.0, 2.0, 1.0;
  p.setMassesFromDensity(1.0);
  const ContactModel model(linear(1e4, 0.5));
  const TimeStepChoice c = chooseTimeStep(model, p, Box::cubic(100.0, Boundary::Periodic), 50.0, 0.0);
  EXPECT_EQ(std::min(c.idA, c.idB), 1);
  EXPECT_EQ(std::max(c.idA, c.idB), 3);
  const double m = 4.0 / 3.0 * kPi;
  EXPECT_NEAR(c.contactDuration, model.contactDuration(0.5 * m, 0.5, 0.0), 1e-15);
  EXPECT_NEAR(c.dt, c.contactDuration / 50.0, 1e-18);
  EXPECT_THAT(c.describe(), HasSubstr("t_c,min / 50"));
}

TEST(TimeStep, WallsCountAsPartnersWithTheParticleMass) {
  ParticleStore p(1, Features{});
  p.radius() << 1.0;
  p.setMassesFromDensity(1.0);
  const ContactModel model(linear(1e4, 1.0));
  const TimeStepChoice c = chooseTimeStep(model, p, Box::cubic(10.0, Boundary::Wall), 50.0, 0.0);
  EXPECT_LT(c.slotB, 0);
  EXPECT_NEAR(c.contactDuration, kPi * std::sqrt(4.0 / 3.0 * kPi / 1e4), 1e-15);
  EXPECT_THAT(c.describe(), HasSubstr("wall"));
}

TEST(TimeStep, BadFactorsAndMissingHertzSpeedAreConfigErrors) {
  ParticleStore p(2, Features{});
  p.radius() << 1.0, 1.0;
  const Box box = Box::cubic(10.0, Boundary::Periodic);
  const ContactModel model(linear(1e4, 1.0));
  try {
    chooseTimeStep(model, p, box, 4.0, 0.0);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("run.dt_factor"));
  }
  ContactParameters hertz = linear(1e4, 1.0);
  hertz.normal = contact::NormalModel::Hertz;
  try {
    chooseTimeStep(ContactModel(hertz), p, box, 50.0, 0.0);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("contact.reference_velocity"));
  }
}

TEST(Scene, FrictionWithoutRotationArraysIsAConfigErrorNamingBoth) {
  Box box;
  ParticleStore p = test::latticeGas(std::vector<double>(8, 1.0), 0.1, box, 1, false);
  DemSettings settings;
  settings.contact = linear(1e4, 0.5);
  settings.contact.friction = 0.3;
  try {
    DemSimulation sim(std::move(p), box, settings);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("contact.friction"));
    EXPECT_THAT(e.what(), HasSubstr("Features::rotation"));
  }
}

TEST(Stability, TooLargeTimeStepIsDetectedWithAHint) {
  Box box;
  ParticleStore p = test::latticeGas(std::vector<double>(64, 1.0), 0.4, box, 2);
  const ContactParameters cp = linear(1e4, 1.0);
  assignImpactVelocities(ContactModel(cp), p, 0.05, 3);
  DemSettings settings;
  settings.contact = cp;
  settings.stability.checkInterval = 10;
  DemSimulation probe(p, box, settings);
  settings.allowUnstableDt = true;  // issue 15: needed for an explicit dt above t_c,min / 5
  settings.timeStep = probe.timeStepChoice().contactDuration / 1.2;  // f = 1.2: omega dt > 2, unstable
  DemSimulation sim(p, box, settings);
  const std::string message = simulationError(sim, 100'000);
  EXPECT_THAT(message, HasSubstr("step "));
  EXPECT_THAT(message, HasSubstr("particle id "));
  // Issue 15: run.dt was given, so the hint names run.dt (run.dt_factor would have no effect).
  EXPECT_THAT(message, HasSubstr("too large for stiffness k = 10000"));
  EXPECT_THAT(message, HasSubstr("run.dt = "));
  EXPECT_THAT(message, HasSubstr("use run.dt <= "));
  EXPECT_THAT(message, ::testing::Not(HasSubstr("wrap periodic")));
}

TEST(Stability, SoftContactsAtHighSpeedAreReportedAsTooSoft) {
  Box box;
  ParticleStore p = test::latticeGas(std::vector<double>(64, 1.0), 0.4, box, 2);
  const ContactParameters cp = linear(1e4, 1.0);
  assignImpactVelocities(ContactModel(cp), p, 0.8, 3);  // 80% overlaps at f = 50
  DemSettings settings;
  settings.contact = cp;
  settings.stability.checkInterval = 5;
  DemSimulation sim(std::move(p), box, settings);
  const std::string message = simulationError(sim, 100'000);
  EXPECT_THAT(message, HasSubstr("of the smaller radius (limit 0.25)"));
  EXPECT_THAT(message, HasSubstr("too soft for the impact speeds"));
}

TEST(Stability, CoincidentCentresAreReportedAsCoincident) {
  // Coincident centres: the contact normal would be 0/0 and the forces NaN. Issue 15: this used to
  // surface as "non-finite velocity" one step later with a time-step hint; it is an input error.
  ParticleStore p(2, Features{});
  p.radius() << 1.0, 1.0;
  p.setMassesFromDensity(1.0);
  p.position().col(0) << 5.0, 5.0, 5.0;
  p.position().col(1) << 5.0, 5.0, 5.0;
  DemSettings settings;
  settings.contact = linear(1e4, 0.5);
  settings.stability.checkInterval = 1;
  try {
    DemSimulation sim(std::move(p), Box::cubic(10.0, Boundary::Periodic), settings);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("coincident"));
    EXPECT_THAT(e.what(), HasSubstr("id 0 and id 1"));
  }
}

TEST(Stability, EnergyGrowthInAnElasticRunIsDetected) {
  Box box;
  ParticleStore p = test::latticeGas(std::vector<double>(64, 1.0), 0.3, box, 4);
  const ContactParameters cp = linear(1e4, 1.0);
  assignImpactVelocities(ContactModel(cp), p, 0.01, 5);
  DemSettings settings;
  settings.contact = cp;
  settings.stepsPerContact = 5.0;
  settings.stability.checkInterval = 10;
  settings.stability.energyTolerance = 1e-9;  // far below velocity Verlet's error at f = 5
  DemSimulation sim(std::move(p), box, settings);
  const std::string message = simulationError(sim, 100'000);
  EXPECT_THAT(message, HasSubstr("total energy grew by"));
  EXPECT_THAT(message, HasSubstr("use run.dt_factor f >= 50"));
}

TEST(Stability, ParticleThroughAWallIsDetected) {
  ParticleStore p(1, Features{});
  p.radius() << 1.0;
  p.setMassesFromDensity(1.0);
  p.position().col(0) << 1.5, 5.0, 5.0;
  p.velocity().col(0) << -1e4, 0.0, 0.0;  // far too fast for k = 1: straight through the wall
  DemSettings settings;
  settings.contact = linear(1.0, 1.0);
  settings.stability.checkInterval = 1;
  DemSimulation sim(std::move(p), Box::cubic(10.0, Boundary::Wall), settings);
  const std::string message = simulationError(sim, 1000);
  EXPECT_THAT(message, HasSubstr("left the walled box through the -x wall"));
}

TEST(Extremes, StiffnessFrom1e2To1e9RunsStablyWithTheAutomaticStep) {
  for (double k : {1e2, 1e5, 1e9}) {
    for (double e : {0.01, 1.0}) {
      SCOPED_TRACE(::testing::Message() << "k = " << k << ", e = " << e);
      Box box;
      std::vector<double> radii;
      for (int i = 0; i < 64; ++i) radii.push_back(1.0 + (i % 4));
      ParticleStore p = test::latticeGas(radii, 0.3, box, 6, false, {Boundary::Wall, Boundary::Wall, Boundary::Wall});
      const ContactParameters cp = linear(k, e);
      assignImpactVelocities(ContactModel(cp), p, 0.01, 8);
      DemSettings settings;
      settings.contact = cp;
      settings.stability.checkInterval = 20;
      DemSimulation sim(std::move(p), box, settings);
      EXPECT_NO_THROW(sim.advance(3000));
      EXPECT_LT(sim.contactStats().maxOverlapRatio, 0.05);
    }
  }
}

/// One big sphere at rest, small ones raining on it from all sides: extreme size ratios.
void rainOnABigSphere(double ratio, double e) {
  const int small = 26;
  ParticleStore p(small + 1, Features{});
  const double big = ratio, edge = 2.0 * big + 20.0;
  p.radius()[0] = big;
  p.position().col(0).setConstant(0.5 * edge);
  Index i = 1;
  for (int a = -1; a <= 1; ++a) {
    for (int b = -1; b <= 1; ++b) {
      for (int c = -1; c <= 1; ++c) {
        if (a == 0 && b == 0 && c == 0) continue;
        const Eigen::Vector3d dir = Eigen::Vector3d(a, b, c).normalized();
        p.radius()[i] = 1.0;
        p.position().col(i) = p.position().col(0) + (big + 1.0 + 2.0) * dir;
        ++i;
      }
    }
  }
  p.setMassesFromDensity(1.0);
  ContactParameters cp = linear(1e5, e);
  cp.scaling = contact::StiffnessScaling::Radius;
  const ContactModel model(cp);
  const double speed = model.speedForOverlap(0.01, 0.5 / p.inverseMass()[1], 0.5);
  for (Index j = 1; j <= small; ++j) {
    p.velocity().col(j) = -speed * (p.position().col(j) - p.position().col(0)).normalized();
  }
  DemSettings settings;
  settings.contact = cp;
  settings.stability.checkInterval = 10;
  DemSimulation sim(std::move(p), Box::cubic(edge, Boundary::Wall), settings);
  const double e0 = sim.energies().total();
  EXPECT_NO_THROW(sim.advance(2000));
  EXPECT_LT(sim.energies().total(), e0 * (1.0 + 1e-3));
  EXPECT_LT(sim.contactStats().maxOverlapRatio, 0.05);
}

TEST(Extremes, SizeRatio100And1000) {
  for (double ratio : {100.0, 1000.0}) {
    for (double e : {0.01, 1.0}) {
      SCOPED_TRACE(::testing::Message() << "ratio " << ratio << ", e = " << e);
      rainOnABigSphere(ratio, e);
    }
  }
}

TEST(Extremes, ParticlesRestingOnAWallUnderGravitySettle) {
  Box box;
  ParticleStore p = test::latticeGas(std::vector<double>(27, 1.0), 0.2, box, 9, false,
                                     {Boundary::Periodic, Boundary::Periodic, Boundary::Wall});
  const double spacing = box.length(0) / 3.0;
  for (Index i = 0; i < p.count(); ++i) {  // three layers of 3 x 3, the first touching the floor
    p.position().col(i) << (i % 3 + 0.5) * spacing, ((i / 3) % 3 + 0.5) * spacing, 1.0 + 2.2 * (i / 9);
  }
  DemSettings settings;
  settings.contact = linear(1e5, 0.3);
  settings.gravity = Eigen::Vector3d(0.0, 0.0, -1.0);
  settings.viscousDamping = 1.0;
  settings.timeStep = 0.0;
  DemSimulation sim(std::move(p), box, settings);
  sim.advance(20'000);
  EXPECT_LT(sim.energies().kinetic, 1e-6);
  const double expected = 4.0 / 3.0 * kPi * 1.0 / 1e5;  // weight / k of one sphere on the wall
  EXPECT_GT(sim.contactStats().wallContacts, 0u);
  EXPECT_LT(sim.contactStats().maxOverlapRatio, 10 * expected);
}

}  // namespace
}  // namespace polydem::integrators

#include "integrators/soft_compression.hpp"

namespace polydem::integrators {
namespace {

TEST(Extremes, DenseAndDiluteRunStablyForNearlyPlasticAndElasticContacts) {
  for (double packing : {0.05, 0.62}) {
    Box box;
    std::vector<double> radii;
    for (int i = 0; i < 216; ++i) radii.push_back(1.0 + 0.5 * (i % 3));
    ParticleStore start = test::latticeGas(radii, std::min(packing, 0.3), box, 21);
    ContactParameters cp = linear(1e4, 0.5);
    if (packing > 0.3) {
      CompressionSettings c;
      c.targetPacking = packing;
      c.growthRate = 1e-2;
      c.relaxedOverlap = 0.02;
      DemSettings compress;
      compress.contact = cp;
      softCompress(start, box, compress, c);
    }
    for (double e : {0.01, 1.0}) {
      SCOPED_TRACE(::testing::Message() << "packing " << packing << ", e = " << e);
      ParticleStore p = start;
      cp.restitution = e;
      assignImpactVelocities(ContactModel(cp), p, 0.01, 3);
      DemSettings settings;
      settings.contact = cp;
      settings.stability.checkInterval = 20;
      DemSimulation sim(std::move(p), box, settings);
      EXPECT_NEAR(sim.packingFraction(), packing, 1e-9);
      EXPECT_NO_THROW(sim.advance(2000));
      EXPECT_LT(sim.contactStats().maxOverlapRatio, 0.05);
      if (packing > 0.3) {
        EXPECT_GT(sim.contactStats().contacts, 100u);
      }
    }
  }
}

}  // namespace
}  // namespace polydem::integrators
