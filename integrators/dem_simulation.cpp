#include "integrators/dem_simulation.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <span>
#include <utility>

#include "broadphase/registry.hpp"
#include "core/errors.hpp"
#include "core/interrupt.hpp"
#include "core/morton.hpp"
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

/// body(i) for i in [0, n), on `threads` OpenMP threads when > 1. Returns the largest value body returned
/// (exact, so independent of the split). Dynamic chunks of kChunk particles although the work per particle
/// is uniform: on a shared machine a thread that loses its core mid-loop then holds up the barrier for
/// one chunk, not for half the particles (static split: 2 threads ran 3x slower than 1 next to a compile).
/// The threaded loops are separate, not inlined functions: the OpenMP region takes the address of its
/// copy of `body`, which would otherwise make the serial loop reload the captured values after each store.
constexpr Index kChunk = 2048;

#if POLYDEM_WITH_OPENMP
template <class Body>
[[gnu::noinline]] double maxOverThreaded(Index n, int threads, Body body) {
  double m = 0.0;
#pragma omp parallel for num_threads(threads) schedule(dynamic, kChunk) reduction(max : m)
  for (Index i = 0; i < n; ++i) m = std::max(m, body(i));
  return m;
}

template <class Body>
[[gnu::noinline]] void forEachThreaded(Index n, int threads, Body body) {
#pragma omp parallel for num_threads(threads) schedule(dynamic, kChunk)
  for (Index i = 0; i < n; ++i) body(i);
}
#endif

template <class Body>
double maxOver(Index n, [[maybe_unused]] int threads, Body body) {
#if POLYDEM_WITH_OPENMP
  if (threads > 1) return maxOverThreaded(n, threads, body);
#endif
  double m = 0.0;
  for (Index i = 0; i < n; ++i) m = std::max(m, body(i));
  return m;
}

template <class Body>
void forEach(Index n, [[maybe_unused]] int threads, Body body) {
#if POLYDEM_WITH_OPENMP
  if (threads > 1) {
    forEachThreaded(n, threads, body);
    return;
  }
#endif
  for (Index i = 0; i < n; ++i) body(i);
}

/// What a half kick reads and writes: a rate (v or omega), its driver (F or torque) and inverse
/// inertia (1/m or 1/I), and the predicted full-step rate (written when kPredict).
struct KickArrays {
  double* rate;
  const double* driver;
  const double* inverse;
  double* predicted = nullptr;
};
/// What the drift reads and writes: positions, and the centres of the last neighbour-list build.
struct DriftArrays {
  double* position = nullptr;
  const double* reference = nullptr;
};

/// One velocity-Verlet half kick, rate += dt/2 driver * inverse, for every particle; with kDrift also
/// the drift x += dt v that follows it, with kPredict the predicted rate(t + dt) = rate + dt/2 driver *
/// inverse for the dashpots. Returns the largest squared displacement since the last build with kDrift
/// (else 0). One pass over the particles, so the opening kick, the drift and the displacement check
/// read each particle once. With kClose the pass first applies the previous step's closing half kick (the
/// same expression, rate += dt/2 driver * inverse, with the same driver): two steps' kicks in one pass,
/// bit for bit what the two passes give.
template <bool kDrift, bool kPredict, bool kClose = false>
double halfKick(Index n, int threads, double dt, const KickArrays& k, const DriftArrays& d = {}) {
  const double half = 0.5 * dt;
  double* v = k.rate;
  const double* f = k.driver;
  const double* im = k.inverse;
  [[maybe_unused]] double* vp = k.predicted;
  [[maybe_unused]] double* x = d.position;
  [[maybe_unused]] const double* ref = d.reference;
  // Each particle's values are read into registers first and stored last: the arrays may alias as far as the
  // compiler knows, and a store followed by a reload of the same value would chain the three components.
  auto body = [=](Index i) {
    const double h = half * im[i];
    double fa[3], va[3], xa[3];
    for (int c = 0; c < 3; ++c) {
      fa[c] = f[3 * i + c];
      va[c] = v[3 * i + c];
      if constexpr (kDrift) xa[c] = x[3 * i + c];
    }
    double dsq = 0.0;
    for (int c = 0; c < 3; ++c) {
      if constexpr (kClose) va[c] += h * fa[c];
      va[c] += h * fa[c];
      if constexpr (kDrift) {
        xa[c] += dt * va[c];
        const double dx = xa[c] - ref[3 * i + c];
        dsq += dx * dx;
      }
    }
    for (int c = 0; c < 3; ++c) {
      v[3 * i + c] = va[c];
      if constexpr (kDrift) x[3 * i + c] = xa[c];
      if constexpr (kPredict) vp[3 * i + c] = va[c] + h * fa[c];
    }
    return dsq;
  };
  if constexpr (kDrift) {
    return maxOver(n, threads, body);
  } else {
    forEach(n, threads, body);
    return 0.0;
  }
}

}  // namespace

