// HardSphereSystem: construction, input checks, the clock and synchronisation, velocity control and
// observables. The other parts of the class live beside it, one concept per file:
// hard_sphere_events.cpp (prediction and collision kernels, the event loop), hard_sphere_neighbourhoods.cpp
// (bounding neighbourhoods, lists, exits, skins, Morton renumbering), hard_sphere_state.cpp (checkpoint
// state save/restore, invariants).
#include "edmd/hard_sphere_system.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "broadphase/registry.hpp"
#include "core/errors.hpp"

namespace polydem::edmd {

namespace {

constexpr const char* kAxis = "xyz";

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
  if (!(options_.exitLead >= 0.0 && options_.exitLead <= 0.9)) {
    throw ConfigError(fmt::format("exit lead must be in [0, 0.9], got {}", options_.exitLead));
  }
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
  prefetchAhead_ = state_.size() * sizeof(State) > (std::size_t{1} << 20) ? 16 : 4;
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
  exits_ = broadphase::makeBroadPhase(options_.exitIndex);
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
  // shift wraps it.
  for (int k = 0; k < 3; ++k) wrapIntoBox(s.x[k], k);
}

void HardSphereSystem::advanceAll() {
  for (Index i = 0; i < count(); ++i) advance(i);
}

void HardSphereSystem::resetSchedule() {
  // Donev 2006 (thesis), Algorithm 4: every particle gets a check now; the pops re-predict everything.
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
  const bool due = options_.adaptiveSkin && total_.collisions - collisionsAtRebuild_ > 5 * std::int64_t{count()};
  bool retune = false;
  if (due && classSkins()) {
    retune = classesWantRebuild(true);
  } else if (due) {
    const int trend = skinTrend();
    retune = trend > 0 || (trend < 0 && skinFloor_ > options_.skinFloor);
  }
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

}  // namespace polydem::edmd
