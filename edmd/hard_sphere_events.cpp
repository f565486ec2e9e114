// HardSphereSystem, part: the hot path. Event prediction (Donev 2006, thesis, Algorithm 5, near-neighbour
// list mode), binary and wall collisions, the watchdogs and the event loop. They share one translation
// unit so that the kernels inline into process() and run() as they did before the split.
#include <algorithm>
#include <cmath>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <fmt/format.h>

#include "core/errors.hpp"
#include "edmd/hard_sphere_system.hpp"
#include "edmd/kinematics.hpp"

namespace polydem::edmd {

namespace {

// Exit a hair early so that round-off in the exit time can never leave a particle outside its
// neighbourhood by more than ~1e-12 of its radius while a non-neighbour is within reach.
constexpr double kExitShrink = 1.0 - 1e-12;

// Branch-free selects for the prediction loop (SSE2 is part of x86-64; other targets get plain code,
// which is correct but branches).
#if defined(__SSE2__)
inline double wrapOnce(double d, double half, double length) {
  // d - L [d > L/2] + L [d < -L/2]
  const __m128d x = _mm_set_sd(d), h = _mm_set_sd(half), l = _mm_set_sd(length);
  const __m128d up = _mm_and_pd(_mm_cmpgt_sd(x, h), l);
  const __m128d down = _mm_and_pd(_mm_cmplt_sd(x, _mm_xor_pd(h, _mm_set_sd(-0.0))), l);
  return _mm_cvtsd_f64(_mm_add_sd(_mm_sub_sd(x, up), down));
}
// tau >= 0, tc < horizon and tc < best: then best = tc and true.
inline bool keepEarlierImpl(double tau, double tc, double horizon, double& best) {
  const __m128d t = _mm_set_sd(tc), b = _mm_set_sd(best);
  const __m128d m = _mm_and_pd(_mm_and_pd(_mm_cmpge_sd(_mm_set_sd(tau), _mm_setzero_pd()), _mm_cmplt_sd(t, b)),
                               _mm_cmplt_sd(t, _mm_set_sd(horizon)));
  best = _mm_cvtsd_f64(_mm_or_pd(_mm_and_pd(m, t), _mm_andnot_pd(m, b)));
  return (_mm_movemask_pd(m) & 1) != 0;
}
#else
inline double wrapOnce(double d, double half, double length) {
  if (d > half) return d - length;
  if (d < -half) return d + length;
  return d;
}
inline bool keepEarlierImpl(double tau, double tc, double horizon, double& best) {
  if (tau >= 0.0 && tc < best && tc < horizon) {
    best = tc;
    return true;
  }
  return false;
}
#endif

}  // namespace

// ---------------------------------------------------------------------------------------------------
// Prediction

inline double HardSphereSystem::wrapped(double d, int axis) const { return wrapOnce(d, half_[axis], wrap_[axis]); }

inline bool HardSphereSystem::keepEarlier(double tau, double tc, double horizon, double& best) {
  return keepEarlierImpl(tau, tc, horizon, best);
}

void HardSphereSystem::predict(Index i) {
  // Donev 2006 (thesis), Algorithm 5, near-neighbour-list mode.
  const std::size_t ui = static_cast<std::size_t>(i);
  const State& si = state_[ui];
  const std::span<const Index> list = neighboursOf(i);
  // Start loading the first neighbours' states while the exit time is computed.
  for (std::size_t k = 0; k < std::min(list.size(), prefetchAhead_); ++k) {
    __builtin_prefetch(&state_[list[k]]);
    __builtin_prefetch(&event_[list[k]]);
  }
  const double ri = radiusAt(si);
  const double rate = growth_ * si.r0;
  Event best{kInfinity, -1, EventKind::None};
  {
    double d[3];
    const Hood& hood = hood_[ui];
    for (int k = 0; k < 3; ++k) d[k] = si.x[k] - hood.centre[k];
    minimumImage(d);
    const double tau = exitDelay(d, si.v, ri, rate, hood.radius * kExitShrink);
    if (tau < kInfinity) best = Event{clock_ + tau, -1, EventKind::Exit};
  }
  if (hasWalls_) {
    for (int k = 0; k < 3; ++k) {
      if (periodic_[k]) continue;
      for (int upper = 0; upper < 2; ++upper) {
        const double tau = wallDelay(si.x[k], si.v[k], ri, rate, length_[k], upper == 1);
        if (clock_ + tau < best.time) best = Event{clock_ + tau, 2 * k + upper, EventKind::Wall};
      }
    }
  }
  // The hot loop: the pair collision time of kinematics.hpp with i's state in registers and the states
  // of later neighbours prefetched (the loop is bound by those loads more than by arithmetic).
  {
    const State* states = state_.data();
    const double xi[3] = {si.x[0], si.x[1], si.x[2]};
    const double vi[3] = {si.v[0], si.v[1], si.v[2]};
    const double r0i = si.r0, clock = clock_, g = growth_;
    const std::size_t m = list.size();
    pairWork_ += static_cast<std::int64_t>(m);
    ClassCounters& cc = classTotal_[static_cast<std::size_t>(hood_[ui].cls)];
    ++cc.predictions;
    cc.scans += static_cast<std::int64_t>(m);
    const Event* events = event_.data();
    double bestTime = best.time;
    Index bestPartner = -1;
    for (std::size_t k = 0; k < m; ++k) {
      const Index ahead = list[std::min(k + prefetchAhead_, m - 1)];
      __builtin_prefetch(states + ahead);
      __builtin_prefetch(events + ahead);
      const Index j = list[k];
      const State& sj = states[j];
      const double dt = clock - sj.t;
      double r[3], u[3];
      for (int a = 0; a < 3; ++a) {
        r[a] = wrapped(xi[a] - (sj.x[a] + sj.v[a] * dt), a);
        u[a] = vi[a] - sj.v[a];
      }
      const double s0 = r0i + sj.r0;
      const double sd = g * s0;
      const ContactQuadratic q = contactQuadratic(r, u, s0 + sd * clock, sd);
      // Most pairs cannot beat the horizon (the best time so far and j's own event): rejected before the
      // square root by a test that is rarely passed, so its branch is predicted (kinematics.hpp).
      const double horizon = std::min(bestTime, events[j].time) - clock;
      const double reach = horizon + 1e-9 * (clock + horizon);
      if (!mayMeetWithin(q, reach)) continue;
      // pairCollisionDelay() rearranged so that the common case has no data-dependent branch (the sign
      // of b is a coin flip; mispredicting it cost more than the arithmetic). For an open gap (c > 0)
      // the positive root, when there is one, is c / (sqrt(b^2 - a c) - b) in every case; otherwise this
      // expression is NaN (the spheres miss: disc < 0) or <= 0 (gap opening, a >= 0), which the
      // acceptance test below rejects. Only b >= 0 with a < 0 (growth overtaking a separating pair)
      // takes the other, cancellation-free form -(b + sqrt) / a.
      const double root = std::sqrt(q.b * q.b - q.a * q.c);
      const double den = root - q.b;
      // The exact test for the common case (open gap, no growth root), without the division: tau = c / den
      // < H <=> c < H den for den > 0 (NaN and den <= 0 fail, as the exact test below would). The margin
      // 1e-9 (clock + H) makes the shortcut conservative, so the accepted pair and its time are exactly
      // those of the full computation.
      if (q.c > 0.0 && !(q.a < 0.0 && q.b >= 0.0) && !openGapMeetsWithin(q, root, reach)) continue;
      double tau = q.c / den;
      if (q.a < 0.0 && q.b >= 0.0) [[unlikely]]
        tau = -(q.b + root) / q.a;
      if (q.c <= 0.0) [[unlikely]]
        tau = pairCollisionDelay(q, approachRate(r, u, sd) < 0.0);
      // Accept before both the best so far and j's own event (Donev 2006, Algorithm 5, step 4), as a branch-free
      // running minimum: whether a pair wins is as unpredictable as the sign of b.
      const double tc = clock + tau;
      const bool take = keepEarlier(tau, tc, events[j].time, bestTime);
      bestPartner = take ? j : bestPartner;
    }
    if (bestPartner >= 0) best = Event{bestTime, bestPartner, EventKind::Collision};
  }
  if (best.kind == EventKind::Collision) {
    Event& ej = event_[static_cast<std::size_t>(best.partner)];
    if (ej.kind == EventKind::Collision && ej.partner != i) {
      event_[static_cast<std::size_t>(ej.partner)].kind = EventKind::Check;  // lazy invalidation
    }
    ej = Event{best.time, i, EventKind::Collision};
    queue_.update(best.partner, best.time);
  }
  event_[ui] = best;
  queue_.update(i, best.time);
}

// ---------------------------------------------------------------------------------------------------
// Collisions

void HardSphereSystem::collide(Index i, Index j) {
  State& a = state_[static_cast<std::size_t>(i)];
  State& b = state_[static_cast<std::size_t>(j)];
  double r[3], u[3];
  for (int k = 0; k < 3; ++k) {
    r[k] = a.x[k] - b.x[k];
    u[k] = a.v[k] - b.v[k];
  }
  minimumImage(r);
  const double s0 = a.r0 + b.r0;
  const double sd = growth_ * s0;
  const double s = s0 + sd * clock_;
  const double hdot = approachRate(r, u, sd);
  if (!(hdot < 0.0)) {
    ++total_.missed;
    return;
  }
  const double dist = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
  if (dist < s) {
    const double overlap = (s - dist) / s;
    maxOverlap_ = std::max(maxOverlap_, overlap);
    if (overlap > options_.overlapLimit) {
      throw SimulationError(fmt::format(
          "particles {} and {} overlap by {:.3g} of their contact distance at t = {} (limit {:.3g}): the event "
          "schedule lost a collision",
          external(i), external(j), overlap, time(), options_.overlapLimit));
    }
  }
  const double reduced = 1.0 / (inverseMass_[i] + inverseMass_[j]);
  const double impulse = collisionImpulse(hdot, reduced, options_.minSeparationSpeed);
  flushKinetic();
  const double before = mass_[i] * (a.v[0] * a.v[0] + a.v[1] * a.v[1] + a.v[2] * a.v[2]) +
                        mass_[j] * (b.v[0] * b.v[0] + b.v[1] * b.v[1] + b.v[2] * b.v[2]);
  const double ka = impulse * inverseMass_[i] / dist, kb = impulse * inverseMass_[j] / dist;
  for (int k = 0; k < 3; ++k) {
    a.v[k] += ka * r[k];
    b.v[k] -= kb * r[k];
  }
  const double after = mass_[i] * (a.v[0] * a.v[0] + a.v[1] * a.v[1] + a.v[2] * a.v[2]) +
                       mass_[j] * (b.v[0] * b.v[0] + b.v[1] * b.v[1] + b.v[2] * b.v[2]);
  kinetic_ += 0.5 * (after - before);
  window_.virial += dist * impulse;
  ++window_.collisions;
  ++total_.collisions;
  ++classTotal_[static_cast<std::size_t>(hood_[static_cast<std::size_t>(i)].cls)].collisions;
  ++classTotal_[static_cast<std::size_t>(hood_[static_cast<std::size_t>(j)].cls)].collisions;
  std::int64_t& ci = collisionsInRun_[static_cast<std::size_t>(i)];
  std::int64_t& cj = collisionsInRun_[static_cast<std::size_t>(j)];
  lastCollision_ = {std::min(external(i), external(j)), std::max(external(i), external(j)), time()};
  recent_[recentNext_] = {i, j};
  recentNext_ = (recentNext_ + 1) % recent_.size();
  if (++ci > watchdogLimit_) watchdogTrip(i);
  if (++cj > watchdogLimit_) watchdogTrip(j);
}

void HardSphereSystem::collideWithWall(Index i, int wall) {
  State& s = state_[static_cast<std::size_t>(i)];
  const int k = wall / 2;
  const bool upper = (wall % 2) == 1;
  const double rate = growth_ * s.r0;
  const double closing = upper ? s.v[k] + rate : rate - s.v[k];
  if (!(closing > 0.0)) {
    ++total_.missed;
    return;
  }
  const double opening = std::max(closing, options_.minSeparationSpeed);
  const double vNew = upper ? -rate - opening : rate + opening;
  flushKinetic();
  const double dv = vNew - s.v[k];
  kinetic_ += 0.5 * mass_[i] * (vNew * vNew - s.v[k] * s.v[k]);
  s.v[k] = vNew;
  window_.virial += radiusAt(s) * mass_[i] * std::abs(dv);
  ++total_.wallCollisions;
}

[[noreturn]] void HardSphereSystem::watchdogTrip(Index i) const {
  std::string pairs;
  for (std::size_t k = 0; k < recent_.size(); ++k) {
    const auto& p = recent_[(recentNext_ + k) % recent_.size()];
    if (p[0] == p[1]) continue;
    pairs += fmt::format(" ({}, {})", external(p[0]), external(p[1]));
  }
  throw SimulationError(fmt::format(
      "watchdog: particle {} took part in {} collisions in this run (limit {}) at t = {}: an unbounded collision "
      "sequence (jammed beyond what double precision resolves, or growth too fast for the pressure); last "
      "collisions:{}",
      external(i), collisionsInRun_[static_cast<std::size_t>(i)], watchdogLimit_, time(), pairs));
}

// ---------------------------------------------------------------------------------------------------
// Event loop

void HardSphereSystem::process(Index i) {
  const std::size_t ui = static_cast<std::size_t>(i);
  const Event e = event_[ui];
  POLYDEM_ASSERT(e.time >= clock_, "event in the past");
  if (e.time == lastEventTime_) {
    if (++sameTimeEvents_ > 10 * static_cast<std::int64_t>(count()) + 1000) {
      std::string pairs;
      for (const auto& p : recent_) {
        if (p[0] != p[1]) pairs += fmt::format(" ({}, {})", external(p[0]), external(p[1]));
      }
      throw SimulationError(fmt::format(
          "watchdog: {} events without the clock advancing at t = {} (particle {}): a zero-delay collision loop; "
          "recent collisions:{}",
          sameTimeEvents_, time(), external(i), pairs));
    }
  } else {
    sameTimeEvents_ = 0;
    lastEventTime_ = e.time;
  }
  clock_ = e.time;
  // Software pipelining of the loads, which bound the event loop (the working set of a 10^4-particle
  // system exceeds L2): the particle most likely to be processed next (the smallest child of the heap
  // root) gets its event, state and neighbourhood fetched now, one event ahead; i's neighbourhood was
  // fetched that way, so its list can be requested at once; a collision partner's state and
  // neighbourhood are requested before the collision arithmetic, and its list before i predicts.
  const Index next = queue_.runnerUp(e.kind == EventKind::Collision ? e.partner : -1);
  __builtin_prefetch(&event_[static_cast<std::size_t>(next)]);
  __builtin_prefetch(&state_[static_cast<std::size_t>(next)]);
  __builtin_prefetch(&hood_[static_cast<std::size_t>(next)]);
  prefetchList(i);
  switch (e.kind) {
    case EventKind::Collision: {
      const Index j = e.partner;
      const std::size_t uj = static_cast<std::size_t>(j);
      __builtin_prefetch(&state_[uj]);
      __builtin_prefetch(&hood_[uj]);
      // What collide() reads besides the states: at 10^5 particles these loads missed every cache and the
      // collision waited on them.
      __builtin_prefetch(&inverseMass_[i]);
      __builtin_prefetch(&inverseMass_[j]);
      __builtin_prefetch(&mass_[i]);
      __builtin_prefetch(&mass_[j]);
      __builtin_prefetch(&collisionsInRun_[ui]);
      __builtin_prefetch(&collisionsInRun_[uj]);
      advance(i);
      advance(j);
      collide(i, j);
      prefetchList(j);
      // j's heap key is already the current time. Predicting i first cannot claim j (the horizon test
      // t_c < t_e(j) = now is strict), then j predicts at once instead of being popped as a check: the
      // "check after binary collision" of Donev 2006, Algorithm 2, step 8, without its two heap operations.
      event_[static_cast<std::size_t>(j)] = Event{clock_, i, EventKind::PartnerCheck};
      predict(i);
      predict(j);
      break;
    }
    case EventKind::PartnerCheck:
    case EventKind::Check:
    case EventKind::None:
      ++total_.checks;
      advance(i);
      predict(i);
      break;
    case EventKind::Exit:
      ++total_.exits;
      ++classTotal_[static_cast<std::size_t>(hood_[ui].cls)].exits;
      advance(i);
      refreshNeighbourhood(i);
      break;
    case EventKind::Wall:
      advance(i);
      collideWithWall(i, e.partner);
      predict(i);
      break;
  }
}

EventCounts HardSphereSystem::run(std::int64_t collisions, double duration) {
  const EventCounts before = total_;
  if (count() == 0 || collisions <= 0) return {};
  const double tEnd = clock_ + duration;
  std::fill(collisionsInRun_.begin(), collisionsInRun_.end(), 0);
  const double limit = options_.watchdogFactor * 2.0 * static_cast<double>(collisions) / count() +
                       static_cast<double>(options_.watchdogSlack);
  watchdogLimit_ = limit < 9e18 ? static_cast<std::int64_t>(limit) : std::numeric_limits<std::int64_t>::max();
  const std::int64_t target = collisions > std::numeric_limits<std::int64_t>::max() - total_.collisions
                                  ? std::numeric_limits<std::int64_t>::max()
                                  : total_.collisions + collisions;
  while (total_.collisions < target) {
    const Index i = queue_.top();
    const double te = queue_.topKey();
    if (te > tEnd) {
      if (std::isfinite(tEnd)) clock_ = tEnd;
      break;
    }
    if (te == kInfinity) break;
    process(i);
  }
  return total_ - before;
}

bool HardSphereSystem::step() {
  if (count() == 0 || queue_.topKey() == kInfinity) return false;
  process(queue_.top());
  return true;
}

Event HardSphereSystem::nextEvent() const {
  if (count() == 0) return Event{kInfinity, -1, EventKind::None};
  return event_[static_cast<std::size_t>(queue_.top())];
}

}  // namespace polydem::edmd