std::vector<Index> mortonOrder(const Eigen::Matrix3Xd& centres, const Box& box) {
  const auto n = static_cast<Index>(centres.cols());
  std::vector<std::uint64_t> code(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) {
    code[static_cast<std::size_t>(i)] = mortonKey(centres.col(i).data(), box, 10);
  }
  std::vector<Index> order(static_cast<std::size_t>(n));
  std::iota(order.begin(), order.end(), Index{0});
  // Index tie-break = the stable order, without std::stable_sort's temporary buffer (GCC 12 -O3 pairs its
  // new(nothrow) with free, which AddressSanitizer reports as an alloc-dealloc mismatch).
  std::sort(order.begin(), order.end(),
            [&](Index a, Index b) { return code[a] < code[b] || (code[a] == code[b] && a < b); });
  return order;
}

DemSimulation::DemSimulation(ParticleStore particles, const Box& box, const DemSettings& settings)
    : particles_(std::move(particles)),
      box_(box),
      settings_(settings),
      model_(settings.contact),
      verlet_(broadphase::makeBroadPhase(settings.broadPhase), resolveSkin(settings.skin, particles_)) {
  settings_.skin = verlet_.skin();
  validateSettings();

  // Particles: sane values, periodic coordinates wrapped, walled ones inside the box.
  const Index n = particles_.count();
  if (n == 0) throw ConfigError("no particles to simulate");
  Eigen::Matrix3Xd& x = particles_.position();
  for (Index i = 0; i < n; ++i) {
    const Index id = particles_.id()[static_cast<std::size_t>(i)];
    const double r = particles_.radius()[i];
    const double im = particles_.inverseMass()[i];
    if (!(r > 0.0 && std::isfinite(r))) throw ConfigError(fmt::format("particle id {}: radius {} must be > 0", id, r));
    if (!(im > 0.0 && std::isfinite(im))) {
      throw ConfigError(fmt::format("particle id {}: mass 1/{} must be positive and finite", id, im));
    }
    if (!x.col(i).allFinite() || !particles_.velocity().col(i).allFinite()) {
      throw ConfigError(fmt::format("particle id {}: non-finite position or velocity", id));
    }
    x.col(i) = box_.wrap(x.col(i));
    if (!box_.contains(x.col(i))) {
      throw ConfigError(fmt::format("particle id {}: centre ({}, {}, {}) outside the walled box {}", id, x(0, i),
                                    x(1, i), x(2, i), box_.describe()));
    }
  }

  if (settings_.needsRotation() && !particles_.features().rotation) {
    throw ConfigError(fmt::format(
        "contact.friction = {} {}needs rotation, but the particle store was created without Features::rotation",
        model_.parameters().friction, settings_.generalKernel ? "(or the general kernel) " : ""));
  }
  if (settings_.spatialSort) {
    const std::vector<Index> order = mortonOrder(particles_.position(), box_);
    particles_.reorder(order);
  }
  selectKernel();

  // Time step. Hertz durations depend on the impact speed: without a reference speed, use twice the
  // fastest particle (a head-on impact of the two fastest).
  double impactSpeed = model_.parameters().referenceVelocity;
  if (impactSpeed == 0.0) impactSpeed = 2.0 * particles_.velocity().colwise().norm().maxCoeff();
  timeStep_ = chooseTimeStep(model_, particles_, box_, settings_.stepsPerContact, impactSpeed);
  if (settings_.timeStep > 0.0) {
    timeStep_.dt = settings_.timeStep;
    timeStep_.stepsPerContact = timeStep_.contactDuration / settings_.timeStep;
    if (timeStep_.stepsPerContact < kMinStepsPerContact && !settings_.allowUnstableDt) {
      throw ConfigError(fmt::format(
          "run.dt = {:g} s is t_c,min / {:.3g} (t_c,min = {:.4g} s, {}): the same rule as run.dt_factor >= {:g} "
          "applies, so use run.dt <= {:.4g} s, or remove run.dt and set run.dt_factor (default 50); "
          "run.allow_unstable_dt = true runs it anyway",
          settings_.timeStep, timeStep_.stepsPerContact, timeStep_.contactDuration,
          timeStep_.describe().substr(timeStep_.describe().find("set by")), kMinStepsPerContact,
          timeStep_.contactDuration / kMinStepsPerContact));
    }
  }
  dt_ = timeStep_.dt;
  velocityPredicted_ = particles_.velocity();
  if (kernel_.rotation) angularVelocityPredicted_ = particles_.angularVelocity();

  rebuild();
  rejectCoincidentCentres();
  computeForces();
  const contact::ContactStats stats = contactStats();
  initialEnergy_ = energies(stats).total();
  chooseLookAhead(stats);
}

