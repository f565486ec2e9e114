#include "integrators/fire_minimiser.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

#include "broadphase/parallel.hpp"
#include "broadphase/registry.hpp"
#include "core/errors.hpp"
#include "core/interrupt.hpp"
#include "integrators/dem_simulation.hpp"  // mortonOrder
#include "integrators/fire_descent.hpp"
#include "polydem/config.hpp"

namespace polydem::integrators {

namespace {

using Clock = std::chrono::steady_clock;
double seconds(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

double resolveSkin(double skin, const ParticleStore& particles) {
  if (skin >= 0.0) return skin;
  if (particles.count() == 0) return 0.0;  // the constructor reports the empty store
  return 0.2 * particles.radius().minCoeff();
}

using fire::LargestTwo;
constexpr Index kFireChunk = fire::kChunk;
Index fireChunks(Index n) { return fire::chunkCount(n); }

/// The threaded path out of line, as in dem_simulation.cpp: the OpenMP region takes the address of its copy
/// of `body`, which would otherwise make the serial loop reload the captured values after each store.
template <class Body>
[[gnu::noinline]] void forChunksThreaded(Index n, int threads, Body body) {
  broadphase::parallel::forEachTask(threads, static_cast<std::size_t>(fireChunks(n)), [&](std::size_t k) {
    const auto c = static_cast<Index>(k);
    body(c, c * kFireChunk, std::min(n, (c + 1) * kFireChunk));
  });
}

/// body(c, begin, end) for every chunk c = [begin, end) of [0, n), on `threads` threads when > 1.
template <class Body>
void forChunks(Index n, int threads, Body body) {
  if (broadphase::parallel::usable(threads) > 1 && n > kFireChunk) {
    forChunksThreaded(n, threads, body);
    return;
  }
  for (Index c = 0; c * kFireChunk < n; ++c) body(c, c * kFireChunk, std::min(n, (c + 1) * kFireChunk));
}

/// The two largest squared displacements of all chunks, from each chunk's two (`maxima`: 2 per chunk);
/// exact, so the same values whatever the split.
double driftOfChunks(const std::vector<double>& maxima) {
  LargestTwo largest;
  for (const double m : maxima) largest.add(m);
  return largest.drift();
}

void requirePositive(double value, const char* key) {
  if (!(value > 0.0 && std::isfinite(value))) throw ConfigError(fmt::format("{} must be > 0, got {}", key, value));
}

}  // namespace

const char* methodName(MinimiserMethod method) { return method == MinimiserMethod::ConjugateGradient ? "cg" : "fire"; }

void FireSettings::validate() const {
  requirePositive(forceTolerance, "minimise.force_tolerance");
  if (!(referenceForce >= 0.0 && std::isfinite(referenceForce))) {
    throw ConfigError(fmt::format("minimise.reference_force must be >= 0, got {}", referenceForce));
  }
  if (maxIterations < 1) throw ConfigError(fmt::format("minimise.max_iterations must be >= 1, got {}", maxIterations));
  requirePositive(dt, "minimise.dt");
  if (!(dtMaxFactor >= 1.0 && std::isfinite(dtMaxFactor))) {
    throw ConfigError(fmt::format("minimise.dt_max_factor must be >= 1, got {}", dtMaxFactor));
  }
  if (!(dtMinFactor > 0.0 && dtMinFactor <= 1.0)) {
    throw ConfigError(fmt::format("minimise.dt_min_factor must be in (0, 1], got {}", dtMinFactor));
  }
  if (nDelay < 0) throw ConfigError(fmt::format("minimise.n_delay must be >= 0, got {}", nDelay));
  if (!(fInc > 1.0 && std::isfinite(fInc))) throw ConfigError(fmt::format("minimise.f_inc must be > 1, got {}", fInc));
  if (!(fDec > 0.0 && fDec < 1.0)) throw ConfigError(fmt::format("minimise.f_dec must be in (0, 1), got {}", fDec));
  if (!(alphaStart > 0.0 && alphaStart < 1.0)) {
    throw ConfigError(fmt::format("minimise.alpha_start must be in (0, 1), got {}", alphaStart));
  }
  if (!(fAlpha > 0.0 && fAlpha <= 1.0)) {
    throw ConfigError(fmt::format("minimise.f_alpha must be in (0, 1], got {}", fAlpha));
  }
  if (maxUphill < 1) throw ConfigError(fmt::format("minimise.max_uphill must be >= 1, got {}", maxUphill));
  if (progressInterval < 0) {
    throw ConfigError(fmt::format("minimise.progress_interval must be >= 0, got {}", progressInterval));
  }
}

FireMinimiser::FireMinimiser(ParticleStore particles, const Box& box, const MinimiserSettings& settings)
    : particles_(std::move(particles)),
      box_(box),
      settings_(settings),
      model_(settings.contact),
      verlet_(broadphase::makeBroadPhase(settings.broadPhase), resolveSkin(settings.skin, particles_)) {
  settings_.fire.validate();
  const contact::ContactParameters& p = model_.parameters();
  if (p.usesFriction()) {
    throw ConfigError(fmt::format(
        "contact.friction = {:g}: the minimiser is for frictionless spheres (tangential springs have no energy "
        "minimum to find); use friction 0",
        p.friction));
  }
  if (p.restitution != 1.0) {
    throw ConfigError(
        fmt::format("contact.restitution = {:g}: the minimiser uses no dashpot (FIRE removes the energy itself); use 1",
                    p.restitution));
  }
  if (settings_.threads < 1) throw ConfigError(fmt::format("run.threads must be >= 1, got {}", settings_.threads));
  if (settings_.threads > 1 && !POLYDEM_WITH_OPENMP) {
    throw ConfigError(fmt::format("run.threads = {} needs a build with POLYDEM_WITH_OPENMP=ON", settings_.threads));
  }
  verlet_.setBlocks(settings_.threads);
  verlet_.setThreads(settings_.threads);  // the broad phase and the list build too (the same list for any count)
  settings_.skin = verlet_.skin();
  if (settings_.outerSkin < 0.0) {
    // The default, 5 x skin, as far as the box allows: a periodic edge must hold 2 (2 r_max + outer skin)
    // (the broad phase's condition); one level where even the skin is at that limit.
    double room = std::numeric_limits<double>::infinity();
    const double rMax = particles_.count() > 0 ? particles_.radius().maxCoeff() : 0.0;
    for (int k = 0; k < 3; ++k) {
      if (box_.periodic(k)) room = std::min(room, (0.5 * box_.length(k) - 2.0 * rMax) * (1.0 - 1e-9));
    }
    settings_.outerSkin = std::max(settings_.skin, std::min(5.0 * settings_.skin, room));
  }
  if (settings_.outerSkin == 0.0) settings_.outerSkin = settings_.skin;
  if (!(settings_.outerSkin >= settings_.skin && std::isfinite(settings_.outerSkin))) {
    throw ConfigError(fmt::format("minimise.outer_skin must be 0 (one level) or >= the skin {}, got {}", settings_.skin,
                                  settings_.outerSkin));
  }
  verlet_.setOuterSkin(settings_.outerSkin);

  const Index n = particles_.count();
  if (n == 0) throw ConfigError("no particles to minimise");
  chunkMaxima_.assign(2 * static_cast<std::size_t>(fireChunks(n)), 0.0);  // n does not change
  Eigen::Matrix3Xd& x = particles_.position();
  double radiusSum = 0.0;
  for (Index i = 0; i < n; ++i) {
    const Index id = particles_.id()[static_cast<std::size_t>(i)];
    const double r = particles_.radius()[i];
    if (!(r > 0.0 && std::isfinite(r))) throw ConfigError(fmt::format("particle id {}: radius {} must be > 0", id, r));
    if (!x.col(i).allFinite()) throw ConfigError(fmt::format("particle id {}: non-finite position", id));
    x.col(i) = box_.wrap(x.col(i));
    if (!box_.contains(x.col(i))) {
      throw ConfigError(fmt::format("particle id {}: centre ({}, {}, {}) outside the walled box {}", id, x(0, i),
                                    x(1, i), x(2, i), box_.describe()));
    }
    radiusSum += r;
  }
  if (settings_.spatialSort) particles_.reorder(mortonOrder(particles_.position(), box_));
  particles_.velocity().setZero();

  contact::KernelFlags flags;
  flags.walls = box_.hasWalls();
  kernel_ = contact::selectForceKernel(model_, flags);
  pairHistory_ = contact::ContactHistory(kernel_.historyWidth);
  wallHistory_ = contact::ContactHistory(kernel_.historyWidth);
  if (p.normal == contact::NormalModel::Hertz || p.scaling == contact::StiffnessScaling::Radius) {
    pressureUnit_ = p.stiffness;
  } else {
    pressureUnit_ = p.stiffness / (2.0 * radiusSum / static_cast<double>(n));
  }
  rebuild();
  computeForces();
}

contact::ForceContext FireMinimiser::context() const {
  auto& self = const_cast<FireMinimiser&>(*this);  // the kernel writes forces; measure() only reads
  contact::ForceContext c;
  c.count = particles_.count();
  c.position = particles_.position().data();
  c.velocityHalf = particles_.velocity().data();
  c.velocity = particles_.velocity().data();  // read only by dashpots, which are off (e = 1)
  c.radius = particles_.radius().data();
  c.inverseMass = particles_.inverseMass().data();
  c.force = self.particles_.force().data();
  c.list = &verlet_.list();
  c.pairHistory = &self.pairHistory_;
  c.wallHistory = &self.wallHistory_;
  for (int k = 0; k < 3; ++k) {
    c.length[k] = box_.length(k);
    c.halfLength[k] = box_.periodic(k) ? 0.5 * box_.length(k) : std::numeric_limits<double>::infinity();
  }
  c.threads = settings_.threads;
  c.crossScratch = self.crossScratch_.data();
  c.crossTouching = self.crossTouching_.data();
  return c;
}

void FireMinimiser::moveAlong(const double* d, double a) {
  double* x = particles_.position().data();
  const double* ref = verlet_.reference().data();
  const Index n = particles_.count();
  double* maxima = chunkMaxima_.data();
  forChunks(n, settings_.threads, [=](Index c, Index begin, Index end) {
    LargestTwo largest;
    for (Index i = begin; i < end; ++i) largest.add(fire::moveParticle(i, a, d, x, ref));
    maxima[2 * c] = largest.first;
    maxima[2 * c + 1] = largest.second;
  });
  pairDrift_ = driftOfChunks(chunkMaxima_);
  if (listStale()) rebuild();
  computeForces();
}

void FireMinimiser::computeForces() {
  const auto t0 = Clock::now();
  kernel_.run(model_, context());
  ++forceEvaluations_;
  forceSeconds_ += seconds(t0, Clock::now());
}

fire::StiffnessRule FireMinimiser::stiffnessRule() const {
  const contact::ContactParameters& p = model_.parameters();
  if (p.normal == contact::NormalModel::Hertz) {
    // dF/d(delta) = 3/2 K sqrt(R_eff delta) at delta = reference x R_eff.
    return {1.5 * p.stiffness, std::sqrt(hertzReferenceOverlap_), true};
  }
  const contact::LinearNormal::Params linear = model_.linearParams();
  return {linear.stiffness, 1.0, linear.radiusScaled};
}

void FireMinimiser::updateMasses() {
  // m_i = k_ii + sum_j k_ij over the candidates of i (and its walls): see the header (Jacobi preconditioning).
  fire::jacobiMasses(verlet_.list(), particles_.radius().data(), particles_.count(), stiffnessRule(),
                     particles_.inverseMass().data());
}

void FireMinimiser::rebuild() {
  const auto t0 = Clock::now();
  if (verlet_.twoLevel() && verlet_.builds() > 0 &&
      verlet_.outerDrift(particles_.position()) + 2.0 * growthSinceOuter_ <= verlet_.outerSkin() - verlet_.skin()) {
    // No pair outside the outer candidates can be within the skin: cut the list from them (the centres stay
    // unwrapped, within the outer skin of their last build).
    verlet_.refine(particles_.spheres(), box_);
  } else {
    broadPhaseBuild();
  }
  growthSinceBuild_ = 0.0;
  pairDrift_ = 0.0;
  if (settings_.threads > 1) {
    crossScratch_.resize(contact::crossScratchSize(verlet_.list().crossCount(), false));
    crossTouching_.resize(verlet_.list().crossCount());
  }
  updateMasses();
  verlet_.adviseHugePages(hugePages_, particles_.adviseHugePages(hugePages_, 0));
  ++rebuildsInCall_;
  broadSeconds_ += seconds(t0, Clock::now());
}

void FireMinimiser::broadPhaseBuild() {
  Eigen::Matrix3Xd& x = particles_.position();
  const Index n = particles_.count();
  for (Index i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) {
      double& xk = x(k, i);
      const double L = box_.length(k);
      if (!std::isfinite(xk)) {
        throw SimulationError(fmt::format("minimiser: particle id {} reached a non-finite position",
                                          particles_.id()[static_cast<std::size_t>(i)]));
      }
      if (box_.periodic(k)) {
        if (xk < 0.0 || xk >= L) {
          xk -= L * std::floor(xk / L);
          if (xk >= L) xk = 0.0;
        }
      } else if (xk < 0.0 || xk > L) {
        throw SimulationError(fire::leftWallMessage(particles_.id()[static_cast<std::size_t>(i)],
                                                    particles_.radius()[i], k, xk, L, particles_.force()(k, i)));
      }
    }
  }
  verlet_.build(particles_.spheres(), box_);
  growthSinceOuter_ = 0.0;
  ++broadBuildsInCall_;
}

bool FireMinimiser::listStale() const {
  // A pair (i, j) left out of the list was more than skin apart (surface to surface) at the build; since
  // then its gap shrank by at most |dx_i| + |dx_j| + dr_i + dr_j <= (the two largest displacements) + 2 max dr.
  // Sharper than 2 max|dx|, which counts the fastest particle twice: when a few particles run ahead (small
  // rattlers under FIRE's growing step), the lists last up to twice as many steps.
  return pairDrift_ + 2.0 * growthSinceBuild_ > verlet_.skin();
}

void FireMinimiser::scaleRadii(double factor) {
  if (!(factor > 0.0 && std::isfinite(factor))) {
    throw ConfigError(fmt::format("scaleRadii: factor must be > 0, got {}", factor));
  }
  if (factor > 1.0) {
    growthSinceBuild_ += (factor - 1.0) * particles_.radius().maxCoeff();
    growthSinceOuter_ += (factor - 1.0) * particles_.radius().maxCoeff();
  }
  particles_.radius() *= factor;
  particles_.velocity().setZero();
  if (listStale()) {
    rebuild();
  } else {
    updateMasses();  // stiffnesses scale with the radii
  }
  computeForces();
}

Eigen::Matrix3Xd FireMinimiser::wrappedPositions() const {
  Eigen::Matrix3Xd x = particles_.position();
  for (Index i = 0; i < particles_.count(); ++i) {
    for (int k = 0; k < 3; ++k) {
      if (!box_.periodic(k)) continue;
      const double L = box_.length(k);
      double& xk = x(k, i);
      if (xk < 0.0 || xk >= L) {
        xk -= L * std::floor(xk / L);
        if (xk >= L) xk = 0.0;
      }
    }
  }
  return x;
}

double FireMinimiser::packingFraction() const {
  // Sum r^3 by chunks in chunk order, as measure() (and the distributed run) adds it.
  const Index n = particles_.count();
  double volume = 0.0;
  for (Index c = 0; c < fireChunks(n); ++c) {
    double chunk = 0.0;
    for (Index i = c * kFireChunk; i < std::min(n, (c + 1) * kFireChunk); ++i) {
      const double r = particles_.radius()[i];
      chunk += r * r * r;
    }
    volume += chunk;
  }
  return 4.0 / 3.0 * kPi * volume / box_.volume();
}

double FireMinimiser::contactForceAtPressure(double reducedPressure) const {
  const double meanDiameter = 2.0 * particles_.radius().mean();
  return reducedPressure * pressureUnit_ * box_.volume() / (static_cast<double>(particles_.count()) * meanDiameter);
}

MinimiserReport FireMinimiser::measure() const {
  // Per particle its row's contacts and walls (fire::tallyContacts), then the particles' sums by chunks in
  // chunk order (fire::measureChunk): the order a distributed run reproduces (parallel/distributed_fire.hpp).
  const Index n = particles_.count();
  measurePart_.assign(3 * static_cast<std::size_t>(n), 0.0);
  const fire::ContactTally tally = fire::tallyContacts(
      model_, context(), [](Index) { return true; }, measurePart_.data());
  fire::MeasureSums sums;
  for (Index c = 0; c < fireChunks(n); ++c) {
    const fire::MeasureSums part = fire::measureChunk(c * kFireChunk, std::min(n, (c + 1) * kFireChunk),
                                                      measurePart_.data(), particles_.radius().data());
    sums.energy += part.energy;
    sums.force += part.force;
    sums.virial += part.virial;
    sums.volume += part.volume;
  }
  const Eigen::VectorXd& im = particles_.inverseMass();
  double forceSq = 0.0, stepSq = 0.0;  // largest |F_i|^2 and largest Jacobi step |F_i|^2 / m_i^2
  for (Index i = 0; i < n; ++i) {
    const double fi = fire::squaredNorm3(particles_.force().data() + 3 * i);
    forceSq = std::max(forceSq, fi);
    stepSq = std::max(stepSq, fi * im[i] * im[i]);
  }
  return fire::assembleReport(tally, sums, forceSq, stepSq, box_, pressureUnit_, settings_.fire.referenceForce);
}

void FireMinimiser::prepareDescent(const MinimiserReport& start) {
  if (model_.parameters().normal == contact::NormalModel::Hertz) {
    // Masses from the stiffness at the current overlaps (Hertz stiffens with overlap); 1e-4 without contacts.
    const double ratio = start.maxOverlapRatio > 0.0 ? start.maxOverlapRatio : 1e-4;
    if (ratio != hertzReferenceOverlap_) {
      hertzReferenceOverlap_ = ratio;
      updateMasses();
    }
  }
  particles_.velocity().setZero();
}

void FireMinimiser::finishCall(FireResult& res) {
  res.rebuilds = rebuildsInCall_;
  res.broadPhaseBuilds = broadBuildsInCall_;
  particles_.velocity().setZero();
  res.seconds.broadPhase = broadSeconds_ - broadAtStart_;
  res.seconds.force = forceSeconds_ - forceAtStart_;
  res.seconds.update = std::max(
      0.0, seconds(callStart_, Clock::now()) - res.seconds.broadPhase - res.seconds.force - res.seconds.measure);
}

/// The serial system of fire::descend() (integrators/fire_descent.hpp): the passes by chunks of slots on the
/// minimiser's threads, sums added in chunk order.
class FireMinimiser::Serial {
 public:
  Serial(FireMinimiser& m, bool stopOnInterrupt)
      : m_(m),
        stopOnInterrupt_(stopOnInterrupt),
        chunkSums_(static_cast<std::size_t>(fireChunks(m.particles_.count()))) {}
  MinimiserReport measure() const { return m_.measure(); }
  void prepare(const MinimiserReport& start) { m_.prepareDescent(start); }
  double overlapFloor() const { return 64.0 * std::numeric_limits<double>::epsilon() * m_.box_.lengths().maxCoeff(); }
  bool interrupted() const { return stopOnInterrupt_ && interruptRequested(); }
  fire::FireSums sums() {
    const double* f = m_.particles_.force().data();
    const double* v = m_.particles_.velocity().data();
    const double* im = m_.particles_.inverseMass().data();
    fire::FireSums* out = chunkSums_.data();
    forChunks(m_.particles_.count(), m_.settings_.threads,
              [=](Index c, Index begin, Index end) { out[c] = fire::reduceChunk(begin, end, f, v, im); });
    fire::FireSums sums;
    for (const fire::FireSums& c : chunkSums_) sums.add(c);
    return sums;
  }
  void restart(double dt) {
    double* x = m_.particles_.position().data();
    double* v = m_.particles_.velocity().data();
    for (Index a = 0; a < 3 * m_.particles_.count(); ++a) {
      x[a] -= 0.5 * dt * v[a];
      v[a] = 0.0;
    }
  }
  void advance(double dt, double keep, double toward) {
    double* x = m_.particles_.position().data();
    double* v = m_.particles_.velocity().data();
    const double* f = m_.particles_.force().data();
    const double* im = m_.particles_.inverseMass().data();
    const double* ref = m_.verlet_.reference().data();
    double* maxima = m_.chunkMaxima_.data();
    forChunks(m_.particles_.count(), m_.settings_.threads, [=](Index c, Index begin, Index end) {
      LargestTwo largest;  // squared displacements since the build
      for (Index i = begin; i < end; ++i) largest.add(fire::kickMixDrift(i, dt, keep, toward, f, v, x, im, ref));
      maxima[2 * c] = largest.first;
      maxima[2 * c + 1] = largest.second;
    });
    m_.pairDrift_ = driftOfChunks(m_.chunkMaxima_);
    if (m_.listStale()) m_.rebuild();
    m_.computeForces();
  }
  void finish(FireResult& res) { m_.finishCall(res); }

