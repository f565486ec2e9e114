// Closed-form collision, exit and wall times against brute-force time stepping, and the collision rule.
#include "edmd/kinematics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <set>
#include <utility>

#include "edmd/event_queue.hpp"

namespace polydem::edmd {
namespace {

// f(t) = |r + u t|^2 - (s + sd t)^2: positive while the gap is open.
double contactFunction(const double r[3], const double u[3], double s, double sd, double t) {
  double d2 = 0.0;
  for (int k = 0; k < 3; ++k) d2 += (r[k] + u[k] * t) * (r[k] + u[k] * t);
  return d2 - (s + sd * t) * (s + sd * t);
}

// First time in (0, horizon] at which f <= 0, by stepping; kNever if none.
double steppedCollision(const double r[3], const double u[3], double s, double sd, double horizon, int steps) {
  const double dt = horizon / steps;
  for (int n = 1; n <= steps; ++n) {
    if (contactFunction(r, u, s, sd, n * dt) <= 0.0) return n * dt;
  }
  return kNever;
}

double predicted(const double r[3], const double u[3], double s, double sd) {
  const ContactQuadratic q = contactQuadratic(r, u, s, sd);
  return pairCollisionDelay(q, q.c <= 0.0 && approachRate(r, u, sd) < 0.0);
}

TEST(PairCollisionDelay, MatchesTimeSteppingOnRandomPairs) {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  const double horizon = 4.0;
  const int steps = 100000;
  int collided = 0, missed = 0;
  for (int trial = 0; trial < 1500; ++trial) {
    SCOPED_TRACE(::testing::Message() << "trial " << trial);
    const double s = 0.5 + 0.5 * (uniform(rng) + 1.0);  // contact distance 0.5..1.5
    // A third of the pairs do not grow, the others grow at up to 0.3 (comparable to the speeds).
    const double sd = trial % 3 == 0 ? 0.0 : 0.15 * (uniform(rng) + 1.0);
    double r[3], u[3];
    double rr;
    do {
      for (int k = 0; k < 3; ++k) r[k] = 2.5 * uniform(rng);
      rr = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
    } while (rr <= s * s * 1.0001);  // open gap at t = 0
    for (int k = 0; k < 3; ++k) u[k] = uniform(rng);
    const double tau = predicted(r, u, s, sd);
    const double stepped = steppedCollision(r, u, s, sd, horizon, steps);
    if (stepped == kNever) {
      // No contact, or after the horizon, or a graze thinner than one step (then tau must still be a
      // genuine contact).
      if (tau < horizon - horizon / steps) {
        EXPECT_NEAR(contactFunction(r, u, s, sd, tau) / (s * s), 0.0, 1e-12) << "tau " << tau;
      }
      ++missed;
    } else {
      ASSERT_LT(tau, kNever);
      EXPECT_LE(tau, stepped + 1e-12);
      EXPECT_GT(tau, stepped - horizon / steps - 1e-12);
      // At tau the spheres touch: f(tau) = 0 to round-off, relative to s^2.
      EXPECT_NEAR(contactFunction(r, u, s, sd, tau) / (s * s), 0.0, 1e-12);
      ++collided;
    }
  }
  EXPECT_GT(collided, 100);  // about 130 of 1500
  EXPECT_GT(missed, 50);
}

TEST(PairCollisionDelay, HeadOnKnownAnswer) {
  // Centres 3 apart, contact distance 1, closing at speed 2: contact after 1.
  const double r[3] = {3.0, 0.0, 0.0}, u[3] = {-2.0, 0.0, 0.0};
  EXPECT_DOUBLE_EQ(predicted(r, u, 1.0, 0.0), 1.0);
  // At rest, growing: s(t) = 1 + 0.5 t reaches 3 at t = 4.
  const double still[3] = {0.0, 0.0, 0.0};
  EXPECT_DOUBLE_EQ(predicted(r, still, 1.0, 0.5), 4.0);
  // Separating at speed 1 while the contact distance grows at 2: |3 + t| = 1 + 2 t at t = 2.
  const double away[3] = {1.0, 0.0, 0.0};
  EXPECT_DOUBLE_EQ(predicted(r, away, 1.0, 2.0), 2.0);
  // Separating without growth: never.
  EXPECT_EQ(predicted(r, away, 1.0, 0.0), kNever);
}

TEST(PairCollisionDelay, NoCancellationNearJamming) {
  // Gap 1e-13 of the contact distance, approach speed 1: tau = gap / speed to full relative precision,
  // where the textbook (-b - sqrt(b^2 - a c)) / a loses every digit.
  const double s = 1.0, gap = 1e-13;
  const double r[3] = {s + gap, 0.0, 0.0}, u[3] = {-1.0, 1e-3, 0.0};
  const long double rl = static_cast<long double>(s) + static_cast<long double>(gap);
  const long double al = 1.0L + 1e-6L, bl = -rl, cl = rl * rl - 1.0L;
  const long double exact = cl / (-bl + std::sqrt(bl * bl - al * cl));
  EXPECT_NEAR(predicted(r, u, s, 0.0) / static_cast<double>(exact), 1.0, 1e-3);
  // With growth as well.
  const double sd = 1e-5;
  const long double bg = -rl - static_cast<long double>(s) * sd, ag = al - 1e-10L;
  const long double exactGrowing = cl / (-bg + std::sqrt(bg * bg - ag * cl));
  EXPECT_NEAR(predicted(r, u, s, sd) / static_cast<double>(exactGrowing), 1.0, 1e-3);
}

TEST(PairCollisionDelay, TouchingPairs) {
  const double r[3] = {1.0, 0.0, 0.0};
  const double closing[3] = {-1.0, 0.0, 0.0}, opening[3] = {1.0, 0.0, 0.0};
  // Overlapping by round-off and approaching: collide now.
  EXPECT_EQ(predicted(r, closing, 1.0 + 1e-15, 0.0), 0.0);
  // Touching and separating without growth: never.
  EXPECT_EQ(predicted(r, opening, 1.0, 0.0), kNever);
  // Surfaces separating (hdot = u.n - sd > 0) while growing: the gap h(t) = |r + u t| - s - sd t is
  // convex, so it never closes again without a third party.
  const double fast[3] = {3.0, 0.0, 0.0}, slow[3] = {0.2, 0.0, 0.0};
  EXPECT_EQ(predicted(r, fast, 1.0, 1.0), kNever);
  EXPECT_EQ(predicted(r, slow, 1.0, 0.1), kNever);
  // Centres moving apart slower than the contact distance grows: the surfaces approach, collide now.
  const double grow[3] = {0.05, 0.3, 0.0};
  EXPECT_EQ(predicted(r, grow, 1.0, 0.4), 0.0);
}

TEST(ExitDelay, MatchesTimeStepping) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  for (int trial = 0; trial < 300; ++trial) {
    SCOPED_TRACE(::testing::Message() << "trial " << trial);
    const double radius = 1.0, bound = 1.3;
    const double rate = trial % 2 ? 0.0 : 0.05 * (uniform(rng) + 1.0);
    double d[3], v[3];
    for (int k = 0; k < 3; ++k) {
      d[k] = 0.15 * uniform(rng) / std::sqrt(3.0);
      v[k] = uniform(rng);
    }
    const double tau = exitDelay(d, v, radius, rate, bound);
    ASSERT_GT(tau, 0.0);
    ASSERT_LT(tau, kNever);
    // At tau: |d + v tau| + radius + rate tau = bound.
    double x2 = 0.0;
    for (int k = 0; k < 3; ++k) x2 += (d[k] + v[k] * tau) * (d[k] + v[k] * tau);
    EXPECT_NEAR(std::sqrt(x2) + radius + rate * tau, bound, 1e-12);
    // And inside before: sample a few earlier times.
    for (double f : {0.1, 0.5, 0.9, 0.999}) {
      double y2 = 0.0;
      for (int k = 0; k < 3; ++k) y2 += (d[k] + v[k] * f * tau) * (d[k] + v[k] * f * tau);
      EXPECT_LT(std::sqrt(y2) + radius + rate * f * tau, bound);
    }
  }
  const double zero[3] = {0.0, 0.0, 0.0};
  EXPECT_EQ(exitDelay(zero, zero, 1.0, 0.0, 1.5), kNever);       // at rest, not growing
  EXPECT_DOUBLE_EQ(exitDelay(zero, zero, 1.0, 0.25, 1.5), 2.0);  // grows into the bound
  const double out[3] = {0.6, 0.0, 0.0};
  EXPECT_EQ(exitDelay(out, zero, 1.0, 0.0, 1.5), 0.0);  // already outside
}

TEST(WallDelay, KnownAnswers) {
  // x = 2, radius 0.5, moving down at 1 towards the wall at 0: gap 1.5.
  EXPECT_DOUBLE_EQ(wallDelay(2.0, -1.0, 0.5, 0.0, 10.0, false), 1.5);
  EXPECT_EQ(wallDelay(2.0, 1.0, 0.5, 0.0, 10.0, false), kNever);
  // Upper wall at 10: gap 7.5, closing at 1 + growth 0.5.
  EXPECT_DOUBLE_EQ(wallDelay(2.0, 1.0, 0.5, 0.5, 10.0, true), 5.0);
  // Growth alone reaches the lower wall.
  EXPECT_DOUBLE_EQ(wallDelay(2.0, 0.0, 0.5, 0.5, 10.0, false), 3.0);
}

TEST(CollisionImpulse, ReversesSurfaceSpeed) {
  // Equal masses 1 (reduced mass 1/2), hdot = -3: J = 3, new hdot = +3.
  EXPECT_DOUBLE_EQ(collisionImpulse(-3.0, 0.5, 1e-10), 3.0);
  // Grazing: the floor on the separation speed applies.
  EXPECT_DOUBLE_EQ(collisionImpulse(-1e-20, 0.5, 1e-10), 0.5 * (1e-10 + 1e-20));
}

// The prediction loop rejects pairs with mayMeetWithin() before it takes the square root; the trajectory
// stays the one of the full computation only if no pair the exact test accepts is rejected. Quadratics of
// open gaps with a >= 0 over many scales (a = 0, a tiny, gaps down to 1e-14 as near jamming, grazing
// discriminants), horizons at, just above and just below the first root.
TEST(PairPrefilter, NeverRejectsAPairTheExactTestAccepts) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto logUniform = [&](double lo, double hi) { return lo * std::pow(hi / lo, unit(rng)); };
  std::int64_t accepted = 0, rejectedBoth = 0;
  for (int n = 0; n < 400000; ++n) {
    const int shape = n % 4;
    const double c = logUniform(1e-14, 1e2);
    const double b = (unit(rng) < 0.8 ? -1.0 : 1.0) * logUniform(1e-10, 1e3);
    // a = 0 (no relative motion across the line: the bound is tight), tiny, generic, or at the grazing
    // discriminant b^2 = a c (nextafter either side).
    double a = 0.0;
    if (shape == 1) a = logUniform(1e-20, 1e-8) * b * b / c;
    if (shape == 2) a = logUniform(1e-6, 1.0) * b * b / c;
    if (shape == 3) a = std::nextafter(b * b / c, unit(rng) < 0.5 ? 0.0 : 1e300);
    const ContactQuadratic q{a, b, c};
    const double root = std::sqrt(q.b * q.b - q.a * q.c);
    const double tau1 = q.c / (root - q.b);  // NaN or <= 0 when the pair misses
    const double scale = std::isfinite(tau1) && tau1 > 0.0 ? tau1 : logUniform(1e-6, 1e6);
    const double factors[] = {1.0, 1.0 + 1e-15, 1.0 - 1e-15, 1.0 + 1e-9, 1.0 + 1e-3, 0.5, 2.0, 1e6};
    for (const double f : factors) {
      const double reach = scale * f;
      const bool exact = openGapMeetsWithin(q, root, reach);
      if (exact) {
        ++accepted;
        ASSERT_TRUE(mayMeetWithin(q, reach)) << "a " << a << " b " << b << " c " << c << " reach " << reach;
      } else {
        rejectedBoth += mayMeetWithin(q, reach) ? 0 : 1;
      }
    }
  }
  // Both branches were exercised, and the prefilter does reject (it is not `true`).
  EXPECT_GT(accepted, 100000);
  EXPECT_GT(rejectedBoth, 100000);
  // Touching pairs and growth faster than the approach always go to the exact path.
  EXPECT_TRUE(mayMeetWithin({1.0, 1.0, 0.0}, 1e-30));
  EXPECT_TRUE(mayMeetWithin({-1.0, 1.0, 1.0}, 1e-30));
  // A receding pair with a >= 0 is rejected even for an infinite horizon.
  EXPECT_FALSE(mayMeetWithin({1.0, 0.5, 1.0}, std::numeric_limits<double>::infinity()));
  EXPECT_FALSE(mayMeetWithin({1.0, 0.0, 1.0}, std::numeric_limits<double>::infinity()));
}