void DemSimulation::validateSettings() {
  settings_.stability.validate();
  if (!settings_.gravity.allFinite()) throw ConfigError("run.gravity must be finite");
  if (settings_.gravity != Eigen::Vector3d::Zero() && box_.fullyPeriodic()) {
    throw ConfigError(
        fmt::format("run.gravity = [{:g}, {:g}, {:g}] in a fully periodic box: nothing holds the particles, they fall "
                    "forever; put walls across gravity, e.g. box.boundaries = [\"periodic\", \"periodic\", \"wall\"]",
                    settings_.gravity[0], settings_.gravity[1], settings_.gravity[2]));
  }
  if (!(settings_.viscousDamping >= 0.0 && std::isfinite(settings_.viscousDamping))) {
    throw ConfigError(fmt::format("run.viscous_damping must be >= 0, got {}", settings_.viscousDamping));
  }
  if (!(settings_.timeStep >= 0.0 && std::isfinite(settings_.timeStep))) {
    throw ConfigError(fmt::format("run.dt must be >= 0 (0 = automatic), got {}", settings_.timeStep));
  }
  if (settings_.threads < 1) throw ConfigError(fmt::format("run.threads must be >= 1, got {}", settings_.threads));
  if (settings_.threads > 1 && !POLYDEM_WITH_OPENMP) {
    throw ConfigError(
        fmt::format("run.threads = {} needs a build with POLYDEM_WITH_OPENMP=ON (this one is serial); "
                    "use run.threads = 1",
                    settings_.threads));
  }
  settings_.resort.validate();
  verlet_.setBlocks(settings_.threads);
  verlet_.setThreads(settings_.threads);
}

void ResortRule::validate() const {
  if (interval < 0) throw ConfigError(fmt::format("resort interval must be >= 0 steps (0 = never), got {}", interval));
  if (!(threshold >= 0.0 && std::isfinite(threshold))) {
    throw ConfigError(fmt::format("resort threshold must be a finite number >= 0, got {}", threshold));
  }
  if (cellParticles < 1) throw ConfigError(fmt::format("resort cell particles must be >= 1, got {}", cellParticles));
}

void DemSimulation::selectKernel() {
  flags_.walls = box_.hasWalls();
  flags_.gravity = settings_.gravity != Eigen::Vector3d::Zero();
  flags_.viscous = settings_.viscousDamping > 0.0;
  kernel_ = contact::selectForceKernel(model_, flags_, settings_.generalKernel);
  pairHistory_ = contact::ContactHistory(kernel_.historyWidth);
  wallHistory_ = contact::ContactHistory(kernel_.historyWidth);
  const auto& p = model_.parameters();
  bool gravityOnPeriodic = false;
  for (int k = 0; k < 3; ++k) gravityOnPeriodic |= settings_.gravity[k] != 0.0 && box_.periodic(k);
  conservative_ = settings_.dissipationFree() && !gravityOnPeriodic;
  predict_ = settings_.dashpotVelocity == DashpotVelocity::Predicted &&
             (p.normalDamped() || flags_.viscous || kernel_.rotation);
}