  // Conjugate gradients (fire::descendByCg): the passes by chunks, sums added in chunk order.
  void resetPrevious() {
    const std::size_t m = 3 * static_cast<std::size_t>(m_.particles_.count());
    m_.cgDirection_.resize(m);
    m_.cgPrevious_.assign(m, 0.0);
    parts_.resize(chunkSums_.size());
  }
  std::array<double, 2> precondition() {
    const double* f = m_.particles_.force().data();
    const double* im = m_.particles_.inverseMass().data();
    double* previous = m_.cgPrevious_.data();
    std::array<double, 3>* part = parts_.data();
    forChunks(m_.particles_.count(), m_.settings_.threads, [=](Index c, Index begin, Index end) {
      const std::array<double, 2> p = fire::preconditionChunk(begin, end, f, im, previous);
      part[c] = {p[0], p[1], 0.0};
    });
    return {total(0), total(1)};
  }
  void restartDirection() { std::copy(m_.cgPrevious_.begin(), m_.cgPrevious_.end(), m_.cgDirection_.begin()); }
  std::array<double, 3> direct(double beta, bool update) {
    const double* f = m_.particles_.force().data();
    double* d = m_.cgDirection_.data();
    const double* previous = m_.cgPrevious_.data();
    std::array<double, 3>* part = parts_.data();
    forChunks(m_.particles_.count(), m_.settings_.threads, [=](Index c, Index begin, Index end) {
      part[c] = fire::directChunk(begin, end, f, d, previous, beta, update);
    });
    return {total(0), largest(1), largest(2)};
  }
  double along() {
    const double* f = m_.particles_.force().data();
    const double* d = m_.cgDirection_.data();
    std::array<double, 3>* part = parts_.data();
    forChunks(m_.particles_.count(), m_.settings_.threads,
              [=](Index c, Index begin, Index end) { part[c][0] = fire::alongChunk(begin, end, f, d); });
    return total(0);
  }
  void moveAlong(double a) { m_.moveAlong(m_.cgDirection_.data(), a); }
  double skin() const { return m_.verlet_.skin(); }