TEST(EventQueue, OrdersAndUpdates) {
  EventQueue q;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<double> keys(200);
  for (double& k : keys) k = uniform(rng);
  q.assign(keys);
  q.validate();
  for (int n = 0; n < 2000; ++n) {
    const Index i = static_cast<Index>(rng() % keys.size());
    keys[static_cast<std::size_t>(i)] = uniform(rng);
    q.update(i, keys[static_cast<std::size_t>(i)]);
    const auto smallest = std::min_element(keys.begin(), keys.end());
    ASSERT_EQ(q.topKey(), *smallest);
    ASSERT_EQ(q.key(q.top()), *smallest);
  }
  q.validate();
}

// The calendar (heap of near keys + time buckets + overflow) pops in exactly the order of one set ordered by
// (key, particle), through ties, +inf keys, width rebuilds, rate changes of 10^4, refills past empty buckets,
// re-spreading of the overflow and assign(): the event loop's use (pop the top, give it a later key, move
// a few other particles' keys) with a reference checked at every step.
TEST(EventQueue, CalendarPopsInKeyThenIndexOrder) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  for (const Index n : {1, 2, 7, 300, 2000}) {
    EventQueue q;
    std::mt19937_64 rng(11 + static_cast<std::uint64_t>(n));
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    std::vector<double> keys(static_cast<std::size_t>(n), 0.0);
    std::set<std::pair<double, Index>> order;
    const auto resetAll = [&](double now) {
      std::fill(keys.begin(), keys.end(), now);  // ties for every particle, as after a synchronisation
      q.assign(keys);
      order.clear();
      for (Index i = 0; i < n; ++i) order.insert({now, i});
    };
    const auto set = [&](Index i, double key) {
      order.erase({keys[static_cast<std::size_t>(i)], i});
      keys[static_cast<std::size_t>(i)] = key;
      order.insert({key, i});
      q.update(i, key);
    };
    q.reset(n);
    for (Index i = 0; i < n; ++i) order.insert({kInf, i});
    resetAll(0.0);
    double scale = 1.0;
    std::int64_t steps = 0;
    for (int phase = 0; phase < 6; ++phase) {
      scale = phase % 2 == 0 ? scale * 1e-4 : scale * 1e3;  // the event rate jumps by decades
      for (int s = 0; s < 40 * n + 200; ++s, ++steps) {
        ASSERT_EQ(q.top(), order.begin()->second) << "n " << n << " step " << steps;
        ASSERT_EQ(q.topKey(), order.begin()->first);
        ASSERT_EQ(q.key(q.top()), order.begin()->first);
        const double now = order.begin()->first;
        const Index i = q.top();
        const double r = uniform(rng);
        // The popped particle: a later time, a tie with now (a zero-delay check), a tie on a coarse grid of
        // times, or never (+inf: nothing ahead of it).
        double next = now + scale * n * uniform(rng);
        if (r < 0.05)
          next = now;
        else if (r < 0.15)
          next = std::floor(now / scale + 3.0) * scale;
        else if (r < 0.18)
          next = kInf;
        else if (r < 0.19)
          next = now + 1e3 * scale * n;                                      // far beyond the buckets: the overflow
        if (!std::isfinite(now)) next = static_cast<double>(steps) * scale;  // everything at +inf: restart
        set(i, next);
        // A partner or a claimed particle: any particle, a later key.
        if (r > 0.6) {
          const Index j = static_cast<Index>(rng() % static_cast<std::uint64_t>(n));
          const double base = std::isfinite(order.begin()->first) ? order.begin()->first : 0.0;
          set(j, std::max(base, keys[static_cast<std::size_t>(j)] < kInf ? base + scale * n * uniform(rng) : base));
        }
        if (s % 997 == 0) {
          ASSERT_NO_THROW(q.validate()) << "n " << n << " step " << steps;
        }
      }
      if (phase == 3) resetAll(order.begin()->first < kInf ? order.begin()->first : 0.0);
    }
    ASSERT_NO_THROW(q.validate());
    if (n >= 300) {
      EXPECT_GT(q.rebuilds(), 2) << "the width never followed the rate";
      EXPECT_GT(q.bucketWidth(), 0.0);
      EXPECT_LT(q.heapSize(), n / 2) << "the near heap should hold a small part of the keys";
    }
  }
}

