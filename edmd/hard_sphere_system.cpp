#include "edmd/hard_sphere_system.hpp"

#include "core/morton.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <fmt/format.h>

#include "broadphase/registry.hpp"
#include "core/errors.hpp"
#include "edmd/kinematics.hpp"

namespace polydem::edmd {

namespace {

constexpr const char* kAxis = "xyz";

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

double PressureWindow::reducedPressure() const {
  if (!(kineticIntegral > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  return 1.0 + virial / (2.0 * kineticIntegral);
}

HardSphereSystem::HardSphereSystem(const Box& box, const Eigen::Matrix3Xd& position, const Eigen::VectorXd& radius,
                                   const Eigen::Matrix3Xd& velocity, SystemOptions options)
    : box_(box), options_(std::move(options)) {
  if (!(options_.neighbourhoodScale > 1.0) || !std::isfinite(options_.neighbourhoodScale)) {
    throw ConfigError(fmt::format("neighbourhood scale must be > 1, got {}", options_.neighbourhoodScale));
  }
  if (!(options_.skinCap > 0.0)) throw ConfigError(fmt::format("skin cap must be > 0, got {}", options_.skinCap));
  if (!(options_.skinFloor > 0.0)) throw ConfigError(fmt::format("skin floor must be > 0, got {}", options_.skinFloor));
  skinFloor_ = options_.skinFloor;
  if (!(options_.minSeparationSpeed > 0.0)) {
    throw ConfigError(fmt::format("minimum separation speed must be > 0, got {}", options_.minSeparationSpeed));
  }
  if (!(options_.exitWork > 0.0) || !std::isfinite(options_.exitWork)) {
    throw ConfigError(fmt::format("exit work must be positive and finite, got {}", options_.exitWork));
  }
  if (!(options_.overlapLimit > 0.0)) {
    throw ConfigError(fmt::format("overlap limit must be > 0, got {}", options_.overlapLimit));
  }
  for (int k = 0; k < 3; ++k) {
    periodic_[k] = box_.periodic(k);
    length_[k] = box_.length(k);
    half_[k] = 0.5 * length_[k];
    wrap_[k] = periodic_[k] ? length_[k] : 0.0;
    hasWalls_ = hasWalls_ || !periodic_[k];
  }
  checkInput(position, radius, velocity);

  const Index n = static_cast<Index>(radius.size());
  state_.resize(static_cast<std::size_t>(n));
  external_.resize(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) external_[static_cast<std::size_t>(i)] = i;
  mass_.resize(n);
  inverseMass_.resize(n);
  double meanVolume = 0.0;
  for (Index i = 0; i < n; ++i) meanVolume += radius[i] * radius[i] * radius[i];
  meanVolume /= std::max<Index>(n, 1);
  for (Index i = 0; i < n; ++i) {
    State& s = state_[static_cast<std::size_t>(i)];
    const Eigen::Vector3d x = box_.wrap(position.col(i));
    for (int k = 0; k < 3; ++k) {
      s.x[k] = x[k];
      s.v[k] = velocity(k, i);
    }
    s.t = 0.0;
    s.r0 = radius[i];
    mass_[i] = radius[i] * radius[i] * radius[i] / meanVolume;
    inverseMass_[i] = 1.0 / mass_[i];
    kinetic_ += 0.5 * mass_[i] * velocity.col(i).squaredNorm();
  }
  sizeRatio_ = n > 0 ? radius.maxCoeff() / radius.minCoeff() : 1.0;
  event_.assign(static_cast<std::size_t>(n), Event{kInfinity, -1, EventKind::None});
  collisionsInRun_.assign(static_cast<std::size_t>(n), 0);
  nbCentre_.resize(3, n);
  nbRadius_.resize(n);
  hood_.resize(static_cast<std::size_t>(n));
  broad_ = broadphase::makeBroadPhase(options_.broadPhase);
  rebuildNeighbourhoods();
  resetSchedule();
}

HardSphereSystem::~HardSphereSystem() = default;

void HardSphereSystem::checkInput(const Eigen::Matrix3Xd& position, const Eigen::VectorXd& radius,
                                  const Eigen::Matrix3Xd& velocity) const {
  const Index n = static_cast<Index>(radius.size());
  if (position.cols() != n || velocity.cols() != n) {
    throw ConfigError(fmt::format("hard-sphere system: {} radii but {} positions and {} velocities", n, position.cols(),
                                  velocity.cols()));
  }
  double rmax = 0.0;
  for (Index i = 0; i < n; ++i) {
    if (!(radius[i] > 0.0) || !std::isfinite(radius[i])) {
      throw ConfigError(fmt::format("particle {}: radius must be positive and finite, got {}", i, radius[i]));
    }
    if (!position.col(i).allFinite() || !velocity.col(i).allFinite()) {
      throw ConfigError(fmt::format("particle {}: non-finite position or velocity", i));
    }
    rmax = std::max(rmax, radius[i]);
    for (int k = 0; k < 3; ++k) {
      if (periodic_[k]) continue;
      const double x = position(k, i);
      if (x - radius[i] < -1e-12 * radius[i] || (length_[k] - x) - radius[i] < -1e-12 * radius[i]) {
        throw ConfigError(fmt::format("particle {}: sphere at {} = {} with radius {} crosses a wall of the box {}", i,
                                      kAxis[k], x, radius[i], box_.describe()));
      }
    }
  }
  if (n == 0) return;
  // Every periodic image must stay unambiguous for the largest neighbourhood (radius r_max + its skin);
  // the skins shrink to fit if needed, the spheres themselves must leave room for some skin.
  const double minLength = periodicLength();
  if (std::isfinite(minLength) && !(rmax < 0.25 * minLength * (1.0 - 1e-6))) {
    throw ConfigError(
        fmt::format("the largest sphere (radius {}) does not fit 4 times into the shortest periodic box edge {}: every "
                    "periodic image must be unambiguous; use more particles (or a narrower size distribution)",
                    rmax, minLength));
  }
  // Overlaps, through a broad phase on the spheres themselves.
  Eigen::Matrix3Xd centres(3, n);
  for (Index i = 0; i < n; ++i) centres.col(i) = box_.wrap(position.col(i));
  auto finder = broadphase::makeBroadPhase(options_.broadPhase);
  const SphereView view{centres, radius};
  finder->build(view, box_, 0.0);
  std::vector<broadphase::Pair> pairs;
  finder->findPairs(view, pairs);
  for (const broadphase::Pair& p : pairs) {
    const double s = radius[p.i] + radius[p.j];
    const double dist = box_.minimumImage(centres.col(p.i) - centres.col(p.j)).norm();
    if (s - dist > 1e-12 * s) {
      throw ConfigError(
          fmt::format("particles {} and {} overlap: centre distance {} < sum of radii {} (relative {:.3g})", p.i, p.j,
                      dist, s, (s - dist) / s));
    }
  }
}

// ---------------------------------------------------------------------------------------------------
// Time, state and schedule

void HardSphereSystem::advance(Index i) {
  State& s = state_[static_cast<std::size_t>(i)];
  const double dt = clock_ - s.t;
  if (dt != 0.0) {
    for (int k = 0; k < 3; ++k) s.x[k] += s.v[k] * dt;
    s.t = clock_;
  }
  // A particle moves less than its neighbourhood room between updates, far below a box length, so one
  // shift wraps it; x - L is exact for x in [L, 2L).
  for (int k = 0; k < 3; ++k) {
    if (!periodic_[k]) continue;
    if (s.x[k] >= length_[k]) {
      s.x[k] -= length_[k];
    } else if (s.x[k] < 0.0) {
      s.x[k] += length_[k];
      if (s.x[k] >= length_[k]) s.x[k] = 0.0;
    }
  }
}

void HardSphereSystem::advanceAll() {
  for (Index i = 0; i < count(); ++i) advance(i);
}

void HardSphereSystem::resetSchedule() {
  // Algorithm 4 (seed :3127-3131): every particle gets a check now; the pops re-predict everything.
  for (Event& e : event_) e = Event{clock_, -1, EventKind::Check};
  queue_.assign(std::vector<double>(event_.size(), clock_));
  sameTimeEvents_ = 0;
  lastEventTime_ = -1.0;
}

void HardSphereSystem::flushKinetic() {
  const double dt = clock_ - kineticMark_;
  window_.kineticIntegral += kinetic_ * dt;
  window_.duration += dt;
  kineticMark_ = clock_;
}

void HardSphereSystem::synchronise() {
  flushKinetic();
  advanceAll();
  kinetic_ = 0.0;
  for (Index i = 0; i < count(); ++i) {
    State& s = state_[static_cast<std::size_t>(i)];
    s.r0 = radiusAt(s);
    s.t = 0.0;
    kinetic_ += 0.5 * mass_[i] * (s.v[0] * s.v[0] + s.v[1] * s.v[1] + s.v[2] * s.v[2]);
  }
  elapsed_ += clock_;
  clock_ = 0.0;
  kineticMark_ = 0.0;
  const bool resort = options_.resortInterval > 0.0 &&
                      static_cast<double>(total_.collisions - collisionsAtSort_) > options_.resortInterval * count();
  const int trend = skinTrend();
  const bool retune = options_.adaptiveSkin && total_.collisions - collisionsAtRebuild_ > 5 * std::int64_t{count()} &&
                      (trend > 0 || (trend < 0 && skinFloor_ > options_.skinFloor));
  if (resort || retune) rebuildNeighbourhoods();
  resetSchedule();
}

void HardSphereSystem::setGrowthRate(double relativeRate) {
  if (!std::isfinite(relativeRate)) throw ConfigError(fmt::format("growth rate must be finite, got {}", relativeRate));
  synchronise();
  growth_ = relativeRate;
}

void HardSphereSystem::scaleVelocities(double factor) {
  if (!std::isfinite(factor)) throw ConfigError(fmt::format("velocity scale factor must be finite, got {}", factor));
  synchronise();
  for (State& s : state_) {
    for (double& v : s.v) v *= factor;
  }
  kinetic_ = 0.0;
  for (Index i = 0; i < count(); ++i) {
    const State& s = state_[static_cast<std::size_t>(i)];
    kinetic_ += 0.5 * mass_[i] * (s.v[0] * s.v[0] + s.v[1] * s.v[1] + s.v[2] * s.v[2]);
  }
}

void HardSphereSystem::setThermalSpeed(double speed) {
  if (!(speed >= 0.0)) throw ConfigError(fmt::format("thermal speed must be >= 0, got {}", speed));
  synchronise();
  const double current = thermalSpeed();
  if (!(current > 0.0)) {
    throw ConfigError("cannot rescale the thermal speed: every particle is at rest (set velocities first)");
  }
  scaleVelocities(speed / current);
}

void HardSphereSystem::setVelocities(const Eigen::Matrix3Xd& velocity) {
  if (velocity.cols() != count()) {
    throw ConfigError(fmt::format("setVelocities: {} columns for {} particles", velocity.cols(), count()));
  }
  if (!velocity.allFinite()) throw ConfigError("setVelocities: non-finite velocity");
  synchronise();
  kinetic_ = 0.0;
  for (Index i = 0; i < count(); ++i) {
    State& s = state_[static_cast<std::size_t>(i)];
    for (int k = 0; k < 3; ++k) s.v[k] = velocity(k, external(i));
    kinetic_ += 0.5 * mass_[i] * velocity.col(external(i)).squaredNorm();
  }
}

// ---------------------------------------------------------------------------------------------------
// Neighbourhoods

void HardSphereSystem::sortSpatially() {
  // Precondition: every particle advanced to clock_ (events are reset by the caller).
  const Index n = count();
  std::vector<std::pair<std::uint64_t, Index>> keys(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) {
    const State& s = state_[static_cast<std::size_t>(i)];
    keys[static_cast<std::size_t>(i)] = {mortonKey(s.x, box_, 10), i};
  }
  std::sort(keys.begin(), keys.end());
  std::vector<State> state(state_.size());
  std::vector<Index> external(external_.size());
  std::vector<std::int64_t> runCounts(collisionsInRun_.size());
  Eigen::VectorXd mass(n), inverseMass(n);
  for (Index k = 0; k < n; ++k) {
    const std::size_t from = static_cast<std::size_t>(keys[static_cast<std::size_t>(k)].second);
    const std::size_t to = static_cast<std::size_t>(k);
    state[to] = state_[from];
    external[to] = external_[from];
    runCounts[to] = collisionsInRun_[from];
    mass[k] = mass_[static_cast<Index>(from)];
    inverseMass[k] = inverseMass_[static_cast<Index>(from)];
  }
  state_.swap(state);
  external_.swap(external);
  collisionsInRun_.swap(runCounts);
  mass_.swap(mass);
  inverseMass_.swap(inverseMass);
  collisionsAtSort_ = total_.collisions;
  recent_ = {};
}

void HardSphereSystem::rebuildNeighbourhoods() {
  // Precondition: every particle advanced to clock_.
  const Index n = count();
  if (n == 0) return;
  sortSpatially();
  double rmin = kInfinity;
  for (const State& s : state_) rmin = std::min(rmin, radiusAt(s));
  nbCentre_.resize(3, n);
  nbRadius_.resize(n);
  if (options_.adaptiveSkin &&
      (total_.collisions - collisionsAtRebuild_) + (total_.exits - exitsAtRebuild_) >= std::int64_t{n}) {
    const int trend = skinTrend();
    if (trend > 0) skinFloor_ = std::min(skinFloor_ * 1.3, 1e3);
    if (trend < 0) skinFloor_ = std::max(skinFloor_ / 1.15, options_.skinFloor);
  }
  collisionsAtRebuild_ = total_.collisions;
  exitsAtRebuild_ = total_.exits;
  pairsAtRebuild_ = pairWork_;
  const double mu1 = options_.neighbourhoodScale - 1.0;
  const double floor = skinFloor_ * rmin;
  // The broad phase needs periodic edges of at least 4 neighbourhood radii.
  double rmax = 0.0;
  for (const State& s : state_) rmax = std::max(rmax, radiusAt(s));
  const double skinLimit = 0.25 * periodicLength() * (1.0 - 1e-9) - rmax;
  // Skins squeezed far below normal would make every sphere exit at once, rebuild after rebuild.
  if (!(skinLimit > 0.1 * mu1 * rmin)) {
    const std::string what = fmt::format(
        "at t = {} the largest sphere (radius {}) leaves no room for its neighbourhood: 4 neighbourhood radii "
        "must fit into the shortest periodic box edge {}; use more particles",
        time(), rmax, periodicLength());
    if (total_.rebuilds == 0) throw ConfigError(what);
    throw SimulationError(what);
  }
  for (Index i = 0; i < n; ++i) {
    const State& s = state_[static_cast<std::size_t>(i)];
    Hood& h = hood_[static_cast<std::size_t>(i)];
    const double r = radiusAt(s);
    const double skin = std::max(std::min(r, options_.skinCap * rmin), floor * std::pow(rmin / r, 1.5));
    h.skin = std::min(mu1 * skin, skinLimit);
    h.radius = r + h.skin;
    for (int k = 0; k < 3; ++k) h.centre[k] = s.x[k];
    nbRadius_[i] = h.radius;
    nbCentre_.col(i) = Eigen::Vector3d(s.x[0], s.x[1], s.x[2]);
  }
  const SphereView view{nbCentre_, nbRadius_};
  try {
    broad_->build(view, box_, 0.0);
  } catch (const ConfigError& e) {
    if (total_.rebuilds == 0) throw;
    throw SimulationError(fmt::format(
        "rebuilding the neighbour lists at t = {}: {} (the spheres have grown too large for this box: use more "
        "particles)",
        time(), e.what()));
  }
  broad_->findPairs(view, pairScratch_);
  hoodGrid_.build(box_, nbCentre_, nbRadius_);
  for (Hood& h : hood_) h.size = 0;
  for (const broadphase::Pair& p : pairScratch_) {
    ++hood_[static_cast<std::size_t>(p.i)].size;
    ++hood_[static_cast<std::size_t>(p.j)].size;
  }
  Index offset = 0;
  for (Hood& h : hood_) {
    h.begin = offset;
    h.capacity = h.size + 6 + h.size / 3;  // spare room for neighbourhood exits
    offset += h.capacity;
    h.size = 0;
  }
  nbData_.assign(static_cast<std::size_t>(offset), -1);
  for (const broadphase::Pair& p : pairScratch_) {
    Hood& a = hood_[static_cast<std::size_t>(p.i)];
    Hood& b = hood_[static_cast<std::size_t>(p.j)];
    nbData_[static_cast<std::size_t>(a.begin + a.size++)] = p.j;
    nbData_[static_cast<std::size_t>(b.begin + b.size++)] = p.i;
  }
  // Sorted lists: the trajectory does not depend on the backend's pair order.
  for (const Hood& h : hood_) std::sort(nbData_.begin() + h.begin, nbData_.begin() + h.begin + h.size);
  ++total_.rebuilds;
}

void HardSphereSystem::relocateList(Index i, Index capacity) {
  Hood& h = hood_[static_cast<std::size_t>(i)];
  const Index begin = static_cast<Index>(nbData_.size());
  nbData_.resize(nbData_.size() + static_cast<std::size_t>(capacity), -1);
  std::copy(nbData_.begin() + h.begin, nbData_.begin() + h.begin + h.size, nbData_.begin() + begin);
  h.begin = begin;
  h.capacity = capacity;
  ++total_.relocatedLists;
}

void HardSphereSystem::insertNeighbour(Index i, Index j) {
  Hood& h = hood_[static_cast<std::size_t>(i)];
  if (h.size == h.capacity) relocateList(i, 2 * h.capacity + 8);
  Index* first = nbData_.data() + h.begin;
  Index* last = first + h.size;
  Index* at = std::lower_bound(first, last, j);
  std::copy_backward(at, last, last + 1);
  *at = j;
  ++h.size;
}

void HardSphereSystem::eraseNeighbour(Index i, Index j) {
  Hood& h = hood_[static_cast<std::size_t>(i)];
  Index* first = nbData_.data() + h.begin;
  Index* last = first + h.size;
  Index* at = std::lower_bound(first, last, j);
  if (at == last || *at != j) return;
  std::copy(at + 1, last, at);
  --h.size;
}

void HardSphereSystem::refreshNeighbourhood(Index i) {
  const std::size_t ui = static_cast<std::size_t>(i);
  const State& s = state_[ui];
  auto restart = [&] {
    advanceAll();
    rebuildNeighbourhoods();
    resetSchedule();
  };
  Hood& hood = hood_[ui];
  if (hood.radius - radiusAt(s) < 0.5 * hood.skin) {
    restart();  // growth has used half of the room: a new epoch with larger neighbourhoods
    return;
  }
  if (options_.adaptiveSkin && total_.exits - exitsAtRebuild_ > 2 * std::int64_t{count()} && skinTrend() > 0) {
    restart();  // skins too thin for how far the spheres fly: rebuild with a larger skin floor
    return;
  }
  for (int k = 0; k < 3; ++k) hood.centre[k] = s.x[k];
  nbCentre_.col(i) = Eigen::Vector3d(s.x[0], s.x[1], s.x[2]);
  hoodGrid_.move(i, s.x);
  hoodGrid_.overlapping(i, scratch_);
  // Reverse entries: drop i from lists it left, add it to lists it entered (both lists sorted).
  const std::span<const Index> old = neighboursOf(i);
  added_.clear();
  removed_.clear();
  std::size_t a = 0, b = 0;
  while (a < old.size() || b < scratch_.size()) {
    if (b == scratch_.size() || (a < old.size() && old[a] < scratch_[b])) {
      removed_.push_back(old[a++]);
    } else if (a == old.size() || scratch_[b] < old[a]) {
      added_.push_back(scratch_[b++]);
    } else {
      ++a;
      ++b;
    }
  }
  for (Index j : removed_) eraseNeighbour(j, i);
  for (Index j : added_) insertNeighbour(j, i);
  const Index size = static_cast<Index>(scratch_.size());
  if (size > hood.capacity) relocateList(i, size + 8 + size / 2);
  std::copy(scratch_.begin(), scratch_.end(), nbData_.begin() + hood.begin);
  hood.size = size;
  predict(i);
}

// ---------------------------------------------------------------------------------------------------
// Prediction

inline double HardSphereSystem::wrapped(double d, int axis) const { return wrapOnce(d, half_[axis], wrap_[axis]); }

inline bool HardSphereSystem::keepEarlier(double tau, double tc, double horizon, double& best) {
  return keepEarlierImpl(tau, tc, horizon, best);
}

void HardSphereSystem::predict(Index i) {
  // Algorithm 5 (seed :3141-3190), NNL mode.
  const std::size_t ui = static_cast<std::size_t>(i);
  const State& si = state_[ui];
  const std::span<const Index> list = neighboursOf(i);
  // Start loading the first neighbours' states while the exit time is computed.
  for (std::size_t k = 0; k < std::min<std::size_t>(list.size(), 4); ++k) {
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
    const Event* events = event_.data();
    double bestTime = best.time;
    Index bestPartner = -1;
    for (std::size_t k = 0; k < m; ++k) {
      const Index ahead = list[std::min(k + 4, m - 1)];
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
      // pairCollisionDelay() rearranged so that the common case has no data-dependent branch (the sign
      // of b is a coin flip; mispredicting it cost more than the arithmetic). For an open gap (c > 0)
      // the positive root, when there is one, is c / (sqrt(b^2 - a c) - b) in every case; otherwise this
      // expression is NaN (the spheres miss: disc < 0) or <= 0 (gap opening, a >= 0), which the
      // acceptance test below rejects. Only b >= 0 with a < 0 (growth overtaking a separating pair)
      // takes the other, cancellation-free form -(b + sqrt) / a.
      const double root = std::sqrt(q.b * q.b - q.a * q.c);
      const double den = root - q.b;
      // Most pairs cannot beat the horizon; in the common case (open gap, no growth root) reject them
      // without the division: tau = c / den < H <=> c < H den for den > 0 (NaN and den <= 0 fail, as
      // the exact test below would). The margin 1e-9 (clock + H) makes the shortcut conservative, so
      // the accepted pair and its time are exactly those of the full computation.
      const double horizon = std::min(bestTime, events[j].time) - clock;
      if (q.c > 0.0 && !(q.a < 0.0 && q.b >= 0.0) && !(q.c < (horizon + 1e-9 * (clock + horizon)) * den)) continue;
      double tau = q.c / den;
      if (q.a < 0.0 && q.b >= 0.0) [[unlikely]]
        tau = -(q.b + root) / q.a;
      if (q.c <= 0.0) [[unlikely]]
        tau = pairCollisionDelay(q, approachRate(r, u, sd) < 0.0);
      // Accept before both the best so far and j's own event (seed :3173-3180), as a branch-free
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
  const Index next = queue_.runnerUp();
  __builtin_prefetch(&event_[static_cast<std::size_t>(next)]);
  __builtin_prefetch(&state_[static_cast<std::size_t>(next)]);
  __builtin_prefetch(&hood_[static_cast<std::size_t>(next)]);
  prefetchList(i);
  switch (e.kind) {
    case EventKind::Collision: {
      const Index j = e.partner;
      __builtin_prefetch(&state_[static_cast<std::size_t>(j)]);
      __builtin_prefetch(&hood_[static_cast<std::size_t>(j)]);
      advance(i);
      advance(j);
      collide(i, j);
      prefetchList(j);
      // j's heap key is already the current time. Predicting i first cannot claim j (the horizon test
      // t_c < t_e(j) = now is strict), then j predicts at once instead of being popped as a check: the
      // seed's "check after binary collision" (:3106-3108) without its two heap operations.
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

// ---------------------------------------------------------------------------------------------------
// Observables

Eigen::Matrix3Xd HardSphereSystem::positions() const {
  Eigen::Matrix3Xd out(3, count());
  for (Index i = 0; i < count(); ++i) {
    const State& s = state_[static_cast<std::size_t>(i)];
    const double dt = clock_ - s.t;
    out.col(external(i)) = box_.wrap(Eigen::Vector3d(s.x[0] + s.v[0] * dt, s.x[1] + s.v[1] * dt, s.x[2] + s.v[2] * dt));
  }
  return out;
}

Eigen::Matrix3Xd HardSphereSystem::velocities() const {
  Eigen::Matrix3Xd out(3, count());
  for (Index i = 0; i < count(); ++i) {
    const State& s = state_[static_cast<std::size_t>(i)];
    out.col(external(i)) = Eigen::Vector3d(s.v[0], s.v[1], s.v[2]);
  }
  return out;
}

Eigen::VectorXd HardSphereSystem::radii() const {
  Eigen::VectorXd out(count());
  for (Index i = 0; i < count(); ++i) out[external(i)] = radiusAt(state_[static_cast<std::size_t>(i)]);
  return out;
}

Eigen::VectorXd HardSphereSystem::masses() const {
  Eigen::VectorXd out(count());
  for (Index i = 0; i < count(); ++i) out[external(i)] = mass_[i];
  return out;
}

double HardSphereSystem::thermalSpeed() const {
  const double m = mass_.sum();
  return m > 0.0 ? std::sqrt(2.0 * kinetic_ / m) : 0.0;
}

Eigen::Vector3d HardSphereSystem::momentum() const {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (Index i = 0; i < count(); ++i) {
    const State& s = state_[static_cast<std::size_t>(i)];
    p += mass_[i] * Eigen::Vector3d(s.v[0], s.v[1], s.v[2]);
  }
  return p;
}

double HardSphereSystem::packingFraction() const {
  double volume = 0.0;
  for (const State& s : state_) {
    const double r = radiusAt(s);
    volume += r * r * r;
  }
  return 4.0 / 3.0 * kPi * volume / box_.volume();
}

double HardSphereSystem::largestRadius() const {
  double r = 0.0;
  for (const State& s : state_) r = std::max(r, radiusAt(s));
  return r;
}

double HardSphereSystem::smallestRadius() const {
  double r = kInfinity;
  for (const State& s : state_) r = std::min(r, radiusAt(s));
  return count() ? r : 0.0;
}

PressureWindow HardSphereSystem::pressureWindow() const {
  PressureWindow w = window_;
  const double dt = clock_ - kineticMark_;
  w.kineticIntegral += kinetic_ * dt;
  w.duration += dt;
  return w;
}

void HardSphereSystem::resetPressureWindow() {
  window_ = PressureWindow{};
  kineticMark_ = clock_;
}

std::string HardSphereSystem::describeBroadPhase() const { return broad_->describe(); }

double HardSphereSystem::periodicLength() const {
  double length = kInfinity;
  for (int k = 0; k < 3; ++k) {
    if (periodic_[k]) length = std::min(length, length_[k]);
  }
  return length;
}

int HardSphereSystem::skinTrend() const {
  // Narrow distributions (size ratio < 2) keep the exits-per-collision rule: both rules leave their
  // skins at the floor at phi 0.5, and it keeps the trajectories the jamming results of docs/edmd.md
  // and tests/edmd were validated with.
  if (sizeRatio_ < 2.0) {
    const double exits = exitRatioSinceRebuild();
    return exits > 0.8 ? 1 : (exits < 0.2 ? -1 : 0);
  }
  const double exitWork = options_.exitWork * static_cast<double>(total_.exits - exitsAtRebuild_);
  const double pairWork = static_cast<double>(pairWork_ - pairsAtRebuild_);
  if (exitWork > 2.0 * pairWork) return 1;
  if (exitWork < 0.5 * pairWork) return -1;
  return 0;
}

double HardSphereSystem::exitRatioSinceRebuild() const {
  const std::int64_t collisions = total_.collisions - collisionsAtRebuild_;
  return collisions > 0 ? static_cast<double>(total_.exits - exitsAtRebuild_) / static_cast<double>(collisions) : 0.0;
}

double HardSphereSystem::meanNeighbours() const {
  double total = 0.0;
  for (const Hood& h : hood_) total += h.size;
  return count() ? total / count() : 0.0;
}

// ---------------------------------------------------------------------------------------------------
// Checkpoint state

SystemState HardSphereSystem::saveState() {
  synchronise();
  const Index n = count();
  const std::size_t un = static_cast<std::size_t>(n);
  SystemState out;
  out.position.resize(3 * un);
  out.velocity.resize(3 * un);
  out.radius.resize(un);
  out.mass.resize(un);
  out.external.resize(un);
  out.hoodCentre.resize(3 * un);
  out.hoodRadius.resize(un);
  out.hoodSkin.resize(un);
  out.hoodBegin.resize(un);
  out.hoodSize.resize(un);
  out.hoodCapacity.resize(un);
  for (std::size_t i = 0; i < un; ++i) {
    const State& s = state_[i];
    const Hood& h = hood_[i];
    for (std::size_t k = 0; k < 3; ++k) {
      out.position[3 * i + k] = s.x[k];
      out.velocity[3 * i + k] = s.v[k];
      out.hoodCentre[3 * i + k] = h.centre[k];
    }
    out.radius[i] = s.r0;
    out.mass[i] = mass_[static_cast<Index>(i)];
    out.external[i] = external_[i];
    out.hoodRadius[i] = h.radius;
    out.hoodSkin[i] = h.skin;
    out.hoodBegin[i] = h.begin;
    out.hoodSize[i] = h.size;
    out.hoodCapacity[i] = h.capacity;
  }
  out.neighbours.assign(nbData_.begin(), nbData_.end());
  out.growth = growth_;
  out.elapsed = elapsed_;
  out.skinFloor = skinFloor_;
  out.sizeRatio = sizeRatio_;
  out.kinetic = kinetic_;
  out.maxOverlap = maxOverlap_;
  out.window = window_;
  out.total = total_;
  out.collisionsAtSort = collisionsAtSort_;
  out.collisionsAtRebuild = collisionsAtRebuild_;
  out.exitsAtRebuild = exitsAtRebuild_;
  out.pairsAtRebuild = pairsAtRebuild_;
  out.pairWork = pairWork_;
  out.lastCollision = lastCollision_;
  return out;
}

void HardSphereSystem::restoreState(const SystemState& state) {
  const Index n = count();
  const std::size_t un = static_cast<std::size_t>(n);
  auto require = [&](bool ok, const char* what) {
    if (!ok) throw InputError(fmt::format("engine state for {} particles: {}", n, what));
  };
  require(state.position.size() == 3 * un && state.velocity.size() == 3 * un && state.hoodCentre.size() == 3 * un,
          "positions, velocities or neighbourhood centres of the wrong length");
  require(state.radius.size() == un && state.mass.size() == un && state.external.size() == un &&
              state.hoodRadius.size() == un && state.hoodSkin.size() == un && state.hoodBegin.size() == un &&
              state.hoodSize.size() == un && state.hoodCapacity.size() == un,
          "per-particle arrays of the wrong length");
  std::vector<char> seen(un, 0);
  for (std::int64_t e : state.external) {
    require(e >= 0 && e < n && !seen[static_cast<std::size_t>(e)], "the particle numbering is not a permutation");
    seen[static_cast<std::size_t>(e)] = 1;
  }
  const std::int64_t slots = static_cast<std::int64_t>(state.neighbours.size());
  for (std::size_t i = 0; i < un; ++i) {
    require(state.hoodBegin[i] >= 0 && state.hoodSize[i] >= 0 && state.hoodSize[i] <= state.hoodCapacity[i] &&
                state.hoodBegin[i] + state.hoodCapacity[i] <= slots,
            "a neighbour list outside its storage");
    for (std::int64_t k = 0; k < state.hoodSize[i]; ++k) {
      const std::int64_t j = state.neighbours[static_cast<std::size_t>(state.hoodBegin[i] + k)];
      require(j >= 0 && j < n, "a neighbour index out of range");
    }
  }
  for (std::size_t i = 0; i < un; ++i) {
    State& s = state_[i];
    Hood& h = hood_[i];
    for (std::size_t k = 0; k < 3; ++k) {
      s.x[k] = state.position[3 * i + k];
      s.v[k] = state.velocity[3 * i + k];
      h.centre[k] = state.hoodCentre[3 * i + k];
    }
    s.t = 0.0;
    s.r0 = state.radius[i];
    mass_[static_cast<Index>(i)] = state.mass[i];
    inverseMass_[static_cast<Index>(i)] = 1.0 / state.mass[i];
    external_[i] = static_cast<Index>(state.external[i]);
    h.radius = state.hoodRadius[i];
    h.skin = state.hoodSkin[i];
    h.begin = static_cast<Index>(state.hoodBegin[i]);
    h.size = static_cast<Index>(state.hoodSize[i]);
    h.capacity = static_cast<Index>(state.hoodCapacity[i]);
    nbRadius_[static_cast<Index>(i)] = h.radius;
    nbCentre_.col(static_cast<Index>(i)) = Eigen::Vector3d(h.centre[0], h.centre[1], h.centre[2]);
  }
  nbData_.assign(state.neighbours.begin(), state.neighbours.end());
  growth_ = state.growth;
  elapsed_ = state.elapsed;
  clock_ = 0.0;
  kineticMark_ = 0.0;
  skinFloor_ = state.skinFloor;
  sizeRatio_ = state.sizeRatio;
  kinetic_ = state.kinetic;
  maxOverlap_ = state.maxOverlap;
  window_ = state.window;
  total_ = state.total;
  collisionsAtSort_ = state.collisionsAtSort;
  collisionsAtRebuild_ = state.collisionsAtRebuild;
  exitsAtRebuild_ = state.exitsAtRebuild;
  pairsAtRebuild_ = state.pairsAtRebuild;
  pairWork_ = state.pairWork;
  lastCollision_ = state.lastCollision;
  std::fill(collisionsInRun_.begin(), collisionsInRun_.end(), 0);
  recent_ = {};
  recentNext_ = 0;
  // The exit index answers "which neighbourhoods overlap this one" (a sorted set, a function of the
  // centres and radii alone), so building it afresh gives the same answers as the incrementally moved one.
  // The broad phase is rebuilt too, so that describeBroadPhase() reports the restored neighbourhoods.
  if (n > 0) {
    const SphereView view{nbCentre_, nbRadius_};
    broad_->build(view, box_, 0.0);
    hoodGrid_.build(box_, nbCentre_, nbRadius_);
  }
  resetSchedule();
}

// ---------------------------------------------------------------------------------------------------
// Invariants

void HardSphereSystem::validate(double overlapTolerance) const {
  const Index n = count();
  auto fail = [](const std::string& what) { throw std::logic_error("hard-sphere system: " + what); };
  queue_.validate();
  Eigen::Matrix3Xd x(3, n);
  for (Index i = 0; i < n; ++i) {
    const State& s = state_[static_cast<std::size_t>(i)];
    const double dt = clock_ - s.t;
    if (dt < 0.0) fail(fmt::format("particle {} lives in the future (t_i = {}, clock {})", i, s.t, clock_));
    x.col(i) = Eigen::Vector3d(s.x[0] + s.v[0] * dt, s.x[1] + s.v[1] * dt, s.x[2] + s.v[2] * dt);
    const Event& e = event_[static_cast<std::size_t>(i)];
    if (queue_.key(i) != e.time) fail(fmt::format("heap key of particle {} differs from its event time", i));
    if (e.time < clock_) fail(fmt::format("event of particle {} at {} lies before the clock {}", i, e.time, clock_));
    if (e.kind == EventKind::Collision) {
      const Event& f = event_[static_cast<std::size_t>(e.partner)];
      if (f.kind != EventKind::Collision || f.partner != i || f.time != e.time) {
        fail(fmt::format("asymmetric schedule: {} collides with {} but not vice versa", i, e.partner));
      }
    }
    // Inside the neighbourhood.
    const Hood& hood = hood_[static_cast<std::size_t>(i)];
    if (nbCentre_.col(i) != Eigen::Vector3d(hood.centre[0], hood.centre[1], hood.centre[2]) ||
        nbRadius_[i] != hood.radius) {
      fail(fmt::format("neighbourhood copies of particle {} disagree", i));
    }
    Eigen::Vector3d d = x.col(i) - nbCentre_.col(i);
    d = box_.minimumImageAny(d);
    const double r = radiusAt(s);
    if (d.norm() + r > nbRadius_[i] * (1.0 + 1e-9)) {
      fail(fmt::format("particle {} left its neighbourhood: |d| + r = {} > {}", i, d.norm() + r, nbRadius_[i]));
    }
    const auto list = neighboursOf(i);
    if (!std::is_sorted(list.begin(), list.end())) fail(fmt::format("neighbour list of {} not sorted", i));
    for (Index j : list) {
      const auto back = neighboursOf(j);
      if (!std::binary_search(back.begin(), back.end(), i)) fail(fmt::format("list of {} lacks {}", j, i));
    }
  }
  // Completeness of the lists and overlaps: every pair whose neighbourhoods overlap must be listed.
  auto checkPair = [&](Index i, Index j) {
    const Eigen::Vector3d dc = box_.minimumImageAny(nbCentre_.col(i) - nbCentre_.col(j));
    if (dc.norm() <= nbRadius_[i] + nbRadius_[j]) {
      const auto list = neighboursOf(i);
      if (!std::binary_search(list.begin(), list.end(), j)) {
        fail(fmt::format("neighbourhoods of {} and {} overlap but they are not neighbours", i, j));
      }
    }
    const Eigen::Vector3d dx = box_.minimumImageAny(x.col(i) - x.col(j));
    const double s = radiusAt(state_[static_cast<std::size_t>(i)]) + radiusAt(state_[static_cast<std::size_t>(j)]);
    if (s - dx.norm() > overlapTolerance * s) {
      fail(fmt::format("particles {} and {} overlap by {:.3g} relative", i, j, (s - dx.norm()) / s));
    }
  };
  if (n <= 2000) {
    for (Index i = 0; i < n; ++i)
      for (Index j = i + 1; j < n; ++j) checkPair(i, j);
  } else {
    for (Index i = 0; i < n; ++i)
      for (Index j : neighboursOf(i))
        if (j > i) checkPair(i, j);
  }
}

}  // namespace polydem::edmd