void DemSimulation::rejectCoincidentCentres() const {
  // Two equal centres have no contact normal: the force would be 0/0. Report them as what they are.
  const contact::ContactList& list = verlet_.list();
  const Eigen::Matrix3Xd& x = particles_.position();
  for (Index i = 0; i < list.particleCount(); ++i) {
    for (Index c = list.offset[i]; c < list.offset[i + 1]; ++c) {
      const Index j = list.neighbour[c];
      if (box_.minimumImage(x.col(j) - x.col(i)).squaredNorm() == 0.0) {
        throw ConfigError(
            fmt::format("particles id {} and id {} are coincident (both centred at ({:g}, {:g}, {:g})): "
                        "remove the duplicate from the input",
                        particles_.id()[static_cast<std::size_t>(i)], particles_.id()[static_cast<std::size_t>(j)],
                        x(0, i), x(1, i), x(2, i)));
      }
    }
  }
}

DemSimulation DemSimulation::restore(const DemState& state, const DemSettings& settings) {
  return DemSimulation(state, settings, RestoreTag{});
}

DemSimulation::DemSimulation(const DemState& state, const DemSettings& settings, RestoreTag)
    : box_(state.box),
      settings_(settings),
      model_(settings.contact),
      verlet_(broadphase::makeBroadPhase(settings.broadPhase), state.skin) {
  settings_.skin = verlet_.skin();
  validateSettings();
  const Index n = static_cast<Index>(state.radius.size());
  auto sized = [&](const auto& a, Index rows, const char* what) {
    if (a.size() != static_cast<Eigen::Index>(rows) * n) {
      throw InputError(fmt::format("checkpoint: {} has {} values, expected {}", what, a.size(), rows * n));
    }
  };
  if (n == 0) throw InputError("checkpoint: no particles");
  sized(state.position, 3, "position");
  sized(state.velocity, 3, "velocity");
  sized(state.force, 3, "force");
  sized(state.inverseMass, 1, "inverse mass");
  sized(state.referencePosition, 3, "reference position");
  sized(state.referenceRadius, 1, "reference radius");
  if (state.id.size() != static_cast<std::size_t>(n)) throw InputError("checkpoint: id has the wrong length");
  particles_ = ParticleStore(n, Features{.rotation = state.rotation});
  particles_.position() = state.position;
  particles_.velocity() = state.velocity;
  particles_.force() = state.force;
  particles_.radius() = state.radius;
  particles_.inverseMass() = state.inverseMass;
  particles_.id() = state.id;
  if (state.rotation) {
    sized(state.angularVelocity, 3, "angular velocity");
    sized(state.torque, 3, "torque");
    sized(state.inverseInertia, 1, "inverse inertia");
    particles_.angularVelocity() = state.angularVelocity;
    particles_.torque() = state.torque;
    particles_.inverseInertia() = state.inverseInertia;
  }
  if (settings_.needsRotation() && !state.rotation) {
    throw InputError("checkpoint: the contact law needs rotation but the saved state has none");
  }
  selectKernel();
  timeStep_ = state.timeStep;
  dt_ = timeStep_.dt;
  step_ = state.step;
  timeOrigin_ = state.timeOrigin;
  initialEnergy_ = state.initialEnergy;
  velocityPredicted_ = particles_.velocity();
  if (kernel_.rotation) angularVelocityPredicted_ = particles_.angularVelocity();

  // The list of the last build, from its own positions and radii: the same pairs in the same order.
  verlet_.build(SphereView{state.referencePosition, state.referenceRadius}, box_);
  verlet_.setBuilds(state.builds);
  growthSinceBuild_ = state.growthSinceBuild;
  if (settings_.threads > 1) {
    crossScratch_.resize(contact::crossScratchSize(verlet_.list().crossCount(), kernel_.rotation));
    crossTouching_.resize(verlet_.list().crossCount());
  }
  if (kernel_.historyWidth > 0) {
    verlet_.keys(particles_.id(), pairKeys_, wallKeys_);
    if (pairKeys_ != state.pairKeys || wallKeys_ != state.wallKeys) {
      throw InputError(
          "checkpoint: the rebuilt neighbour list differs from the saved one (was the checkpoint "
          "written by another version of polydem?)");
    }
    pairHistory_.assign(state.pairKeys, state.pairValues);
    wallHistory_.assign(state.wallKeys, state.wallValues);
  }
  chooseLookAhead(contactStats());
}

