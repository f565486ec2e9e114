// Head-on collisions with the mass-velocity dashpot through DemSimulation: one gamma_n gives every pair
// its own restitution e = exp(-pi zeta / sqrt(1 - zeta^2)), zeta = gamma_n / (2 omega_0), omega_0 =
// sqrt(k / m_eff) (analytic linear spring-dashpot). The predicted dashpot velocity (default) reaches it
// to second order in dt; the half-step velocity (LAMMPS) only to first order.
#include <gtest/gtest.h>

#include <cmath>

#include "integrators/dem_simulation.hpp"
#include "tests/integrators/dem_scenes.hpp"

namespace polydem::integrators {
namespace {

constexpr double kStiffness = 1.0e4;  // N/m, unit-density spheres of radius ~1 m

/// Restitution of a head-on collision of spheres r1, r2 (density 1) with gamma_n, dt = t_c / f.
double restitution(double r1, double r2, double gammaN, double f, DashpotVelocity mode) {
  contact::ContactParameters cp;
  cp.stiffness = kStiffness;
  cp.damping = contact::DampingModel::MassVelocity;
  cp.dampingRate = gammaN;
  const contact::ContactModel model(cp);
  const double m1 = 4.0 / 3.0 * kPi * r1 * r1 * r1, m2 = 4.0 / 3.0 * kPi * r2 * r2 * r2;
  const double meff = 1.0 / (1.0 / m1 + 1.0 / m2), reff = r1 * r2 / (r1 + r2);
  const double speed = model.speedForOverlap(0.01 * std::min(r1, r2), meff, reff);
  const double dt = model.contactDuration(meff, reff, speed) / f;
  test::HeadOn scene = test::headOn(r1, r2, speed, dt, 10.0);
  DemSettings settings;
  settings.contact = cp;
  settings.timeStep = dt;
  settings.spatialSort = false;
  settings.dashpotVelocity = mode;
  DemSimulation sim(std::move(scene.particles), scene.box, settings);
  sim.advance(static_cast<std::int64_t>(4.0 * f) + 20);
  const auto& v = sim.particles().velocity();
  return (v(0, 1) - v(0, 0)) / speed;
}

double analytic(double r1, double r2, double gammaN) {
  const double m1 = 4.0 / 3.0 * kPi * r1 * r1 * r1, m2 = 4.0 / 3.0 * kPi * r2 * r2 * r2;
  const double meff = 1.0 / (1.0 / m1 + 1.0 / m2);
  const double zeta = gammaN / (2.0 * std::sqrt(kStiffness / meff));
  return std::exp(-kPi * zeta / std::sqrt(1.0 - zeta * zeta));
}

TEST(DashpotVelocity, OneGammaGivesEveryPairItsOwnRestitution) {
  const double gammaN = 20.0;  // 1/s: zeta = 0.14 for the (1, 1) pair, 0.51 for (2, 3)
  const double small = analytic(1.0, 1.0, gammaN), large = analytic(2.0, 3.0, gammaN);
  EXPECT_GT(small - large, 0.2);  // not one e for all pairs: that is the restitution dashpot
  EXPECT_NEAR(restitution(1.0, 1.0, gammaN, 50.0, DashpotVelocity::Predicted), small, 2e-3);
  EXPECT_NEAR(restitution(2.0, 3.0, gammaN, 50.0, DashpotVelocity::Predicted), large, 2e-3);
}

TEST(DashpotVelocity, PredictedIsSecondOrderHalfStepFirstOrder) {
  const double gammaN = 20.0, exact = analytic(2.0, 3.0, gammaN);
  const double p50 = std::abs(restitution(2.0, 3.0, gammaN, 50.0, DashpotVelocity::Predicted) - exact);
  const double p100 = std::abs(restitution(2.0, 3.0, gammaN, 100.0, DashpotVelocity::Predicted) - exact);
  const double h50 = std::abs(restitution(2.0, 3.0, gammaN, 50.0, DashpotVelocity::HalfStep) - exact);
  const double h100 = std::abs(restitution(2.0, 3.0, gammaN, 100.0, DashpotVelocity::HalfStep) - exact);
  EXPECT_GT(h50, 3.0 * p50);          // the half-step velocity lags: its dissipation is off by O(zeta omega_0 dt)
  EXPECT_NEAR(h50 / h100, 2.0, 0.4);  // first order
  EXPECT_GT(p50 / p100, 3.0);         // second order (about 4)
}

TEST(DashpotVelocity, ElasticRunsDoNotDependOnTheChoice) {
  EXPECT_EQ(restitution(1.0, 2.0, 0.0, 50.0, DashpotVelocity::Predicted),
            restitution(1.0, 2.0, 0.0, 50.0, DashpotVelocity::HalfStep));
}

}  // namespace
}  // namespace polydem::integrators
