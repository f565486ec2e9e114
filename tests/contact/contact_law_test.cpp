#include "contact/contact_law.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "core/errors.hpp"

namespace polydem::contact {
namespace {

TEST(LinearDamping, RatioInvertsTheRestitutionFormula) {
  for (double e : {0.01, 0.1, 0.5, 0.9, 0.999}) {
    const double zeta = linearDampingRatio(e);
    EXPECT_NEAR(std::exp(-kPi * zeta / std::sqrt(1.0 - zeta * zeta)), e, 1e-14) << "e = " << e;
  }
  EXPECT_EQ(linearDampingRatio(1.0), 0.0);
  EXPECT_EQ(linearDampingRatio(0.0), 1.0);
}

TEST(HertzDampingSolve, ElasticDurationMatchesTheClosedForm) {
  // x'' = -x^(3/2), x'(0) = 1: tau = 2 (5/4)^(2/5) sqrt(pi) Gamma(7/5) / Gamma(9/10).
  const double tau = 2.0 * std::pow(1.25, 0.4) * std::sqrt(kPi) * std::tgamma(1.4) / std::tgamma(0.9);
  const HertzCollision c = integrateHertzCollision(0.0);
  EXPECT_NEAR(c.tau, tau, 1e-6 * tau);
  EXPECT_NEAR(c.restitution, 1.0, 1e-7);
}

TEST(HertzDampingSolve, AlphaReproducesTheRequestedRestitution) {
  double previousAlpha = -1.0;
  for (double e : {0.9, 0.5, 0.1, 0.01}) {
    const HertzDamping d = hertzDamping(e);
    EXPECT_GT(d.alpha, previousAlpha) << "alpha grows as e falls";
    previousAlpha = d.alpha;
    EXPECT_NEAR(integrateHertzCollision(d.alpha).restitution, e, 1e-9) << "e = " << e;
  }
}

TEST(NormalLaws, HertzForceScalesWithOverlapToThe3Over2) {
  const HertzNormal::Params p{2e6, 0.0};
  const double f1 = HertzNormal::force(p, 1e-3, 0.0, 1.0, 0.5).force;
  const double f2 = HertzNormal::force(p, 4e-3, 0.0, 1.0, 0.5).force;
  EXPECT_NEAR(f2 / f1, 8.0, 1e-12);
  EXPECT_NEAR(f1, 2e6 * std::sqrt(0.5) * std::pow(1e-3, 1.5), 1e-12 * f1);
}

TEST(NormalLaws, LinearDampingUsesThePairsReducedMass) {
  const ContactModel model([] {
    ContactParameters p;
    p.stiffness = 1e4;
    p.restitution = 0.5;
    return p;
  }());
  const LinearNormal::Params lp = model.linearParams();
  for (double meff : {1e-3, 1.0, 1e3}) {
    const NormalForce nf = LinearNormal::force(lp, 0.0, 1.0, meff, 1.0);
    EXPECT_NEAR(nf.force, 2.0 * model.zeta() * std::sqrt(meff * 1e4), 1e-12 * nf.force);
  }
}

TEST(ContactModel, DurationsAndOverlapSpeedsAreConsistent) {
  ContactParameters p;
  p.stiffness = 1e4;
  p.restitution = 1.0;
  const ContactModel linear(p);
  EXPECT_NEAR(linear.contactDuration(2.0, 1.0, 0.0), kPi * std::sqrt(2.0 / 1e4), 1e-15);
  // Undamped: the speed for a target overlap and the stiffness for that speed invert each other.
  const double v = linear.speedForOverlap(0.01, 2.0, 0.5);
  EXPECT_NEAR(v, 0.01 * std::sqrt(1e4 / 2.0), 1e-15);
  EXPECT_NEAR(linear.stiffnessForOverlap(0.01, 2.0, 0.5, v), 1e4, 1e-8);
  p.normal = NormalModel::Hertz;
  const ContactModel hertz(p);
  const double vh = hertz.speedForOverlap(0.01, 2.0, 0.5);
  EXPECT_NEAR(hertz.stiffnessForOverlap(0.01, 2.0, 0.5, vh), 1e4, 1e-8);
}

TEST(ContactParameters, OutOfRangeValuesNameTheKey) {
  auto message = [](ContactParameters p) {
    try {
      p.validate();
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  ContactParameters ok;
  ok.stiffness = 1.0;
  EXPECT_EQ(message(ok), "no error");
  ContactParameters p = ok;
  p.stiffness = 0.0;
  EXPECT_NE(message(p).find("contact.stiffness must be > 0"), std::string::npos);
  p = ok;
  p.restitution = -0.1;
  EXPECT_NE(message(p).find("contact.restitution"), std::string::npos);
  p.restitution = 1.5;
  EXPECT_NE(message(p).find("contact.restitution"), std::string::npos);
  p = ok;
  p.friction = -1.0;
  EXPECT_NE(message(p).find("contact.friction"), std::string::npos);
  p = ok;
  p.restitution = std::nan("");
  EXPECT_NE(message(p).find("contact.restitution"), std::string::npos);
  p = ok;
  p.normal = NormalModel::Hertz;
  p.scaling = StiffnessScaling::Radius;
  EXPECT_NE(message(p).find("contact.stiffness_scaling"), std::string::npos);
}

}  // namespace
}  // namespace polydem::contact
