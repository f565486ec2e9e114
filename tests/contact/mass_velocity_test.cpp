// The mass-velocity dashpot (LAMMPS gran/hooke): the law's force, its validation and the contact
// duration, against the analytic linear spring-dashpot (m_eff x'' = -k x - gamma_n m_eff x').
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "contact/contact_law.hpp"
#include "contact/force_loop.hpp"
#include "core/errors.hpp"

namespace polydem::contact {
namespace {

ContactParameters massVelocity(double k, double gammaN) {
  ContactParameters p;
  p.stiffness = k;
  p.damping = DampingModel::MassVelocity;
  p.dampingRate = gammaN;
  return p;
}

std::string configError(const ContactParameters& p) {
  try {
    p.validate();
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

TEST(MassVelocity, ForceIsSpringPlusGammaTimesReducedMassTimesRate) {
  const ContactModel model(massVelocity(2.0e4, 5000.0));
  const double overlap = 1e-5, rate = 0.7, meff = 3e-4, reff = 1e-3;
  const NormalForce f = LinearMassVelocityNormal::force(model.massVelocityParams(), overlap, rate, meff, reff);
  EXPECT_DOUBLE_EQ(f.force, 2.0e4 * overlap + 5000.0 * meff * rate);
  EXPECT_DOUBLE_EQ(f.stiffness, 2.0e4);
  EXPECT_DOUBLE_EQ(f.damping, 5000.0 * meff);
  // Radius scaling as for the restitution dashpot: k_ij = k R_eff; the dashpot does not scale.
  ContactParameters scaled = massVelocity(2.0e7, 5000.0);
  scaled.scaling = StiffnessScaling::Radius;
  const NormalForce g =
      LinearMassVelocityNormal::force(ContactModel(scaled).massVelocityParams(), overlap, rate, meff, reff);
  EXPECT_DOUBLE_EQ(g.force, 2.0e7 * reff * overlap + 5000.0 * meff * rate);
}

TEST(MassVelocity, DampingIsOnlyElasticAtZeroRate) {
  EXPECT_TRUE(massVelocity(1.0, 0.0).elastic());
  EXPECT_FALSE(massVelocity(1.0, 1.0).elastic());
  EXPECT_TRUE(massVelocity(1.0, 1.0).normalDamped());
  ContactParameters restitution;
  restitution.stiffness = 1.0;
  EXPECT_TRUE(restitution.elastic());  // the default is unchanged: e = 1, no dashpot
  restitution.restitution = 0.5;
  EXPECT_TRUE(restitution.normalDamped());
}

TEST(MassVelocity, ContactDurationIsTheDampedHalfPeriod) {
  const double k = 2.0e4, gammaN = 5000.0, meff = 3e-4;
  const ContactModel model(massVelocity(k, gammaN));
  const double omega0 = std::sqrt(k / meff), zeta = gammaN / (2.0 * omega0);
  ASSERT_LT(zeta, 1.0);
  EXPECT_NEAR(model.contactDuration(meff, 1e-3, 0.0), kPi / (omega0 * std::sqrt(1.0 - zeta * zeta)), 1e-15);
  // Overdamped pairs (gamma_n >= 2 omega_0) never end a contact: the undamped half period is used.
  const ContactModel heavy(massVelocity(k, 4.0 * omega0));
  EXPECT_NEAR(heavy.contactDuration(meff, 1e-3, 0.0), kPi / omega0, 1e-15);
}

TEST(MassVelocity, ValidationNamesTheKey) {
  EXPECT_NE(configError(massVelocity(1.0, -1.0)).find("contact.gamma_n must be >= 0"), std::string::npos);
  EXPECT_NE(configError(massVelocity(1.0, std::nan(""))).find("contact.gamma_n"), std::string::npos);
  ContactParameters hertz = massVelocity(1.0, 1.0);
  hertz.normal = NormalModel::Hertz;
  EXPECT_NE(configError(hertz).find("applies to the linear law only"), std::string::npos);
  ContactParameters both = massVelocity(1.0, 1.0);
  both.restitution = 0.5;
  EXPECT_NE(configError(both).find("contact.restitution = 0.5 and contact.damping"), std::string::npos);
  ContactParameters stray;
  stray.stiffness = 1.0;
  stray.dampingRate = 3.0;
  EXPECT_NE(configError(stray).find("contact.gamma_n = 3 applies to contact.damping = \"mass-velocity\" only"),
            std::string::npos);
}

TEST(MassVelocity, KernelIsTheMassVelocityOne) {
  const ContactModel model(massVelocity(1.0, 1.0));
  EXPECT_EQ(selectForceKernel(model, {}).name, "linear(mass-velocity)+frictionless [no walls, gravity or damping]");
  ContactParameters friction = massVelocity(1.0, 1.0);
  friction.friction = 0.5;
  const ForceKernel k = selectForceKernel(ContactModel(friction), {});
  EXPECT_EQ(k.name, "linear(mass-velocity)+cundall-strack [no walls, gravity or damping]");
  EXPECT_TRUE(k.rotation);
  EXPECT_EQ(selectForceKernel(model, {}, true).name, "linear(mass-velocity)+cundall-strack [walls gravity viscous]");
}

TEST(LammpsHistory, SelectedWithFrictionOnLinearLawsOnly) {
  ContactParameters p = massVelocity(1.0, 1.0);
  p.friction = 0.5;
  p.tangential = TangentialModel::LammpsHistory;
  const ForceKernel k = selectForceKernel(ContactModel(p), {});
  EXPECT_EQ(k.name, "linear(mass-velocity)+lammps-history [no walls, gravity or damping]");
  EXPECT_TRUE(k.rotation);
  EXPECT_EQ(k.historyWidth, 3);
  ContactParameters restitution;
  restitution.stiffness = 1.0;
  restitution.restitution = 0.5;
  restitution.friction = 0.5;
  restitution.tangential = TangentialModel::LammpsHistory;
  EXPECT_EQ(selectForceKernel(ContactModel(restitution), {.walls = true}).name, "linear+lammps-history [walls]");
  restitution.friction = 0.0;  // frictionless: no tangential law at all
  EXPECT_EQ(selectForceKernel(ContactModel(restitution), {}).name,
            "linear+frictionless [no walls, gravity or damping]");
  restitution.normal = NormalModel::Hertz;
  EXPECT_NE(configError(restitution).find("contact.tangential = \"lammps-history\" applies to the linear law only"),
            std::string::npos);
}

}  // namespace
}  // namespace polydem::contact
