#include "integrators/fire_minimiser.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>

#include "broadphase/parallel.hpp"
#include "broadphase/registry.hpp"
#include "core/errors.hpp"
#include "core/interrupt.hpp"
#include "integrators/dem_simulation.hpp"  // mortonOrder
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

/// The two largest squared displacements since the list's build, for the rebuild rule (listStale()).
struct LargestTwo {
  double first = 0.0, second = 0.0;
  // Branch-free (the same values as `if (dsq > second) {second = min(dsq, first); first = max(dsq, first);}`,
  // a NaN left out as there): the update pass's one loop-carried dependency is then two maxima per particle.
  void add(double dsq) {
    second = std::max(second, std::min(dsq, first));
    first = std::max(first, dsq);
  }
  double drift() const { return std::sqrt(first) + std::sqrt(second); }
};

/// The sums of FIRE's reduction pass: P = F.v, |v|^2, |F|^2, sum (F_i.v_i)/m_i and sum |F_i|^2/m_i^2 (the
/// kicked |v|^2 without a second pass), and the largest |F_i|^2.
struct FireSums {
  double power = 0.0, vv = 0.0, ff = 0.0, fvm = 0.0, ffm = 0.0, fmaxSq = 0.0;
  void add(const FireSums& o) {
    power += o.power;
    vv += o.vv;
    ff += o.ff;
    fvm += o.fvm;
    ffm += o.ffm;
    fmaxSq = std::max(fmaxSq, o.fmaxSq);
  }
};

/// The minimisers' passes run over fixed chunks of particles, each chunk's sums kept apart and added in chunk
/// order afterwards: the result is the same for any thread count (the threads only share out the chunks).
constexpr Index kFireChunk = 4096;

Index fireChunks(Index n) { return (n + kFireChunk - 1) / kFireChunk; }

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