void DemSimulation::chooseLookAhead(const contact::ContactStats& stats) {
  const auto candidates = static_cast<double>(std::max<std::size_t>(1, verlet_.list().pairCount()));
  lookAhead_ =
      contact::chooseLookAhead(particles_.count(), static_cast<double>(stats.contacts) / candidates, kernel_.batched());
}

DemState DemSimulation::state() const {
  DemState s;
  s.box = box_;
  s.step = step_;
  s.timeOrigin = timeOrigin_;
  s.timeStep = timeStep_;
  s.skin = verlet_.skin();
  s.initialEnergy = initialEnergy_;
  s.growthSinceBuild = growthSinceBuild_;
  s.builds = verlet_.builds();
  s.rotation = particles_.features().rotation;
  s.id = particles_.id();
  s.position = particles_.position();
  s.velocity = particles_.velocity();
  s.force = particles_.force();
  s.radius = particles_.radius();
  s.inverseMass = particles_.inverseMass();
  if (s.rotation) {
    s.angularVelocity = particles_.angularVelocity();
    s.torque = particles_.torque();
    s.inverseInertia = particles_.inverseInertia();
  }
  s.referencePosition = verlet_.reference();
  s.referenceRadius = verlet_.referenceRadius();
  if (kernel_.historyWidth > 0) {
    s.pairKeys.assign(pairHistory_.keys().begin(), pairHistory_.keys().end());
    s.wallKeys.assign(wallHistory_.keys().begin(), wallHistory_.keys().end());
    s.pairValues.assign(pairHistory_.allValues().begin(), pairHistory_.allValues().end());
    s.wallValues.assign(wallHistory_.allValues().begin(), wallHistory_.allValues().end());
  }
  return s;
}

contact::ForceContext DemSimulation::context() const {
  // The kernel writes force, torque and histories; measureContacts() only reads. One builder for both.
  auto& self = const_cast<DemSimulation&>(*this);
  contact::ForceContext c;
  c.count = particles_.count();
  c.position = particles_.position().data();
  c.velocityHalf = particles_.velocity().data();
  c.velocity = predict_ ? velocityPredicted_.data() : particles_.velocity().data();
  c.radius = particles_.radius().data();
  c.inverseMass = particles_.inverseMass().data();
  c.force = self.particles_.force().data();
  if (kernel_.rotation) {
    c.angularVelocityHalf = particles_.angularVelocity().data();
    c.angularVelocity = predict_ ? angularVelocityPredicted_.data() : particles_.angularVelocity().data();
    c.inverseInertia = particles_.inverseInertia().data();
    c.torque = self.particles_.torque().data();
  }
  c.list = &verlet_.list();
  c.pairHistory = &self.pairHistory_;
  c.wallHistory = &self.wallHistory_;
  for (int k = 0; k < 3; ++k) {
    c.length[k] = box_.length(k);
    c.halfLength[k] = box_.periodic(k) ? 0.5 * box_.length(k) : std::numeric_limits<double>::infinity();
    c.gravity[k] = settings_.gravity[k];
  }
  c.viscousRate = settings_.viscousDamping;
  c.dt = dt_;
  c.threads = settings_.threads;
  c.crossScratch = self.crossScratch_.data();
  c.crossTouching = self.crossTouching_.data();
  c.lookAhead = lookAhead_;
  return c;
}

contact::ForceContext DemSimulation::context() { return std::as_const(*this).context(); }

void DemSimulation::computeForces() { kernel_.run(model_, context()); }