// Lazy list deletion: keys that move between buckets leave stale entries behind, which are skipped when a
// list is emptied and dropped (a compaction) before they exceed 3N + 1024; the pop order stays that of the
// ordered set throughout. Phase 1 is the event loop's pattern (pop, re-predict, move a few others); phase 2
// moves keys between buckets without any pop, which only the compaction bounds.
TEST(EventQueue, StaleBucketEntriesAreBoundedAndSkipped) {
  constexpr Index n = 1000;
  EventQueue q;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<double> keys(static_cast<std::size_t>(n));
  for (double& k : keys) k = uniform(rng);
  q.assign(keys);
  std::set<std::pair<double, Index>> order;
  for (Index i = 0; i < n; ++i) order.insert({keys[static_cast<std::size_t>(i)], i});
  const auto set = [&](Index i, double key) {
    order.erase({keys[static_cast<std::size_t>(i)], i});
    keys[static_cast<std::size_t>(i)] = key;
    order.insert({key, i});
    q.update(i, key);
  };
  const auto popAndMove = [&](int steps) {
    for (int s = 0; s < steps; ++s) {
      ASSERT_EQ(q.top(), order.begin()->second) << "step " << s;
      ASSERT_EQ(q.topKey(), order.begin()->first);
      const double now = order.begin()->first;
      set(q.top(), now + uniform(rng));
      for (int k = 0; k < 6; ++k) set(static_cast<Index>(rng() % n), now + 10.0 * uniform(rng));
      ASSERT_LE(q.listEntries(), 3 * n + 1024);
      if (s % 4999 == 0) {
        ASSERT_NO_THROW(q.validate()) << "step " << s;
      }
    }
  };
  popAndMove(20 * n);
  ASSERT_GT(q.bucketWidth(), 0.0);
  const double now = order.begin()->first;
  const double width = q.bucketWidth();
  for (int s = 0; s < 10 * n; ++s) {
    const Index i = static_cast<Index>(rng() % n);
    // Only keys beyond the heap's range move, so that the top and the measured rate stay as they are (a
    // width rebuild would drop the stale entries too).
    if (keys[static_cast<std::size_t>(i)] < now + 2.0 * width) continue;
    set(i, now + width * static_cast<double>(2 + rng() % 50));
    ASSERT_LE(q.listEntries(), 3 * n + 1024);
  }
  EXPECT_GT(q.compactions(), 0) << "the stale entries never reached the bound: the test does not exercise it";
  ASSERT_NO_THROW(q.validate());
  popAndMove(20 * n);
  ASSERT_NO_THROW(q.validate());
}

}  // namespace
}  // namespace polydem::edmd