/// The sums of particles [begin, end): even and odd ones into separate sums added at the end (two add
/// chains per sum instead of one; four measured the same). The order is fixed, so the result is too.
FireSums reduceForFire(Index begin, Index end, const double* f, const double* v, const double* im) {
  double power[2] = {}, vv[2] = {}, ff[2] = {}, fvm[2] = {}, ffm[2] = {}, fmax[2] = {};
  auto particle = [&](Index i, int lane) {
    const double* fi = f + 3 * i;
    const double* vi = v + 3 * i;
    const double fsq = fi[0] * fi[0] + fi[1] * fi[1] + fi[2] * fi[2];
    const double fv = fi[0] * vi[0] + fi[1] * vi[1] + fi[2] * vi[2];
    power[lane] += fv;
    vv[lane] += vi[0] * vi[0] + vi[1] * vi[1] + vi[2] * vi[2];
    ff[lane] += fsq;
    fvm[lane] += fv * im[i];
    ffm[lane] += fsq * im[i] * im[i];
    fmax[lane] = std::max(fmax[lane], fsq);
  };
  Index i = begin;
  for (; i + 1 < end; i += 2) {
    particle(i, 0);
    particle(i + 1, 1);
  }
  if (i < end) particle(i, 0);
  return {power[0] + power[1], vv[0] + vv[1],   ff[0] + ff[1],
          fvm[0] + fvm[1],     ffm[0] + ffm[1], std::max(fmax[0], fmax[1])};
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
    for (Index i = begin; i < end; ++i) {
      double dsq = 0.0;
      for (int k = 0; k < 3; ++k) {
        const Index j = 3 * i + k;
        x[j] += a * d[j];
        const double dx = x[j] - ref[j];
        dsq += dx * dx;
      }
      largest.add(dsq);
    }
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

FireMinimiser::StiffnessRule FireMinimiser::stiffnessRule() const {
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
  Eigen::VectorXd& im = particles_.inverseMass();
  const Eigen::VectorXd& r = particles_.radius();
  const Index n = particles_.count();
  const contact::ContactList& list = verlet_.list();
  const StiffnessRule stiffness = stiffnessRule();
  for (Index i = 0; i < n; ++i) im[i] = stiffness(r[i], r[i]);
  for (Index i = 0; i < n; ++i) {
    const double ri = r[i];
    double mi = im[i];  // j != i: the stores to im[j] leave it alone
    for (Index c = list.offset[i]; c < list.offset[i + 1]; ++c) {
      const Index j = list.neighbour[c];
      const double k = stiffness(ri, r[j]);
      mi += k;
      im[j] += k;
    }
    im[i] = mi;
  }
  for (std::size_t c = 0; c < list.wallParticle.size(); ++c) {
    const Index i = list.wallParticle[c];
    im[i] += 2.0 * stiffness(r[i], r[i]);  // R_eff = r_i against a wall
  }
  for (Index i = 0; i < n; ++i) im[i] = 1.0 / im[i];
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
        throw SimulationError(fmt::format(
            "minimiser: particle id {} left the walled box along {} (a step too large for the wall stiffness: "
            "reduce minimise.dt)",
            particles_.id()[static_cast<std::size_t>(i)], "xyz"[k]));
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
  return 4.0 / 3.0 * kPi * particles_.radius().array().cube().sum() / box_.volume();
}

double FireMinimiser::contactForceAtPressure(double reducedPressure) const {
  const double meanDiameter = 2.0 * particles_.radius().mean();
  return reducedPressure * pressureUnit_ * box_.volume() / (static_cast<double>(particles_.count()) * meanDiameter);
}

MinimiserReport FireMinimiser::measure() const {
  MinimiserReport rep;
  const contact::ForceContext ctx = context();
  const contact::ContactList& list = verlet_.list();
  const bool hertz = model_.parameters().normal == contact::NormalModel::Hertz;
  const auto lin = model_.linearParams();
  const auto hz = model_.hertzParams();
  auto normalForce = [&](double overlap, double reff) {
    return hertz ? contact::HertzNormal::force(hz, overlap, 0.0, 1.0, reff).force
                 : contact::LinearNormal::force(lin, overlap, 0.0, 1.0, reff).force;
  };
  double forceSum = 0.0, virial = 0.0;
  const double* x = ctx.position;
  const double* r = ctx.radius;
  for (Index i = 0; i < ctx.count; ++i) {
    for (Index c = list.offset[i]; c < list.offset[i + 1]; ++c) {
      const Index j = list.neighbour[c];
      double dsq = 0.0;
      for (int k = 0; k < 3; ++k) {  // the kernel's minimum image
        double d = x[3 * i + k] - x[3 * j + k];
        if (d > ctx.halfLength[k]) {
          d -= ctx.length[k];
        } else if (d < -ctx.halfLength[k]) {
          d += ctx.length[k];
        }
        dsq += d * d;
      }
      const double sumR = r[i] + r[j];
      if (dsq >= sumR * sumR) continue;
      const double dist = std::sqrt(dsq);
      const double overlap = sumR - dist;
      const double reff = r[i] * r[j] / sumR;
      const double fn = normalForce(overlap, reff);
      ++rep.contacts;
      rep.energy += model_.normalEnergy(overlap, reff);
      forceSum += fn;
      virial += fn * dist;
      rep.maxOverlapRatio = std::max(rep.maxOverlapRatio, overlap / std::min(r[i], r[j]));
      rep.maxOverlap = std::max(rep.maxOverlap, overlap);
    }
  }
  for (std::size_t c = 0; c < list.wallParticle.size(); ++c) {
    const Index i = list.wallParticle[c];
    const int face = list.wallFace[c];
    const int axis = face >> 1;
    const double gap = (face & 1) ? ctx.length[axis] - x[3 * i + axis] : x[3 * i + axis];
    const double overlap = r[i] - gap;
    if (!(overlap > 0.0)) continue;
    const double fn = normalForce(overlap, r[i]);
    ++rep.wallContacts;
    rep.energy += model_.normalEnergy(overlap, r[i]);
    forceSum += fn;
    virial += fn * gap;  // the lever from the centre to the wall
    rep.maxOverlapRatio = std::max(rep.maxOverlapRatio, overlap / r[i]);
    rep.maxOverlap = std::max(rep.maxOverlap, overlap);
  }
  const std::size_t all = rep.contacts + rep.wallContacts;
  rep.meanContactForce = all > 0 ? forceSum / static_cast<double>(all) : 0.0;
  rep.pressure = virial / (3.0 * box_.volume());
  rep.reducedPressure = rep.pressure / pressureUnit_;
  const Eigen::VectorXd& im = particles_.inverseMass();
  double forceSq = 0.0, stepSq = 0.0;  // largest |F_i|^2 and largest Jacobi step |F_i|^2 / m_i^2
  for (Index i = 0; i < particles_.count(); ++i) {
    const double fi = particles_.force().col(i).squaredNorm();
    forceSq = std::max(forceSq, fi);
    stepSq = std::max(stepSq, fi * im[i] * im[i]);
  }
  rep.maxForce = std::sqrt(forceSq);
  rep.stepUlps = std::sqrt(stepSq) / (std::numeric_limits<double>::epsilon() * box_.lengths().maxCoeff());
  const double scale = std::max(rep.meanContactForce, settings_.fire.referenceForce);
  rep.residual = scale > 0.0 ? rep.maxForce / scale : 0.0;
  rep.packingFraction = packingFraction();
  return rep;
}

FireResult FireMinimiser::minimise(const Progress& progress, bool stopOnInterrupt) {
  const FireSettings& fs = settings_.fire;
  fs.validate();
  FireResult res;
  rebuildsInCall_ = 0;
  broadBuildsInCall_ = 0;
  const auto callStart = Clock::now();
  const double broadAtStart = broadSeconds_, forceAtStart = forceSeconds_;
  double measureSeconds = 0.0;
  auto timedMeasure = [&] {
    const auto t0 = Clock::now();
    MinimiserReport r = measure();
    measureSeconds += seconds(t0, Clock::now());
    return r;
  };
  MinimiserReport start = timedMeasure();
  if (model_.parameters().normal == contact::NormalModel::Hertz) {
    // Masses from the stiffness at the current overlaps (Hertz stiffens with overlap); 1e-4 without contacts.
    const double ratio = start.maxOverlapRatio > 0.0 ? start.maxOverlapRatio : 1e-4;
    if (ratio != hertzReferenceOverlap_) {
      hertzReferenceOverlap_ = ratio;
      updateMasses();
    }
  }
  const Index n = particles_.count();
  double* x = particles_.position().data();
  double* v = particles_.velocity().data();
  const double* f = particles_.force().data();
  const double* im = particles_.inverseMass().data();
  particles_.velocity().setZero();

  const double dtMax = fs.dt * fs.dtMaxFactor;
  const double dtMin = fs.dt * fs.dtMinFactor;
  double dt = fs.dt;
  double alpha = fs.alphaStart;
  std::int64_t downhill = 0, uphill = 0;
  double knownScale = std::max(start.meanContactForce, fs.referenceForce);
  constexpr std::int64_t kMeasureEvery = 256;
  // The stall window of the round-off floor: 4 x the evaluations the residual's last halving took, within
  // [kStallMin, kStallMax] (the window follows the descent's own pace: 16384 whatever the pace wasted 10-20% of
  // a near-jamming minimisation at N = 10^4 after the floor was reached).
  constexpr std::int64_t kStallMin = 2048, kStallMax = 16384;
  double bestResidual = std::numeric_limits<double>::infinity();
  std::int64_t bestAt = 0, halvingGap = kStallMax;
  const double overlapFloor = 64.0 * std::numeric_limits<double>::epsilon() * box_.lengths().maxCoeff();

  auto finish = [&](bool converged, const char* reason, std::int64_t it, const MinimiserReport* report) {
    res.converged = converged;
    res.stopReason = reason;
    res.iterations = it;
    res.rebuilds = rebuildsInCall_;
    res.broadPhaseBuilds = broadBuildsInCall_;
    res.last = report ? *report : timedMeasure();
    res.last.iteration = it;
    res.last.dt = dt;
    particles_.velocity().setZero();
    res.seconds.broadPhase = broadSeconds_ - broadAtStart;
    res.seconds.force = forceSeconds_ - forceAtStart;
    res.seconds.measure = measureSeconds;
    res.seconds.update =
        std::max(0.0, seconds(callStart, Clock::now()) - res.seconds.broadPhase - res.seconds.force - measureSeconds);
    return res;
  };

  // The stopping rule after a measurement at force evaluation `it` (both methods; all are converged stops):
  // the reason to stop, or nullptr.
  auto verdict = [&](const MinimiserReport& now, double fmax, std::int64_t it) -> const char* {
    if (now.contacts + now.wallContacts == 0) return "no contacts";
    if (now.maxOverlap <= overlapFloor) return "overlaps at round-off";
    knownScale = std::max(now.meanContactForce, fs.referenceForce);
    if (fmax <= fs.forceTolerance * knownScale) return "converged";
    // The round-off floor: the remaining forces ask every particle to move by less than the resolution of
    // its coordinates, and the residual has not halved for the stall window. A tolerance below that floor cannot
    // be met (seen: 10^4 equal spheres at p/k 1e-6, residual hovering at 3-5e-9 against 1e-9 for 1.3 million
    // steps); stop and say so rather than spend the iteration budget.
    if (now.residual < 0.5 * bestResidual) {
      if (std::isfinite(bestResidual)) halvingGap = it - bestAt;
      bestResidual = now.residual;
      bestAt = it;
    }
    const std::int64_t window = std::clamp(4 * halvingGap, kStallMin, kStallMax);
    if (now.stepUlps <= 1.0 && it - bestAt >= window) return "round-off floor";
    return nullptr;
  };
  auto report = [&](std::int64_t it, double step) {
    MinimiserReport now = timedMeasure();
    now.iteration = it;
    now.dt = step;
    knownScale = std::max(now.meanContactForce, fs.referenceForce);
    progress(now);
  };
  const int threads = settings_.threads;
  const Index chunks = fireChunks(n);
  if (settings_.method == MinimiserMethod::ConjugateGradient) {
    // Preconditioned Polak-Ribiere+ conjugate gradients (the header): s = M^-1 F, d = s + beta d, and a line
    // search of one trial move and one secant move. `dt` holds the line step, in units of M^-1 F. The passes
    // over the particles run by chunks (forChunks, sums added in chunk order: the same for any thread count),
    // and the direction update also gives the next iteration's F.d, max |d_i| and max |F_i|: five passes (was eight)
    // and two force evaluations per iteration.
    const std::size_t m = 3 * static_cast<std::size_t>(n);
    cgDirection_.resize(m);
    cgPrevious_.resize(m);
    double* d = cgDirection_.data();
    double* previous = cgPrevious_.data();                                          // M^-1 F at the last iteration
    std::vector<std::array<double, 3>> perChunk(static_cast<std::size_t>(chunks));  // once per call
    std::array<double, 3>* part = perChunk.data();
    auto total = [&](int k) {
      double sum = 0.0;
      for (Index c = 0; c < chunks; ++c) sum += part[c][static_cast<std::size_t>(k)];
      return sum;
    };
    auto largest = [&](int k) {
      double most = 0.0;
      for (Index c = 0; c < chunks; ++c) most = std::max(most, part[c][static_cast<std::size_t>(k)]);
      return most;
    };
    // F.d (0), max |d_i|^2 (1), max |F_i|^2 (2) for the direction as it is; with `beta` >= 0 first
    // d = M^-1 F + beta d (the previous M^-1 F being the current one here).
    auto direct = [&](double beta, bool update) {
      forChunks(n, threads, [=](Index c, Index begin, Index end) {
        double g = 0.0, dmax = 0.0, fmax = 0.0;
        for (Index i = begin; i < end; ++i) {
          const double* fi = f + 3 * i;
          double* di = d + 3 * i;
          if (update) {
            for (int k = 0; k < 3; ++k) di[k] = previous[3 * i + k] + beta * di[k];
          }
          g += fi[0] * di[0] + fi[1] * di[1] + fi[2] * di[2];
          dmax = std::max(dmax, di[0] * di[0] + di[1] * di[1] + di[2] * di[2]);
          fmax = std::max(fmax, fi[0] * fi[0] + fi[1] * fi[1] + fi[2] * fi[2]);
        }
        part[c] = {g, dmax, fmax};
      });
    };
    auto alongDirection = [&] {
      forChunks(n, threads, [=](Index c, Index begin, Index end) {
        double g = 0.0;
        for (Index k = 3 * begin; k < 3 * end; ++k) g += f[k] * d[k];
        part[c][0] = g;
      });
      return total(0);
    };
    // M^-1 F into `previous`: F.M^-1 F (0) and F.(M^-1 F - previous) (1).
    auto precondition = [&] {
      forChunks(n, threads, [=](Index c, Index begin, Index end) {
        double sNew = 0.0, change = 0.0;
        for (Index i = begin; i < end; ++i) {
          for (int k = 0; k < 3; ++k) {
            const Index a = 3 * i + k;
            const double sk = im[i] * f[a];
            sNew += f[a] * sk;
            change += f[a] * (sk - previous[a]);
            previous[a] = sk;
          }
        }
        part[c] = {sNew, change, 0.0};
      });
    };
    std::fill(previous, previous + m, 0.0);
    precondition();
    double sOld = total(0);  // F.M^-1 F at the last iteration
    std::copy(previous, previous + m, d);
    direct(0.0, false);
    dt = 0.5;  // the line minimum of a mode of preconditioned stiffness 2 (about the stiffest) lies at 0.5
    std::int64_t evaluations = 0;
    for (std::int64_t iteration = 0;; ++iteration) {
      double g0 = total(0), dmaxSq = largest(1);
      const double fmaxSq = largest(2);
      if (!std::isfinite(fmaxSq)) {
        throw SimulationError(fmt::format("minimiser: non-finite forces at CG iteration {}", iteration));
      }
      const double fmax = std::sqrt(fmaxSq);
      // Every 128 iterations = 256 force evaluations, as FIRE measures.
      if (fmax <= fs.forceTolerance * knownScale || fmaxSq == 0.0 || iteration % (kMeasureEvery / 2) == 0) {
        const MinimiserReport now = timedMeasure();
        if (const char* why = verdict(now, fmax, evaluations)) return finish(true, why, evaluations, &now);
      }
      if (evaluations >= fs.maxIterations) return finish(false, "iteration budget", evaluations, nullptr);
      if (stopOnInterrupt && interruptRequested()) return finish(false, "interrupted", evaluations, nullptr);
      if (progress && fs.progressInterval > 0 && iteration % ((fs.progressInterval + 1) / 2) == 0) {
        report(evaluations, dt);
      }
      if (!(g0 > 0.0)) {  // not a descent direction: restart along M^-1 F
        ++res.uphillSteps;
        g0 = sOld;
        std::copy(previous, previous + m, d);
        direct(0.0, false);
        dmaxSq = largest(1);
      }
      // No line move carries a sphere further than one skin (a guard: near jamming the moves are ~1e-6 of it;
      // without it, a direction without positive curvature would grow the step 4x per iteration unbounded).
      const double reach = dmaxSq > 0.0 ? verlet_.skin() / std::sqrt(dmaxSq) : 4.0 * dt;
      const double trial = std::min(dt, reach);
      moveAlong(d, trial);
      const double g1 = alongDirection();
      // The secant root of g(a) = F(x + a d).d; where g did not fall (no positive curvature along d), go on
      // downhill by the cap.
      const double secant = g0 > g1 ? trial * g0 / (g0 - g1) : 4.0 * trial;
      const double best = std::min({secant, 4.0 * trial, reach});
      moveAlong(d, best - trial);
      evaluations += 2;
      dt = std::max(best, 1e-4);  // the next trial: the last line step (kept off zero)
      precondition();
      const double sNew = total(0), change = total(1);
      const double beta = sOld > 0.0 ? std::max(0.0, change / sOld) : 0.0;
      sOld = sNew;
      direct(beta, true);
    }
  }

  // FIRE's passes by chunks (forChunks): per-chunk sums and displacement maxima, combined in chunk order.
  std::vector<FireSums> sumsOfChunk(static_cast<std::size_t>(chunks));  // once per call, not per step
  FireSums* chunkSums = sumsOfChunk.data();
  double* maxima = chunkMaxima_.data();
  for (std::int64_t it = 0;; ++it) {
    forChunks(n, threads, [=](Index c, Index begin, Index end) { chunkSums[c] = reduceForFire(begin, end, f, v, im); });
    FireSums sums;
    for (Index c = 0; c < chunks; ++c) sums.add(chunkSums[c]);
    auto [power, vv, ff, fvm, ffm, fmaxSq] = sums;
    if (!std::isfinite(ff) || !std::isfinite(vv)) {
      throw SimulationError(fmt::format("minimiser: non-finite forces or velocities at FIRE step {}", it));
    }
    const double fmax = std::sqrt(fmaxSq);
    if (fmax <= fs.forceTolerance * knownScale || fmaxSq == 0.0 || it % kMeasureEvery == 0) {
      const MinimiserReport now = timedMeasure();
      if (const char* why = verdict(now, fmax, it)) return finish(true, why, it, &now);
    }
    if (it >= fs.maxIterations) return finish(false, "iteration budget", it, nullptr);
    if (stopOnInterrupt && interruptRequested()) return finish(false, "interrupted", it, nullptr);
    if (progress && fs.progressInterval > 0 && it % fs.progressInterval == 0) report(it, dt);

    if (power > 0.0) {
      ++downhill;
      uphill = 0;
      if (downhill > fs.nDelay) {
        dt = std::min(dt * fs.fInc, dtMax);
        alpha *= fs.fAlpha;
      }
    } else {
      downhill = 0;
      ++uphill;
      ++res.uphillSteps;
      if (uphill > fs.maxUphill) return finish(false, "uphill", it, nullptr);
      if (!(fs.initialDelay && it < fs.nDelay)) {
        if (dt * fs.fDec >= dtMin) dt *= fs.fDec;
        alpha = fs.alphaStart;
      }
      // FIRE 2.0: correct the overshoot by half a step back, then restart from rest.
      for (Index a = 0; a < 3 * n; ++a) {
        x[a] -= 0.5 * dt * v[a];
        v[a] = 0.0;
      }
      vv = 0.0;
      fvm = 0.0;
    }

    // Semi-implicit Euler with the FIRE mixing between kick and drift: v += dt F/m; v = (1 - alpha) v +
    // alpha |v| F/|F|; x += dt v. |v| after the kick from the sums above (no second pass).
    const double kicked = std::sqrt(std::max(0.0, vv + 2.0 * dt * fvm + dt * dt * ffm));
    const double fNorm = std::sqrt(ff);
    const double keep = fNorm > 0.0 ? 1.0 - alpha : 1.0;
    const double toward = fNorm > 0.0 ? alpha * kicked / fNorm : 0.0;
    const double* ref = verlet_.reference().data();
    forChunks(n, threads, [=](Index c, Index begin, Index end) {
      LargestTwo largest;  // squared displacements since the build
      for (Index i = begin; i < end; ++i) {
        // Registers first, stores last: the arrays may alias as far as the compiler knows (see halfKick).
        const double h = dt * im[i];
        double fa[3], va[3], xa[3];
        for (int k = 0; k < 3; ++k) {
          fa[k] = f[3 * i + k];
          va[k] = v[3 * i + k];
          xa[k] = x[3 * i + k];
        }
        double dsq = 0.0;
        for (int k = 0; k < 3; ++k) {
          va[k] = keep * (va[k] + h * fa[k]) + toward * fa[k];
          xa[k] += dt * va[k];
          const double dx = xa[k] - ref[3 * i + k];
          dsq += dx * dx;
        }
        for (int k = 0; k < 3; ++k) {
          v[3 * i + k] = va[k];
          x[3 * i + k] = xa[k];
        }
        largest.add(dsq);
      }
      maxima[2 * c] = largest.first;
      maxima[2 * c + 1] = largest.second;
    });
    pairDrift_ = driftOfChunks(chunkMaxima_);
    if (listStale()) rebuild();
    computeForces();
  }
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
