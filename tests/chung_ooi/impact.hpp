#pragma once
// One impact of the Chung & Ooi benchmark (Granular Matter 13, 643 (2011)) run through the real engine:
// a DemSimulation of one sphere falling onto the z = 0 wall of the box (the rigid plane), or of two
// spheres meeting along z in a periodic box, with the Hertz normal law and a Cundall-Strack or
// Hertz-Mindlin tangential law. Also the analytic results the tests compare with.
//
// Frame: the normal n is +z (from the wall, or from sphere b, towards sphere a); tangential motion is
// along x. The contact-point velocity of a relative to b is v_c = (v_a - v_b) - (R_a w_a + R_b w_b) x n
// (the force kernel's lever arms, to first order in the overlap).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "contact/hertz_mindlin.hpp"
#include "core/box.hpp"
#include "core/particle_store.hpp"
#include "integrators/dem_simulation.hpp"

namespace polydem::chung_ooi {

using Vec3 = Eigen::Vector3d;

/// Materials of the benchmark (E in Pa, nu, density in kg/m^3), as given in Chung & Ooi's tests.
struct Material {
  contact::ElasticMaterial elastic;
  double density;
};
inline constexpr Material kGlass{{4.8e10, 0.20}, 2800.0};
inline constexpr Material kLimestone{{2.0e10, 0.25}, 2500.0};
inline constexpr Material kAluminiumAlloy{{7.0e10, 0.33}, 2700.0};
inline constexpr Material kMagnesiumAlloy{{4.0e10, 0.35}, 1800.0};
inline constexpr Material kAluminiumOxide{{3.8e11, 0.23}, 4000.0};
inline constexpr Material kCastIron{{1.0e11, 0.25}, 7000.0};

struct Body {
  Material material;
  double radius;  ///< m
  Vec3 velocity = Vec3::Zero();
  Vec3 spin = Vec3::Zero();  ///< angular velocity (rad/s)
  double mass() const { return material.density * 4.0 / 3.0 * kPi * radius * radius * radius; }
};

struct Impact {
  Body a;
  std::optional<Body> b = std::nullopt;  ///< none: sphere a hits the rigid plane z = 0
  double restitution = 1.0;
  double friction = 0.0;
  contact::TangentialModel tangential = contact::TangentialModel::HertzMindlin;
  double cundallStrackRatio = 2.0 / 7.0;  ///< k_t / (K sqrt(R* d)) for Cundall-Strack
  double tangentialDampingRatio = 0.0;
  double stepsPerContact = 1000.0;  ///< dt = analytic elastic t_c / this
};

struct Outcome {
  Vec3 velocityA, spinA, velocityB, spinB;  ///< after the contact (b: zero for the plane)
  double contactDuration = 0.0;             ///< s, steps with overlap x dt
  double maxOverlap = 0.0;                  ///< m
  double maxForce = 0.0;                    ///< N, largest |F| on a during the contact
  double dt = 0.0;
};

/// Pair constants: effective modulus E*, shear modulus G*, radius R*, mass m*.
struct Pair {
  double youngModulus, shearModulus, radius, mass;
};
inline Pair pairOf(const Impact& s) {
  const contact::ElasticMaterial rigid{std::numeric_limits<double>::infinity(), 0.0};
  const contact::ElasticMaterial other = s.b ? s.b->material.elastic : rigid;
  const double ma = s.a.mass(), ra = s.a.radius;
  return {contact::effectiveYoungModulus(s.a.material.elastic, other),
          contact::effectiveShearModulus(s.a.material.elastic, other), s.b ? ra * s.b->radius / (ra + s.b->radius) : ra,
          s.b ? ma * s.b->mass() / (ma + s.b->mass()) : ma};
}

/// Hertz, elastic head-on: maximum overlap (m) at approach speed v.
inline double hertzMaxOverlap(const Pair& p, double v) {
  return std::pow(15.0 * p.mass * v * v / (16.0 * p.youngModulus * std::sqrt(p.radius)), 0.4);
}
/// Hertz, elastic head-on: maximum force (N).
inline double hertzMaxForce(const Pair& p, double v) {
  return 4.0 / 3.0 * p.youngModulus * std::sqrt(p.radius) * std::pow(hertzMaxOverlap(p, v), 1.5);
}
/// Hertz, elastic head-on: contact duration 2 (d_max / v) int_0^1 (1 - x^(5/2))^(-1/2) dx (s), i.e.
/// 2.868 (m*^2 / (R* E*^2 v))^(1/5).
inline double hertzContactDuration(const Pair& p, double v) {
  const double integral = std::tgamma(0.4) * std::sqrt(kPi) / (2.5 * std::tgamma(0.9));
  return 2.0 * integral * hertzMaxOverlap(p, v) / v;
}

/// The contact parameters of a setup (K = 4/3 E*; Hertz-Mindlin with the pair's G*).
inline contact::ContactParameters contactParameters(const Impact& s) {
  const Pair p = pairOf(s);
  contact::ContactParameters c;
  c.normal = contact::NormalModel::Hertz;
  c.stiffness = 4.0 / 3.0 * p.youngModulus;
  c.restitution = s.restitution;
  c.friction = s.friction;
  c.tangential = s.tangential;
  c.tangentialDampingRatio = s.tangentialDampingRatio;
  if (s.tangential == contact::TangentialModel::HertzMindlin) {
    c.shearModulus = p.shearModulus;
  } else {
    c.tangentialStiffnessRatio = s.cundallStrackRatio;
  }
  return c;
}

/// Contact-point velocity of a relative to b (or to the plane).
inline Vec3 contactVelocity(const Vec3& va, const Vec3& wa, double ra, const Vec3& vb, const Vec3& wb, double rb) {
  const Vec3 n(0.0, 0.0, 1.0);
  return (va - vb) - (ra * wa + rb * wb).cross(n);
}

/// Run the impact to its end (both bodies separating) in the engine.
inline Outcome run(const Impact& s) {
  const Pair pair = pairOf(s);
  const double vn = s.a.velocity.z() - (s.b ? s.b->velocity.z() : 0.0);  // < 0: approaching
  const double speed = -vn;
  const double tc = hertzContactDuration(pair, speed);
  const double dt = tc / s.stepsPerContact;
  const Index n = s.b ? 2 : 1;
  const bool rotation = s.friction > 0.0;
  ParticleStore p(n, Features{.rotation = rotation});
  p.radius()[0] = s.a.radius;
  if (s.b) p.radius()[1] = s.b->radius;
  p.setMassesFromDensity(s.a.material.density);
  if (s.b) {  // its own density
    p.inverseMass()[1] = 1.0 / s.b->mass();
    if (rotation) p.inverseInertia()[1] = 1.0 / (0.4 * s.b->mass() * s.b->radius * s.b->radius);
  }
  const double rsum = s.a.radius + (s.b ? s.b->radius : 0.0);
  const double edge = 20.0 * rsum;
  const double gap = 20.5 * dt * speed;  // touches half-way between steps, 20 steps after the start
  const double za = s.b ? 0.5 * edge + 0.5 * (rsum + gap) : s.a.radius + gap;
  p.position().col(0) << 0.5 * edge, 0.5 * edge, za;
  p.velocity().col(0) = s.a.velocity;
  if (rotation) p.angularVelocity().col(0) = s.a.spin;
  if (s.b) {
    p.position().col(1) << 0.5 * edge, 0.5 * edge, za - rsum - gap;
    p.velocity().col(1) = s.b->velocity;
    if (rotation) p.angularVelocity().col(1) = s.b->spin;
  }
  integrators::DemSettings settings;
  settings.contact = contactParameters(s);
  settings.timeStep = dt;
  settings.spatialSort = false;  // keep a in slot 0
  const Box box = s.b ? Box::cubic(edge, Boundary::Periodic)
                      : Box(Vec3::Constant(edge), {Boundary::Periodic, Boundary::Periodic, Boundary::Wall});
  integrators::DemSimulation sim(std::move(p), box, settings);
  Outcome out;
  out.dt = sim.dt();
  bool touched = false;
  std::int64_t inContact = 0;
  const auto limit = static_cast<std::int64_t>(40 + 3 * s.stepsPerContact);
  for (std::int64_t k = 0; k < limit; ++k) {
    sim.advance(1);
    const contact::ContactStats st = sim.contactStats();
    const bool touching = st.contacts + st.wallContacts > 0;
    if (touching) {
      touched = true;
      ++inContact;
      out.maxOverlap = std::max(out.maxOverlap, st.maxOverlapRatio * std::min(s.a.radius, s.b ? s.b->radius : 1e300));
      out.maxForce = std::max(out.maxForce, sim.particles().force().col(0).norm());
    } else if (touched) {
      break;
    }
  }
  out.contactDuration = static_cast<double>(inContact) * out.dt;
  const ParticleStore& q = sim.particles();
  out.velocityA = q.velocity().col(0);
  out.spinA = rotation ? Vec3(q.angularVelocity().col(0)) : Vec3::Zero();
  out.velocityB = s.b ? Vec3(q.velocity().col(1)) : Vec3::Zero();
  out.spinB = s.b && rotation ? Vec3(q.angularVelocity().col(1)) : Vec3::Zero();
  return out;
}

/// Mindlin-to-Hertz stiffness ratio kappa = 8 G* / K = 6 G* / E* of a setup (3 (1-nu)/(2-nu) for one material).
inline double kappaOf(const Impact& s) {
  const Pair p = pairOf(s);
  return 6.0 * p.shearModulus / p.youngModulus;
}

/// Normalised angles of Maw, Barber & Fawcett, Wear 38, 101 (1976), as used by Chung & Ooi:
/// Psi = (2 kappa / 3) tan(theta) / mu, with tan(theta) = v_ct / v_n of the contact point (for one material
/// 2 kappa / 3 = 2 (1 - nu) / (2 - nu)). Psi1 before, Psi2 after the impact (negative: reversed).
struct Angles {
  double psi1, psi2;
};
inline Angles normalisedAngles(const Impact& s, const Outcome& o) {
  const double rb = s.b ? s.b->radius : 0.0;
  const Vec3 vb0 = s.b ? s.b->velocity : Vec3::Zero(), wb0 = s.b ? s.b->spin : Vec3::Zero();
  const Vec3 before = contactVelocity(s.a.velocity, s.a.spin, s.a.radius, vb0, wb0, rb);
  const Vec3 after = contactVelocity(o.velocityA, o.spinA, s.a.radius, o.velocityB, o.spinB, rb);
  const double scale = 2.0 * kappaOf(s) / (3.0 * s.friction);
  return {scale * before.x() / -before.z(), scale * after.x() / after.z()};
}

/// Sliding throughout (rigid-body Coulomb impact, solid spheres, e = 1 for the normal part): the
/// contact-point velocity drops by (7/2) mu (1 + e) v_n, so Psi2 = (Psi1 - (7/3) kappa (1 + e)) / e.
inline double slidingPsi2(double psi1, double kappa, double e) { return (psi1 - 7.0 / 3.0 * kappa * (1.0 + e)) / e; }

/// No-slip limit Psi1 -> 0 (Mindlin stiffness, no micro-slip: the Maw et al. solution for vanishing
/// tangential load): Psi2 / Psi1 = w(tau), from the dimensionless elastic contact
///   x'' = -x^(3/2),   w'' = -(7/2) kappa x^(1/2) w,   x(0) = 0, x'(0) = 1, w(0) = 1, w'(0) = 0,
/// integrated by RK4 (independently of the engine) until x returns to 0.
inline double noSlipRatio(double kappa) {
  auto rhs = [kappa](const Eigen::Vector4d& y) {  // x, x', w, w'
    const double x = std::max(y[0], 0.0);
    return Eigen::Vector4d(y[1], -x * std::sqrt(x), y[3], -3.5 * kappa * std::sqrt(x) * y[2]);
  };
  Eigen::Vector4d y(0.0, 1.0, 1.0, 0.0);
  const double h = 1e-5;
  for (int k = 0; k < 10'000'000; ++k) {
    const Eigen::Vector4d k1 = rhs(y), k2 = rhs(y + 0.5 * h * k1), k3 = rhs(y + 0.5 * h * k2), k4 = rhs(y + h * k3);
    const Eigen::Vector4d next = y + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    if (next[0] <= 0.0 && k > 0) {
      const double f = y[0] / (y[0] - next[0]);
      return y[2] + f * (next[2] - y[2]);
    }
    y = next;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

}  // namespace polydem::chung_ooi
