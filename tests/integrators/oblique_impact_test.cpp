// Oblique impact of a sphere on a wall with friction, in the spirit of Chung & Ooi, Granular Matter 13,
// 643 (2011), test 6: rebound velocity and spin against the analytic regimes.
//
// Linear normal spring with e = 1 and a Cundall-Strack spring with k_t / k_n = 2/7 and no tangential
// damping: the tangential contact-point motion then has the effective mass m_t = m / (1 + m r^2 / I)
// = 2m/7 and the same frequency as the normal one, so with impact speed V at angle theta from the
// normal (u = V sin theta, v_n = V cos theta, no initial spin):
//   tan theta <= 7/2 mu  (sticking throughout: k_t xi <= mu k_n d at every instant)
//     the contact-point velocity reverses: v_t' = 3/7 u, r omega' = 10/7 u;
//   tan theta >= 7 mu    (sliding throughout: the contact point never stops)
//     v_t' = u - 2 mu v_n, r omega' = 5 mu v_n.
#include <gtest/gtest.h>

#include <cmath>

#include "integrators/dem_simulation.hpp"

namespace polydem::integrators {
namespace {

struct Rebound {
  double tangentialVelocity;  ///< v_t' / u
  double spin;                ///< r omega' / u
  double normalVelocity;      ///< v_n' / v_n
};

Rebound impact(double tanTheta, double mu) {
  contact::ContactParameters cp;
  cp.stiffness = 1e6;
  cp.restitution = 1.0;
  cp.friction = mu;
  cp.tangentialStiffnessRatio = 2.0 / 7.0;
  const contact::ContactModel model(cp);
  const double r = 1.0, m = 4.0 / 3.0 * kPi;
  const double vn = model.speedForOverlap(1e-3 * r, m, r);  // 0.1% overlap: lever arm ~ r
  const double u = tanTheta * vn;
  const double dt = model.contactDuration(m, r, 0.0) / 50.0;

  ParticleStore p(1, Features{.rotation = true});
  p.radius() << r;
  p.setMassesFromDensity(1.0);
  const double edge = 10.0;
  p.position().col(0) << 0.5 * edge, 0.5 * edge, r + 10.5 * dt * vn;  // touches the floor half-way between steps
  p.velocity().col(0) << u, 0.0, -vn;
  DemSettings settings;
  settings.contact = cp;
  DemSimulation sim(std::move(p),
                    Box(Eigen::Vector3d::Constant(edge), {Boundary::Periodic, Boundary::Periodic, Boundary::Wall}),
                    settings);
  EXPECT_NEAR(sim.dt(), dt, 1e-14 * dt);
  sim.advance(100);  // 10 steps of approach, 50 in contact, then free flight
  EXPECT_EQ(sim.contactStats().wallContacts, 0u);
  const auto& v = sim.particles().velocity();
  const auto& w = sim.particles().angularVelocity();
  return {v(0, 0) / u, r * w(1, 0) / u, v(2, 0) / vn};
}

TEST(ObliqueImpact, StickingRegimeReversesTheContactPointVelocity) {
  const double mu = 0.3;
  for (double tanTheta : {0.5 * mu, 2.0 * mu, 3.4 * mu}) {
    SCOPED_TRACE(::testing::Message() << "tan theta = " << tanTheta);
    const Rebound r = impact(tanTheta, mu);
    EXPECT_NEAR(r.tangentialVelocity, 3.0 / 7.0, 0.02 * 3.0 / 7.0);
    EXPECT_NEAR(r.spin, 10.0 / 7.0, 0.02 * 10.0 / 7.0);
    EXPECT_NEAR(r.normalVelocity, 1.0, 1e-3);
  }
}

TEST(ObliqueImpact, SlidingRegimeLosesTwoMuTimesTheNormalSpeed) {
  const double mu = 0.3;
  for (double tanTheta : {7.5 * mu, 10.0 * mu, 30.0 * mu}) {
    SCOPED_TRACE(::testing::Message() << "tan theta = " << tanTheta);
    const Rebound r = impact(tanTheta, mu);
    const double vt = 1.0 - 2.0 * mu / tanTheta;  // in units of u: v_n / u = 1 / tan theta
    const double spin = 5.0 * mu / tanTheta;
    EXPECT_NEAR(r.tangentialVelocity, vt, 0.02 * vt);
    EXPECT_NEAR(r.spin, spin, 0.02 * spin);
    EXPECT_NEAR(r.normalVelocity, 1.0, 1e-3);
  }
}

TEST(ObliqueImpact, SpinReboundIsMonotoneAcrossTheTransition) {
  // Between 7/2 mu and 7 mu the contact slides, then sticks: no closed form, but r omega' / v_n must
  // rise from 10/7 tan theta (sticking) towards the sliding plateau 5 mu without jumps.
  const double mu = 0.3;
  double previous = 0.0;
  for (double t = 0.5; t <= 12.0; t += 0.5) {
    const double spinPerVn = impact(t * mu, mu).spin * t * mu;
    EXPECT_GE(spinPerVn, previous - 1e-3 * mu);
    EXPECT_LE(spinPerVn, 5.0 * mu * 1.02);
    previous = spinPerVn;
  }
}

}  // namespace
}  // namespace polydem::integrators