void DemSimulation::wrapPositions() {
  Eigen::Matrix3Xd& x = particles_.position();
  const Index n = particles_.count();
  for (Index i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) {
      double& xk = x(k, i);
      const double L = box_.length(k);
      if (!std::isfinite(xk)) blowUp(i, "a non-finite position");
      if (box_.periodic(k)) {
        if (xk < 0.0 || xk >= L) {
          xk -= L * std::floor(xk / L);
          if (xk >= L) xk = 0.0;
          // Only a particle that flew ~1e16 box lengths makes the wrap itself fail.
          if (!(xk >= 0.0 && xk < L)) blowUp(i, fmt::format("{} = {:g} beyond the box", "xyz"[k], xk));
        }
      } else if (xk < 0.0 || xk > L) {
        checkStability();  // names the particle that left the box and why
        fail(
            fmt::format("particle id {} left the box along {}", particles_.id()[static_cast<std::size_t>(i)], "xyz"[k]),
            dtHint());
      }
    }
  }
}

std::uint64_t coarseCell(const double* x, const Box& box, int bits) {
  double w[3];
  for (int k = 0; k < 3; ++k) {
    w[k] = x[k];
    const double L = box.length(k);
    if (box.periodic(k) && (w[k] < 0.0 || w[k] >= L)) {
      w[k] -= L * std::floor(w[k] / L);
      if (w[k] >= L) w[k] = 0.0;
    }
  }
  return mortonKey(w, box, 10) >> (3 * (10 - bits));
}

int orderDecayBits(Index count, Index cellParticles) {
  int bits = 0;
  while (bits < 10 && std::ldexp(static_cast<double>(cellParticles), 3 * (bits + 1)) <= count) ++bits;
  return bits;
}

namespace {

/// a[k] = a[order[k]] for every particle, `width` values per particle, in the array's own memory.
template <class T>
void permuteInPlace(T* a, int width, std::span<const Index> order, std::vector<T>& scratch) {
  const std::size_t w = static_cast<std::size_t>(width);
  scratch.resize(order.size() * w);
  for (std::size_t k = 0; k < order.size(); ++k) {
    std::copy_n(a + static_cast<std::size_t>(order[k]) * w, w, scratch.data() + k * w);
  }
  std::copy(scratch.begin(), scratch.end(), a);
}

}  // namespace

double DemSimulation::orderDecay() const {
  const Index n = particles_.count();
  const int bits = orderDecayBits(n, settings_.resort.cellParticles);
  if (bits == 0) return 0.0;
  const std::size_t cells = std::size_t{1} << (3 * bits);
  decayCells_.assign(cells + 1, 0);
  const Eigen::Matrix3Xd& x = particles_.position();
  for (Index i = 0; i < n; ++i) ++decayCells_[coarseCell(x.col(i).data(), box_, bits) + 1];
  for (std::size_t c = 0; c < cells; ++c) decayCells_[c + 1] += decayCells_[c];
  Index misplaced = 0;
  for (Index i = 0; i < n; ++i) {
    const std::uint64_t c = coarseCell(x.col(i).data(), box_, bits);
    misplaced += (i < decayCells_[c] || i >= decayCells_[c + 1]) ? 1 : 0;
  }
  return static_cast<double>(misplaced) / static_cast<double>(n);
}

void DemSimulation::resortParticles() {
  wrapPositions();
  const std::vector<Index> order = mortonOrder(particles_.position(), box_);
  // In place: the Python module hands out views of these arrays (python/simulation.cpp). The scratch
  // buffers are allocated here, once per re-sort (at most once per resort.interval steps).
  std::vector<double> scratch;
  std::vector<Index> idScratch;
  auto cols = [&](Eigen::Matrix3Xd& m) {
    if (m.cols() == particles_.count()) permuteInPlace(m.data(), 3, order, scratch);
  };
  auto vec = [&](Eigen::VectorXd& v) {
    if (v.size() == particles_.count()) permuteInPlace(v.data(), 1, order, scratch);
  };
  cols(particles_.position());
  cols(particles_.velocity());
  cols(particles_.force());
  cols(velocityPredicted_);
  vec(particles_.radius());
  vec(particles_.inverseMass());
  if (particles_.features().rotation) {
    cols(particles_.angularVelocity());
    cols(particles_.torque());
    vec(particles_.inverseInertia());
    cols(angularVelocityPredicted_);
  }
  permuteInPlace(particles_.id().data(), 1, order, idScratch);
  ++resorts_;
  rebuild();
}

