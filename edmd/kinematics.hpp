#pragma once
// Closed-form kinematics of hard spheres whose radii grow linearly in time: pair collision times,
// bounding-neighbourhood exit times, wall collision times, and the elastic collision rule with growth.
//
// Pair collision (our derivation, cross-checked against the public Skoge-Donev code; Donev 2006 (thesis), §3.2.2,
// states "first positive root of a quadratic"). With r = x_i - x_j (minimum image), u = v_i - v_j, contact distance s =
// O_i + O_j and its growth rate sd = gamma_i + gamma_j:
//   |r + u tau|^2 = (s + sd tau)^2   <=>   a tau^2 + 2 b tau + c = 0,
//   a = u.u - sd^2,  b = r.u - s sd,  c = r.r - s^2.
// Roots are taken in the cancellation-free forms c / (-b + sqrt(b^2 - a c)) and -(b + sqrt(..)) / a,
// never (-b - sqrt(..)) / a, which loses every digit when a -> 0 or c -> 0 (near jamming c ~ 1e-12 s^2).
//
// Touching or overlapping pairs (c <= 0, which round-off produces right after a collision) are decided
// by the sign of the surface approach rate hdot = (r.u)/|r| - sd: approaching -> collide now (overlap
// recovery, Donev 2006, §3.5.1), separating -> only the growth root. collide() uses the very same
// approachRate(), so a pair it has just processed is never predicted to collide again at zero delay.
//
// Elastic collision of growing spheres (Donev 2006, §6.3.2): momentum is exchanged
// along n = r/|r| only and the relative normal velocity of the two *surfaces*, hdot = u.n - sd, is
// reversed. The impulse J = 2 mu (-hdot) (mu = reduced mass) does the work of the growth agent, so every
// collision of growing spheres injects energy; the thermostat removes it.
#include <algorithm>
#include <cmath>
#include <limits>

namespace polydem::edmd {

inline constexpr double kNever = std::numeric_limits<double>::infinity();

/// Coefficients of the contact quadratic a tau^2 + 2 b tau + c = 0 of one pair (see file comment).
struct ContactQuadratic {
  double a, b, c;
};

inline ContactQuadratic contactQuadratic(const double r[3], const double u[3], double s, double sd) {
  const double uu = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
  const double ru = r[0] * u[0] + r[1] * u[1] + r[2] * u[2];
  const double rr = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
  return {uu - sd * sd, ru - s * sd, rr - s * s};
}

/// Necessary condition, without a square root, for a pair to meet within `reach` (s, the horizon with its
/// margin): for an open gap (c > 0) and a >= 0, sqrt(b^2 - a c) <= |b|, so the first root tau_1 = c /
/// (sqrt(b^2 - a c) - b) >= c / (2 |b|) when b < 0, and tau_1 < reach implies c < 2 reach (-b); the factor
/// 2.5 is room for round-off, so that every pair openGapMeetsWithin() accepts passes this test
/// (tests/edmd/kinematics_test.cpp, PairPrefilter). For b >= 0 the right side is <= 0 or NaN: rejected, as
/// such a pair misses. Touching pairs (c <= 0) and a < 0 (growth faster than the approach) always pass.
/// Written with `|`, so that the one branch taken on its result does not depend on the sign of b (a coin
/// flip) and is rarely taken.
inline bool mayMeetWithin(const ContactQuadratic& q, double reach) {
  return (q.c <= 0.0) | (q.a < 0.0) | (q.c <= 2.5 * reach * -q.b);
}

/// The prediction loop's exact acceptance for an open gap without a growth root: tau_1 = c / (root - b) <
/// reach, written without the division (root = sqrt(b^2 - a c); NaN and root - b <= 0 fail, as they miss).
inline bool openGapMeetsWithin(const ContactQuadratic& q, double root, double reach) {
  return q.c < reach * (root - q.b);
}

/// Rate of change of the surface gap, hdot = (r.u)/|r| - sd (m/s); negative when approaching. The one
/// expression used both by prediction (for touching pairs) and by the collision rule.
inline double approachRate(const double r[3], const double u[3], double sd) {
  const double rr = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
  const double ru = r[0] * u[0] + r[1] * u[1] + r[2] * u[2];
  return ru / std::sqrt(rr) - sd;
}

/// Smallest delay tau >= 0 (s) until contact, or kNever. `approaching` is approachRate() < 0; it is only
/// consulted when c <= 0 (touching or overlapping within round-off).
inline double pairCollisionDelay(const ContactQuadratic& q, bool approaching) {
  const double a = q.a, b = q.b, c = q.c;
  if (c <= 0.0) {
    if (approaching) return 0.0;
    // Separating now; growth faster than the relative speed (a < 0) brings them back. In exact
    // arithmetic c = 0 here, so the discriminant is b^2 >= 0; clamp round-off.
    if (a < 0.0) return -(b + std::sqrt(std::max(b * b - a * c, 0.0))) / a;
    return kNever;
  }
  if (b < 0.0) {
    const double disc = b * b - a * c;
    if (disc < 0.0) return kNever;  // only possible for a > 0: the spheres miss
    return c / (-b + std::sqrt(disc));
  }
  // Gap opening (b >= 0): only growth outpacing the motion (a < 0) can close it; then a c < 0 and the
  // product of the roots c / a < 0, so exactly one root is positive.
  if (a < 0.0) return -(b + std::sqrt(b * b - a * c)) / a;
  return kNever;
}

/// Delay (s) until a sphere of radius `radius` growing at `rate` (m/s), at offset d from the centre of
/// its bounding neighbourhood of radius `bound`, touches the neighbourhood's inner surface moving with
/// velocity v: |d + v tau| = (bound - radius) - rate tau. 0 if it is already there. The gap function is
/// concave, so there is exactly one crossing and -C / (B + sqrt(B^2 - A C)) never cancels (Donev 2006, §3.3.2).
inline double exitDelay(const double d[3], const double v[3], double radius, double rate, double bound) {
  const double g0 = bound - radius;
  if (!(g0 > 0.0)) return 0.0;
  const double cc = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) - g0 * g0;
  if (cc >= 0.0) return 0.0;
  const double aa = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) - rate * rate;
  const double bb = (d[0] * v[0] + d[1] * v[1] + d[2] * v[2]) + g0 * rate;
  const double den = bb + std::sqrt(std::max(bb * bb - aa * cc, 0.0));
  if (!(den > 0.0)) return kNever;  // at rest and not growing
  return -cc / den;
}

/// Delay (s) until a sphere at coordinate x (radius O, growth rate `rate`, velocity v along the axis)
/// touches the wall at 0 (lower) or at L (upper). 0 if it touches and approaches already.
inline double wallDelay(double x, double v, double radius, double rate, double length, bool upper) {
  const double gap = upper ? (length - x) - radius : x - radius;
  const double closing = upper ? v + rate : rate - v;  // -d(gap)/dt
  if (!(closing > 0.0)) return kNever;
  if (gap <= 0.0) return 0.0;
  return gap / closing;
}

/// Impulse magnitude J (kg m/s) of an elastic collision with surface approach rate hdot < 0 and reduced
/// mass mu: J = 2 mu (-hdot), so that the new approach rate is -hdot. `minSeparation` (m/s, > 0) is a
/// floor on the new separation rate: grazing collisions with |hdot| below round-off would otherwise be
/// left approaching and re-collide at zero delay forever.
inline double collisionImpulse(double hdot, double reducedMass, double minSeparation) {
  const double after = std::max(-hdot, minSeparation);
  return reducedMass * (after - hdot);
}

}  // namespace polydem::edmd
