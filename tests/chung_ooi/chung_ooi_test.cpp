// The eight benchmark tests of Chung & Ooi, "Benchmark tests for verifying discrete element modelling
// codes at particle impact level", Granular Matter 13, 643 (2011), run through DemSimulation (one sphere on
// the box's z = 0 wall, or two spheres in a periodic box) with the Hertz normal law and the Hertz-Mindlin
// tangential law, against analytic results. Parameters and tolerances: docs/chung_ooi.md. Materials and the
// set-ups of tests 1-4 are the paper's; those of tests 5-8 are chosen here (stated in the doc).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tests/chung_ooi/impact.hpp"

namespace polydem::chung_ooi {
namespace {

constexpr double kDeg = kPi / 180.0;

/// Tests 1 and 2: the elastic Hertz impact: maximum overlap, maximum force, contact duration, rebound.
void checkElasticNormal(const Impact& s) {
  const Outcome o = run(s);
  const Pair p = pairOf(s);
  const double v = s.a.velocity.z() * -1.0 + (s.b ? s.b->velocity.z() : 0.0);
  EXPECT_NEAR(o.maxOverlap, hertzMaxOverlap(p, v), 2e-3 * hertzMaxOverlap(p, v));
  EXPECT_NEAR(o.maxForce, hertzMaxForce(p, v), 2e-3 * hertzMaxForce(p, v));
  // Counted in whole steps of t_c / 1000: +-2 steps.
  EXPECT_NEAR(o.contactDuration, hertzContactDuration(p, v), 2e-3 * hertzContactDuration(p, v));
  EXPECT_NEAR(o.velocityA.z(), -s.a.velocity.z(), 1e-4 * v);
  if (s.b) {
    EXPECT_NEAR(o.velocityB.z(), -s.b->velocity.z(), 1e-4 * v);
  }
}

TEST(ChungOoi, Test1ElasticNormalImpactOfTwoIdenticalSpheres) {
  for (const Material& m : {kGlass, kLimestone}) {
    SCOPED_TRACE(::testing::Message() << "E = " << m.elastic.youngModulus);
    Impact s{.a = {m, 0.010, Vec3(0, 0, -10.0)}, .b = Body{m, 0.010, Vec3(0, 0, 10.0)}};
    checkElasticNormal(s);
  }
}

TEST(ChungOoi, Test2ElasticNormalImpactOfASphereWithARigidPlane) {
  for (const Material& m : {kAluminiumAlloy, kMagnesiumAlloy}) {
    SCOPED_TRACE(::testing::Message() << "E = " << m.elastic.youngModulus);
    checkElasticNormal(Impact{.a = {m, 0.10, Vec3(0, 0, -0.2)}});
  }
}

TEST(ChungOoi, Test3NormalImpactWithDifferentCoefficientsOfRestitution) {
  for (const Material& m : {kAluminiumOxide, kCastIron}) {
    for (double e : {0.2, 0.4, 0.6, 0.8, 1.0}) {
      SCOPED_TRACE(::testing::Message() << "E = " << m.elastic.youngModulus << ", e = " << e);
      const Outcome o = run(Impact{.a = {m, 0.0025, Vec3(0, 0, -3.9)}, .restitution = e});
      EXPECT_NEAR(o.velocityA.z() / 3.9, e, 5e-3 * e);
    }
  }
}

TEST(ChungOoi, Test4ObliqueImpactAtConstantSpeedAndVaryingIncidentAngle) {
  // Aluminium oxide, R = 2.5 mm, |V| = 3.9 m/s, mu = 0.092, e = 0.98 (the paper's Kharaz et al. set-up).
  const double speed = 3.9, mu = 0.092, e = 0.98, r = 0.0025;
  for (const Material& m : {kAluminiumOxide, kAluminiumAlloy}) {
    for (double deg = 5.0; deg < 90.0; deg += 10.0) {
      SCOPED_TRACE(::testing::Message() << "E = " << m.elastic.youngModulus << ", theta = " << deg);
      const double vt = speed * std::sin(deg * kDeg), vn = speed * std::cos(deg * kDeg);
      const Impact s{.a = {m, r, Vec3(vt, 0, -vn)}, .restitution = e, .friction = mu};
      const Outcome o = run(s);
      EXPECT_NEAR(o.velocityA.z() / vn, e, 5e-3);
      const double et = o.velocityA.x() / vt, spin = o.spinA.y() * r;  // r omega, positive for forward roll
      // Coulomb: the tangential impulse is at most mu times the normal one, (1 + e) m v_n.
      EXPECT_LE(spin, 2.5 * mu * (1.0 + e) * vn * 1.005);
      EXPECT_GE(et, 1.0 - mu * (1.0 + e) * vn / vt - 5e-3);
      if (std::tan(deg * kDeg) > 1.25 * 3.5 * mu * (1.0 + e)) {  // sliding throughout (rigid-body theory)
        EXPECT_NEAR(et, 1.0 - mu * (1.0 + e) * vn / vt, 1e-2);
        EXPECT_NEAR(spin, 2.5 * mu * (1.0 + e) * vn, 1e-2 * 2.5 * mu * (1.0 + e) * vn);
      }
    }
  }
}

/// Tests 5-8: Psi2(Psi1) at the two limits the Maw et al. solution has in closed form, for Psi1 values
/// made by `make(psi1)`: no slip (Psi1 -> 0, here 0.001: Psi2 / Psi1 from the dimensionless no-slip
/// contact within 1%; the Coulomb slip at the very end, where F_n -> 0 first, fades only as Psi1^(2/3)) and sliding
/// throughout (Psi1 >= 4 chi + 1: Psi2 = Psi1 - 4 chi within 0.02).
template <class Make>
void checkPsiLimits(Make make) {
  const Impact probe = make(1.0);
  const double kappa = kappaOf(probe);
  const double fourChi = 14.0 / 3.0 * kappa;
  {
    const Impact s = make(0.001);
    const Angles a = normalisedAngles(s, run(s));
    EXPECT_NEAR(a.psi1, 0.001, 1e-12);
    EXPECT_NEAR(a.psi2 / a.psi1, noSlipRatio(kappa), 0.01 * std::abs(noSlipRatio(kappa)));
  }
  for (double psi1 : {fourChi + 1.0, fourChi + 3.0, 2.0 * fourChi}) {
    SCOPED_TRACE(::testing::Message() << "Psi1 = " << psi1);
    for (auto law : {contact::TangentialModel::HertzMindlin, contact::TangentialModel::CundallStrack}) {
      Impact s = make(psi1);
      s.tangential = law;
      const Angles a = normalisedAngles(s, run(s));
      EXPECT_NEAR(a.psi2, slidingPsi2(psi1, kappa, 1.0), 0.02);
    }
  }
}

/// tan(theta) = v_ct / v_n of the contact point for a given Psi1.
double tanFor(double psi1, double kappa, double mu) { return psi1 * 3.0 * mu / (2.0 * kappa); }

TEST(ChungOoi, Test5ObliqueImpactWithAPlaneAtConstantNormalAndVaryingTangentialVelocity) {
  // Chosen: aluminium oxide, R = 2.5 mm, v_n = 5 m/s, mu = 0.092, e = 1.
  const double vn = 5.0, mu = 0.092, r = 0.0025;
  const double kappa = 3.0 * (1.0 - 0.23) / (2.0 - 0.23);
  checkPsiLimits([&](double psi1) {
    return Impact{.a = {kAluminiumOxide, r, Vec3(vn * tanFor(psi1, kappa, mu), 0, -vn)}, .friction = mu};
  });
}

TEST(ChungOoi, Test6ImpactWithAPlaneAtConstantNormalAndVaryingAngularVelocity) {
  // Chosen: as test 5 but the contact point moves through the spin alone: v_c = -R omega x n.
  const double vn = 5.0, mu = 0.092, r = 0.0025;
  const double kappa = 3.0 * (1.0 - 0.23) / (2.0 - 0.23);
  auto make = [&](double psi1) {
    const double omega = -vn * tanFor(psi1, kappa, mu) / r;  // omega_y < 0: v_c,x = -r omega_y > 0
    Impact s{.a = {kAluminiumOxide, r, Vec3(0, 0, -vn), Vec3(0, omega, 0)}, .friction = mu};
    return s;
  };
  checkPsiLimits(make);
  // Sliding throughout: the whole tangential impulse mu (1 + e) m v_n goes into the centre's velocity.
  const Outcome o = run(make(20.0));
  EXPECT_NEAR(o.velocityA.x(), -2.0 * mu * vn, 5e-3 * 2.0 * mu * vn);
}

TEST(ChungOoi, Test7ImpactOfTwoIdenticalSpheresWithVaryingTangentialVelocity) {
  // Chosen: glass, R = 10 mm, relative normal speed 0.004 m/s, mu = 0.35, e = 1; the spheres move
  // tangentially at +-v_t / 2. (Slow, because the analytic solution keeps the normal fixed while two
  // sliding spheres turn their line of centres by about 3 d_max tan(theta) / (R_a + R_b) during contact.)
  const double vn = 0.004, mu = 0.35, r = 0.010;
  const double kappa = 3.0 * (1.0 - 0.2) / (2.0 - 0.2);
  auto make = [&](double psi1) {
    const double vt = vn * tanFor(psi1, kappa, mu);
    return Impact{.a = {kGlass, r, Vec3(0.5 * vt, 0, -0.5 * vn)},
                  .b = Body{kGlass, r, Vec3(-0.5 * vt, 0, 0.5 * vn)},
                  .friction = mu};
  };
  checkPsiLimits(make);
  // Symmetry: equal spins, opposite velocities.
  const Outcome o = run(make(3.0));
  EXPECT_NEAR(o.spinA.y(), o.spinB.y(), 1e-9 * std::abs(o.spinA.y()));
  EXPECT_NEAR((o.velocityA + o.velocityB).norm(), 0.0, 1e-12);
}

TEST(ChungOoi, Test8ImpactOfTwoDifferentlySizedSpheresOfDifferentMaterials) {
  // Chosen: a glass sphere (R = 10 mm) on a limestone sphere (R = 20 mm), relative normal speed 0.004 m/s
  // (slow: see test 7), mu = 0.35, e = 1, the pair's E* and G* from both materials (contact.shear_modulus).
  const double vn = 0.004, mu = 0.35;
  auto make = [&](double psi1) {
    Impact s{.a = {kGlass, 0.010, Vec3(0, 0, -0.5 * vn)},
             .b = Body{kLimestone, 0.020, Vec3(0, 0, 0.5 * vn)},
             .friction = mu};
    const double vt = vn * tanFor(psi1, kappaOf(s), mu);
    s.a.velocity.x() = 0.5 * vt;
    s.b->velocity.x() = -0.5 * vt;
    return s;
  };
  checkPsiLimits(make);
  // Linear momentum is conserved; angular momentum about the centre of mass too (spins plus orbit).
  const Impact s = make(3.0);
  const Outcome o = run(s);
  const double ma = s.a.mass(), mb = s.b->mass();
  const Vec3 before = ma * s.a.velocity + mb * s.b->velocity, after = ma * o.velocityA + mb * o.velocityB;
  EXPECT_NEAR((after - before).norm(), 0.0, 1e-12 * ma * vn);
  // Torques on a and b are -a_i n x F_t: their ratio is the lever-arm ratio, so the spins change as
  // R_a / I_a : R_b / I_b (to the overlap's first order: lever arms r - d/2).
  const double ia = 0.4 * ma * 0.010 * 0.010, ib = 0.4 * mb * 0.020 * 0.020;
  EXPECT_NEAR(o.spinA.y() * ia / 0.010, o.spinB.y() * ib / 0.020, 1e-3 * std::abs(o.spinA.y() * ia / 0.010));
}

}  // namespace
}  // namespace polydem::chung_ooi
