// The Hertz-Mindlin tangential law itself: effective moduli, the incremental force with its Coulomb cap,
// parameter checks naming the key, the kernel it selects, the stored energy, and the scene keys.
#include "contact/hertz_mindlin.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "apps/polydem/relax_scene.hpp"
#include "contact/force_loop.hpp"
#include "core/errors.hpp"
#include "integrators/initial_velocities.hpp"
#include "polydem/config.hpp"
#include "tests/chung_ooi/impact.hpp"
#include "tests/integrators/dem_scenes.hpp"

namespace polydem::contact {
namespace {

using ::testing::HasSubstr;

TEST(HertzMindlin, EffectiveModuliFollowHertzAndMindlin) {
  const ElasticMaterial glass{4.8e10, 0.2}, rigid{std::numeric_limits<double>::infinity(), 0.0};
  const double g = 4.8e10 / 2.4;
  EXPECT_DOUBLE_EQ(glass.shearModulus(), g);
  EXPECT_DOUBLE_EQ(effectiveYoungModulus(glass, glass), 4.8e10 / (2.0 * 0.96));
  EXPECT_DOUBLE_EQ(effectiveShearModulus(glass, glass), g / (2.0 * 1.8));
  EXPECT_DOUBLE_EQ(effectiveYoungModulus(glass, rigid), 4.8e10 / 0.96);
  EXPECT_DOUBLE_EQ(effectiveShearModulus(glass, rigid), g / 1.8);
  // One material, or a sphere on a rigid plane: G* / E* = (1 - nu) / (2 (2 - nu)).
  EXPECT_NEAR(effectiveShearModulus(glass, glass) / effectiveYoungModulus(glass, glass), shearToYoungRatio(0.2), 1e-15);
  EXPECT_NEAR(effectiveShearModulus(glass, rigid) / effectiveYoungModulus(glass, rigid), shearToYoungRatio(0.2), 1e-15);
}

TEST(HertzMindlin, StiffnessRatioFromShearModulusOrPoissonRatio) {
  ContactParameters c;
  c.normal = NormalModel::Hertz;
  c.stiffness = 4.0 / 3.0 * 2.5e10;
  c.tangential = TangentialModel::HertzMindlin;
  c.poissonRatio = 0.2;
  EXPECT_NEAR(mindlinStiffnessRatio(c), 3.0 * 0.8 / 1.8, 1e-15);
  c.poissonRatio.reset();
  c.shearModulus = 2.5e10 * shearToYoungRatio(0.2);
  EXPECT_NEAR(mindlinStiffnessRatio(c), 3.0 * 0.8 / 1.8, 1e-14);  // 8 G* / K
}

TEST(HertzMindlin, IncrementalForceIsCappedAndTheSpringResetToTheLimit) {
  const HertzMindlin::Params p{0.5, 2.0, 0.0};
  const NormalForce nf{10.0, 100.0, 0.0};  // F_n = 10 N, K sqrt(R d) = 100 N/m: k_t = 200 N/m
  const Eigen::Vector3d n(0, 0, 1), v(1.0, 0, 0);
  double spring[3] = {0.0, 0.0, 0.0};
  Eigen::Vector3d f = detail::tangentialForce(p, nf, n, v, v, 1e-3, spring);
  EXPECT_NEAR(f.x(), -0.2, 1e-15);  // dF = -k_t v dt
  f = detail::tangentialForce(p, nf, n, v, v, 1e-3, spring);
  EXPECT_NEAR(f.x(), -0.4, 1e-15);
  f = detail::tangentialForce(p, nf, n, v, v, 1.0, spring);  // would reach -200.4 N: capped at mu F_n
  EXPECT_NEAR(f.x(), -5.0, 1e-12);
  EXPECT_NEAR(spring[0], -5.0, 1e-12);
  // Reversal starts from the limit: the spring does not remember the overshoot.
  f = detail::tangentialForce(p, nf, n, -v, -v, 1e-3, spring);
  EXPECT_NEAR(f.x(), -4.8, 1e-12);
  // A force left out of the tangent plane (the contact turned) is rotated back, keeping its length.
  double tilted[3] = {3.0, 0.0, 4.0};
  f = detail::tangentialForce(p, nf, n, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 1e-3, tilted);
  EXPECT_NEAR(f.x(), 5.0, 1e-12);
  EXPECT_NEAR(f.z(), 0.0, 1e-15);
}

ContactParameters mindlin() {
  ContactParameters c;
  c.normal = NormalModel::Hertz;
  c.stiffness = 1e9;
  c.friction = 0.3;
  c.tangential = TangentialModel::HertzMindlin;
  c.poissonRatio = 0.3;
  return c;
}

std::string error(const ContactParameters& c) {
  try {
    c.validate();
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

TEST(HertzMindlin, ParameterErrorsNameTheKey) {
  EXPECT_EQ(error(mindlin()), "no error");
  ContactParameters c = mindlin();
  c.normal = NormalModel::Linear;
  EXPECT_THAT(error(c), HasSubstr("contact.tangential = \"hertz-mindlin\" needs contact.law = \"hertz\""));
  c = mindlin();
  c.poissonRatio.reset();
  EXPECT_THAT(error(c), HasSubstr("needs exactly one of contact.shear_modulus"));
  c.shearModulus = 1e9;
  c.poissonRatio = 0.3;
  EXPECT_THAT(error(c), HasSubstr("needs exactly one of contact.shear_modulus"));
  c = mindlin();
  c.poissonRatio = 0.7;
  EXPECT_THAT(error(c), HasSubstr("contact.poisson_ratio must be in [0, 0.5]"));
  c.poissonRatio = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT(error(c), HasSubstr("contact.poisson_ratio must be a finite number"));
  c = mindlin();
  c.poissonRatio.reset();
  c.shearModulus = -1.0;
  EXPECT_THAT(error(c), HasSubstr("contact.shear_modulus must be > 0"));
  c = mindlin();
  c.tangential = TangentialModel::CundallStrack;
  EXPECT_THAT(error(c), HasSubstr("contact.poisson_ratio applies to contact.tangential = \"hertz-mindlin\" only"));
}

TEST(HertzMindlin, SelectsItsOwnKernelOnlyWithFriction) {
  const ContactModel model(mindlin());
  const ForceKernel k = selectForceKernel(model, KernelFlags{.walls = true});
  EXPECT_EQ(k.name, "hertz+hertz-mindlin [walls]");
  EXPECT_TRUE(k.rotation);
  EXPECT_EQ(k.historyWidth, 3);
  EXPECT_EQ(selectForceKernel(model, KernelFlags{}, true).name, "hertz+hertz-mindlin [walls gravity viscous]");
  ContactParameters frictionless = mindlin();
  frictionless.friction = 0.0;
  EXPECT_EQ(selectForceKernel(ContactModel(frictionless), KernelFlags{}).name,
            "hertz+frictionless [no walls, gravity or damping]");
  EXPECT_THAT(ContactModel(mindlin()).parameters().describe(), HasSubstr("hertz-mindlin G* = "));
}

TEST(HertzMindlin, StoredEnergyIsForceSquaredOverTwiceTheStiffness) {
  // Through a sticking oblique impact on the wall, contactStats().elasticEnergy is the Hertz energy plus
  // |F_t|^2 / (2 k_t) of the stored spring force (the history holds a force, not a displacement). (The
  // incremental law is not a potential: with F_t held and k_t rising, |F_t|^2 / (2 k_t) falls, so the total
  // energy is not checked here.)
  using namespace chung_ooi;
  Impact s{.a = {kGlass, 0.01, Vec3(0.04, 0, -0.2)}, .friction = 0.5};
  const Pair pair = pairOf(s);
  integrators::DemSettings settings;
  settings.contact = contactParameters(s);
  settings.timeStep = hertzContactDuration(pair, 0.2) / 1000.0;
  settings.spatialSort = false;
  ParticleStore p(1, Features{.rotation = true});
  p.radius()[0] = 0.01;
  p.setMassesFromDensity(kGlass.density);
  p.position().col(0) << 0.05, 0.05, 0.01 + 5.5 * settings.timeStep * 0.2;
  p.velocity().col(0) = s.a.velocity;
  integrators::DemSimulation sim(
      std::move(p), Box(Vec3::Constant(0.1), {Boundary::Periodic, Boundary::Periodic, Boundary::Wall}), settings);
  const double k = settings.contact.stiffness, ratio = mindlinStiffnessRatio(settings.contact);
  int checked = 0;
  for (int step = 0; step < 1200; ++step) {
    sim.advance(1);
    const ContactStats st = sim.contactStats();
    if (st.wallContacts == 0) continue;
    const double d = sim.particles().radius()[0] - sim.particles().position()(2, 0);
    const integrators::DemState state = sim.state();
    ASSERT_EQ(state.wallValues.size(), 3 * state.wallKeys.size());
    double fsq = 0.0;
    for (std::size_t c = 0; c < state.wallKeys.size(); ++c) {
      for (int q = 0; q < 3; ++q) fsq += state.wallValues[3 * c + q] * state.wallValues[3 * c + q];
    }
    const double expected =
        0.4 * k * std::sqrt(0.01) * std::pow(d, 2.5) + 0.5 * fsq / (ratio * k * std::sqrt(0.01 * d));
    EXPECT_NEAR(st.elasticEnergy, expected, 1e-9 * expected) << "step " << step;
    ++checked;
  }
  EXPECT_GT(checked, 900);
}

/// A Hertz-Mindlin gas falling on a floor: walls on z, gravity, friction, histories remapped at rebuilds.
integrators::DemSimulation mindlinGas(int threads) {
  Box box;
  std::vector<double> radii;
  for (int i = 0; i < 216; ++i) radii.push_back(1.0 + 0.5 * ((i * 37) % 101) / 100.0);
  ParticleStore p =
      test::latticeGas(radii, 0.3, box, 5, true, {Boundary::Periodic, Boundary::Periodic, Boundary::Wall});
  ContactParameters cp = mindlin();
  cp.stiffness = 1e5;
  cp.restitution = 0.7;
  cp.tangentialDampingRatio = 0.5;
  integrators::assignImpactVelocities(ContactModel(cp), p, 0.05, 7);
  for (Index i = 0; i < p.count(); ++i) p.velocity()(2, i) -= 1.0;
  integrators::DemSettings settings;
  settings.contact = cp;
  settings.gravity = Eigen::Vector3d(0.0, 0.0, -20.0);
  settings.threads = threads;
  return integrators::DemSimulation(std::move(p), box, settings);
}

TEST(HertzMindlin, ResumedAndThreadedRunsAreBitIdentical) {
  integrators::DemSimulation straight = mindlinGas(1);
  integrators::DemSimulation first = mindlinGas(1);
  straight.advance(400);
  first.advance(173);
  integrators::DemSimulation resumed = integrators::DemSimulation::restore(first.state(), first.settings());
  resumed.advance(227);
  EXPECT_GT(straight.pairHistory().activeCount(), 0u);
  EXPECT_GT(straight.rebuilds(), 1);
  EXPECT_TRUE(resumed.particles().position() == straight.particles().position());
  EXPECT_TRUE(resumed.particles().angularVelocity() == straight.particles().angularVelocity());
#if POLYDEM_WITH_OPENMP
  integrators::DemSimulation threaded = mindlinGas(2);
  threaded.advance(400);
  EXPECT_TRUE(threaded.particles().position() == straight.particles().position());
  EXPECT_TRUE(threaded.particles().angularVelocity() == straight.particles().angularVelocity());
#endif
}

TEST(HertzMindlin, SceneKeys) {
  const std::string scene = R"(
[particles]
count = 10
[contact]
law = "hertz"
stiffness = 1e9
friction = 0.3
tangential = "hertz-mindlin"
poisson_ratio = 0.25
[run]
steps = 10
)";
  const app::RelaxScene s = app::parseRelaxScene(scene);
  EXPECT_EQ(s.dem.contact.tangential, TangentialModel::HertzMindlin);
  EXPECT_EQ(s.dem.contact.poissonRatio.value_or(-1.0), 0.25);
  auto fails = [&](const std::vector<std::string>& overrides) {
    try {
      app::parseRelaxScene(scene, overrides);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_THAT(fails({"contact.tangential=mindlin"}), HasSubstr("contact.tangential"));
  EXPECT_THAT(fails({"contact.shear_modulus=1e8"}), HasSubstr("needs exactly one of contact.shear_modulus"));
  EXPECT_THAT(fails({"contact.shear_modulus=0"}), HasSubstr("contact.shear_modulus must be > 0"));
  EXPECT_THAT(fails({"contact.tangential_stiffness_ratio=0.5"}),
              HasSubstr("contact.tangential_stiffness_ratio applies to contact.tangential = \"cundall-strack\" only"));
  EXPECT_THAT(fails({"contact.law=linear"}), HasSubstr("needs contact.law = \"hertz\""));
  EXPECT_THAT(fails({"contact.tangential=cundall-strack"}),
              HasSubstr("contact.poisson_ratio applies to contact.tangential = \"hertz-mindlin\" only"));
}

}  // namespace
}  // namespace polydem::contact