 private:
  double total(std::size_t k) const {
    double sum = 0.0;
    for (const auto& p : parts_) sum += p[k];
    return sum;
  }
  double largest(std::size_t k) const {
    double most = 0.0;
    for (const auto& p : parts_) most = std::max(most, p[k]);
    return most;
  }

  FireMinimiser& m_;
  bool stopOnInterrupt_;
  std::vector<fire::FireSums> chunkSums_;     // once per call, not per step
  std::vector<std::array<double, 3>> parts_;  // conjugate gradients' per-chunk sums
};

FireResult FireMinimiser::minimise(const Progress& progress, bool stopOnInterrupt) {
  const FireSettings& fs = settings_.fire;
  fs.validate();
  rebuildsInCall_ = 0;
  broadBuildsInCall_ = 0;
  callStart_ = Clock::now();
  broadAtStart_ = broadSeconds_;
  forceAtStart_ = forceSeconds_;
  Serial system(*this, stopOnInterrupt);
  if (settings_.method == MinimiserMethod::Fire) return fire::descend(system, fs, progress, stopOnInterrupt);
  return fire::descendByCg(system, fs, progress, stopOnInterrupt);
}

void FireMinimiser::adoptState(const Eigen::Matrix3Xd& x, const Eigen::VectorXd& r) {
  if (x.cols() != particles_.count() || r.size() != particles_.count()) {
    throw std::logic_error("FireMinimiser::adoptState: sizes differ from the minimiser's");
  }
  particles_.position() = x;
  particles_.radius() = r;
  particles_.velocity().setZero();
  broadPhaseBuild();
  growthSinceBuild_ = 0.0;
  pairDrift_ = 0.0;
  updateMasses();
  computeForces();
}

FireMinimiser::ListState FireMinimiser::listState() const {
  return {growthSinceBuild_, growthSinceOuter_, hertzReferenceOverlap_,
          verlet_.outerReference() != particles_.position()};
}

std::size_t FireMinimiser::memoryBytes() const {
  const auto n = static_cast<std::size_t>(particles_.count());
  std::size_t bytes = n * (9 + 2) * sizeof(double) + n * sizeof(Index);
  bytes += crossScratch_.capacity() * sizeof(double) + crossTouching_.capacity();
  bytes += (cgDirection_.capacity() + cgPrevious_.capacity() + chunkMaxima_.capacity()) * sizeof(double);
  bytes += verlet_.memoryBytes();
  return bytes;
}

}  // namespace polydem::integrators