void DemSimulation::rebuild() {
  wrapPositions();
  try {
    verlet_.build(particles_.spheres(), box_);
  } catch (const ConfigError& e) {
    if (step_ == 0) throw;  // the input itself
    // Mid-run, the broad phase only refuses a state the run itself produced.
    fail(fmt::format("blow-up: the neighbour-list rebuild refused the state ({})", e.what()), dtHint());
  }
  growthSinceBuild_ = 0.0;
  if (settings_.threads > 1) {
    // Grows only (resize keeps the capacity): no allocation once the list has reached its size.
    crossScratch_.resize(contact::crossScratchSize(verlet_.list().crossCount(), kernel_.rotation));
    crossTouching_.resize(verlet_.list().crossCount());
  }
  if (kernel_.historyWidth > 0) {
    verlet_.keys(particles_.id(), pairKeys_, wallKeys_);
    pairHistory_.remap(pairKeys_);
    wallHistory_.remap(wallKeys_);
  }
  adviseHugePages();
}

void DemSimulation::adviseHugePages() {
  std::size_t slot = verlet_.adviseHugePages(hugePages_, particles_.adviseHugePages(hugePages_, 0));
  for (const Eigen::Matrix3Xd* m : {&velocityPredicted_, &angularVelocityPredicted_}) {
    hugePages_.apply(slot++, m->data(), static_cast<std::size_t>(m->size()) * sizeof(double));
  }
}

std::int64_t DemSimulation::advance(std::int64_t steps, bool stopOnInterrupt) {
  const std::int64_t checkInterval = settings_.stability.checkInterval;
  bool closePending = false;  // the previous step's closing half kick is left to this step's opening pass
  for (std::int64_t s = 0; s < steps; ++s) {
    const double limit = std::max(0.0, 0.5 * verlet_.skin() - growthSinceBuild_);
    const Clock::time_point t0 = Clock::now();
    const double maxSq = openingKickAndDrift(closePending);
    const Clock::time_point t1 = Clock::now();
    // Re-sort at fixed steps when the order has decayed (a decision independent of the skin), else rebuild
    // when some particle moved skin / 2.
    const ResortRule& rule = settings_.resort;
    if (settings_.spatialSort && rule.interval > 0 && (step_ + 1) % rule.interval == 0 &&
        orderDecay() > rule.threshold) {
      resortParticles();
    } else if (maxSq > limit * limit) {
      rebuild();
    }
    const Clock::time_point t2 = Clock::now();
    computeForces();
    const Clock::time_point t3 = Clock::now();
    // The closing half kick joins the next step's opening pass when that step follows at once: not the call's
    // last step, no stability check after this one (it reads the full-step velocities), no stop asked for (an
    // interrupt arriving after this decision stops the run one step later, after an unfused step).
    closePending = joinClosingKick(s, steps, step_ + 1, checkInterval, stopOnInterrupt && interruptRequested());
    if (closePending) {
      ++times_.joinedKicks;
    } else {
      closingKick();
    }
    const Clock::time_point t4 = Clock::now();
    times_.integration += seconds(t0, t1) + seconds(t3, t4);
    times_.broadPhase += seconds(t1, t2);
    times_.force += seconds(t2, t3);
    ++step_;
    if (settings_.stability.checkInterval > 0 && step_ % settings_.stability.checkInterval == 0) {
      chooseLookAhead(checkStability());
      times_.check += seconds(t4, Clock::now());
    }
    if (stopOnInterrupt && !closePending && interruptRequested()) return s + 1;
  }
  return steps;
}

double DemSimulation::openingKickAndDrift(bool close) { return close ? openingPass<true>() : openingPass<false>(); }

template <bool kClose>
double DemSimulation::openingPass() {
  const Index n = particles_.count();
  const int threads = settings_.threads;
  KickArrays translation{particles_.velocity().data(), particles_.force().data(), particles_.inverseMass().data(),
                         velocityPredicted_.data()};
  const DriftArrays drift{particles_.position().data(), verlet_.reference().data()};
  const double maxSq = predict_ ? halfKick<true, true, kClose>(n, threads, dt_, translation, drift)
                                : halfKick<true, false, kClose>(n, threads, dt_, translation, drift);
  if (kernel_.rotation) {
    const KickArrays rotation{particles_.angularVelocity().data(), particles_.torque().data(),
                              particles_.inverseInertia().data(), angularVelocityPredicted_.data()};
    if (predict_) {
      halfKick<false, true, kClose>(n, threads, dt_, rotation);
    } else {
      halfKick<false, false, kClose>(n, threads, dt_, rotation);
    }
  }
  return maxSq;
}

void DemSimulation::closingKick() {
  const Index n = particles_.count();
  const int threads = settings_.threads;
  halfKick<false, false>(n, threads, dt_,
                         {particles_.velocity().data(), particles_.force().data(), particles_.inverseMass().data()});
  if (kernel_.rotation) {
    halfKick<false, false>(
        n, threads, dt_,
        {particles_.angularVelocity().data(), particles_.torque().data(), particles_.inverseInertia().data()});
  }
}

void DemSimulation::growRadii(double factor) {
  if (!(factor >= 1.0 && std::isfinite(factor))) {
    throw ConfigError(fmt::format("growRadii: factor must be >= 1, got {}", factor));
  }
  const double f3 = factor * factor * factor;
  growthSinceBuild_ += (factor - 1.0) * particles_.radius().maxCoeff();
  particles_.radius() *= factor;
  particles_.inverseMass() /= f3;
  if (particles_.features().rotation) particles_.inverseInertia() /= f3 * factor * factor;
  // A grown pair may already have been closer than the skin allows: rebuild now if needed.
  // Forces are not recomputed here (that would advance the tangential springs twice): the next step's
  // first half-kick uses forces of the old radii, an O(dr) error that only compression runs see.
  if (growthSinceBuild_ > 0.5 * verlet_.skin()) rebuild();
  // Only a dissipation-free run checks its energy; a damped one (every soft compression) keeps its reference
  // untouched, which also keeps a distributed compression's checkpoint byte-identical (parallel/distributed_dem).
  if (conservative_) initialEnergy_ = energies().total();
}

double DemSimulation::packingFraction() const { return packingFraction(particles_.radius(), box_); }

double DemSimulation::packingFraction(const Eigen::VectorXd& radius, const Box& box) {
  return 4.0 / 3.0 * kPi * radius.array().cube().sum() / box.volume();
}

contact::ContactStats DemSimulation::contactStats() const { return contact::measureContacts(model_, context()); }

Energies DemSimulation::energies(const contact::ContactStats& stats) const {
  Energies e;
  const Index n = particles_.count();
  const Eigen::Matrix3Xd& v = particles_.velocity();
  const Eigen::VectorXd& im = particles_.inverseMass();
  for (Index i = 0; i < n; ++i) {
    e.kinetic += 0.5 * v.col(i).squaredNorm() / im[i];
    if (settings_.gravity != Eigen::Vector3d::Zero()) {
      e.potential -= settings_.gravity.dot(particles_.position().col(i)) / im[i];
    }
  }
  if (particles_.features().rotation) {
    const Eigen::Matrix3Xd& w = particles_.angularVelocity();
    const Eigen::VectorXd& ii = particles_.inverseInertia();
    for (Index i = 0; i < n; ++i) e.rotational += 0.5 * w.col(i).squaredNorm() / ii[i];
  }
  e.elastic = stats.elasticEnergy;
  return e;
}

Eigen::Vector3d DemSimulation::momentum() const {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (Index i = 0; i < particles_.count(); ++i) p += particles_.velocity().col(i) / particles_.inverseMass()[i];
  return p;
}

std::size_t DemSimulation::memoryBytes() const {
  const auto n = static_cast<std::size_t>(particles_.count());
  std::size_t bytes = n * (9 + 2) * sizeof(double) + n * sizeof(Index);  // x, v, F, r, 1/m, id
  if (particles_.features().rotation) bytes += n * 7 * sizeof(double);
  bytes += static_cast<std::size_t>(velocityPredicted_.size() + angularVelocityPredicted_.size()) * sizeof(double);
  bytes += crossScratch_.capacity() * sizeof(double) + crossTouching_.capacity();
  bytes += verlet_.memoryBytes() + pairHistory_.memoryBytes() + wallHistory_.memoryBytes();
  bytes += (pairKeys_.capacity() + wallKeys_.capacity()) * sizeof(std::uint64_t);
  bytes += decayCells_.capacity() * sizeof(Index);
  return bytes;
}

}  // namespace polydem::integrators
