// DistributedFire: the serial FIRE minimiser on MPI ranks. The argument for bit-identity is in
// distributed_fire.hpp; every expression that decides a value is the serial code's own (fire_descent.hpp,
// the broad phase's pair predicate, the compiled force kernel).
#include "parallel/distributed_fire.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "broadphase/auto_select.hpp"
#include "broadphase/broad_phase.hpp"
#include "core/errors.hpp"
#include "core/interrupt.hpp"
#include "integrators/verlet_list.hpp"
#include "parallel/mpi_util.hpp"

namespace polydem::parallel {

namespace {

using integrators::fire::kChunk;

integrators::DemState stateOf(const integrators::FireMinimiser& m) {
  const integrators::FireMinimiser::ListState ls = m.listState();
  if (ls.moved || ls.growthSinceBuild != 0.0 || ls.growthSinceOuter != 0.0 ||
      m.neighbours().referenceRadius() != m.particles().radius()) {
    throw std::logic_error("DistributedFire: the minimiser's particles changed since its construction");
  }
  const ParticleStore& p = m.particles();
  integrators::DemState g;
  g.box = m.box();
  g.skin = m.settings().outerSkin;  // the ghosts and the candidates reach the outer skin
  g.id = p.id();
  g.position = p.position();
  g.velocity = Eigen::Matrix3Xd::Zero(3, p.count());
  g.force = p.force();
  g.radius = p.radius();
  g.inverseMass = p.inverseMass();
  g.referencePosition = p.position();
  g.referenceRadius = p.radius();
  return g;
}

integrators::DemSettings settingsOf(const integrators::FireMinimiser& m) {
  integrators::DemSettings s;
  s.contact = m.settings().contact;
  s.broadPhase = m.settings().broadPhase;
  s.skin = m.settings().outerSkin;
  s.threads = m.settings().threads;
  s.spatialSort = false;  // the minimiser sorted once at its construction; the slots are the keys
  s.resort.interval = 0;
  return s;
}

}  // namespace

DistributedFire::DistributedFire(const integrators::FireMinimiser& m, DecompositionKind kind)
    : settings_(m.settings()), dem_(stateOf(m), settingsOf(m), kind) {
  if (dem_.kernel_.name != m.kernel().name) {
    throw std::logic_error(
        fmt::format("DistributedFire: kernel {} differs from the minimiser's {}", dem_.kernel_.name, m.kernel().name));
  }
  const integrators::FireMinimiser::ListState ls = m.listState();
  total_ = m.particles().count();
  skin_ = m.neighbours().skin();
  outerSkin_ = settings_.outerSkin;
  pressureUnit_ = m.pressureUnit();
  hertzReferenceOverlap_ = ls.hertzReferenceOverlap;
  chunks_.setup(dem_.key_, dem_.ownedSlots_, total_, kChunk);
  cut();
  updateMasses();
  computeForces();
  forceEvaluations_ = m.forceEvaluations();  // the same forces as the minimiser's last evaluation
}

// ---- the list, the masses, the forces -------------------------------------------------------------------

void DistributedFire::cut() {
  // VerletList::cutFromOuter() on the local rows: the rows keep the candidates' order.
  const contact::ContactList& outer = dem_.list_;
  const SphereView spheres{dem_.x_, dem_.r_};
  integrators::cutList(outer, spheres, dem_.box_, skin_, inner_);
  if (settings_.threads > 1) {
    inner_.buildBlocks(settings_.threads);
    crossScratch_.resize(contact::crossScratchSize(inner_.crossCount(), false));
    crossTouching_.resize(inner_.crossCount());
  }
  innerReference_ = dem_.x_;
  growthSinceBuild_ = 0.0;
  pairDrift_ = 0.0;
}

integrators::fire::StiffnessRule DistributedFire::stiffnessRule() const {
  // FireMinimiser::stiffnessRule().
  const contact::ContactParameters& p = dem_.model_.parameters();
  if (p.normal == contact::NormalModel::Hertz) return {1.5 * p.stiffness, std::sqrt(hertzReferenceOverlap_), true};
  const contact::LinearNormal::Params linear = dem_.model_.linearParams();
  return {linear.stiffness, 1.0, linear.radiusScaled};
}

void DistributedFire::updateMasses() {
  integrators::fire::jacobiMasses(inner_, dem_.r_.data(), dem_.n_, stiffnessRule(), dem_.invm_.data());
}

contact::ForceContext DistributedFire::context() {
  contact::ForceContext c = dem_.context();
  c.list = &inner_;
  c.crossScratch = crossScratch_.data();
  c.crossTouching = crossTouching_.data();
  return c;
}

void DistributedFire::computeForces() {
  const double t0 = MPI_Wtime();
  if (dem_.n_ > 0) dem_.kernel_.run(dem_.model_, context());
  ++forceEvaluations_;
  forceSeconds_ += MPI_Wtime() - t0;
}

double DistributedFire::drift(const Eigen::Matrix3Xd& reference) {
  integrators::fire::LargestTwo largest;
  double finite = 1.0;
  for (const Index i : dem_.ownedSlots_) {
    const double dsq = (dem_.x_.col(i) - reference.col(i)).squaredNorm();
    if (!std::isfinite(dsq)) finite = 0.0;
    largest.add(dsq);
  }
  std::vector<double> all(3 * static_cast<std::size_t>(dem_.size_));
  const double mine[3] = {largest.first, largest.second, finite};
  {
    CommTimer timer(dem_.stats_.commSeconds);
    mpiCheck(MPI_Allgather(mine, 3, MPI_DOUBLE, all.data(), 3, MPI_DOUBLE, MPI_COMM_WORLD), "MPI_Allgather");
  }
  integrators::fire::LargestTwo global;
  for (std::size_t q = 0; q < all.size(); q += 3) {
    if (all[q + 2] == 0.0) return std::numeric_limits<double>::infinity();
    global.add(all[q]);
    global.add(all[q + 1]);
  }
  return global.drift();
}

void DistributedFire::rebuild() {
  const double t0 = MPI_Wtime();
  // FireMinimiser::rebuild(): outerDrift() over every particle (VerletList::outerDrift: +inf if a centre is
  // not finite), against the room the outer candidates leave.
  if (outerSkin_ > skin_ && drift(dem_.ref_) + 2.0 * growthSinceOuter_ <= outerSkin_ - skin_) {
    dem_.exchangeGhosts();  // the cut reads the ghosts' centres
    cut();
  } else {
    checkCentres();
    dem_.rebuild();  // wraps the centres (as broadPhaseBuild()), migrates, sends fresh ghosts, the candidates
    chunks_.setup(dem_.key_, dem_.ownedSlots_, total_, kChunk);
    growthSinceOuter_ = 0.0;
    ++broadBuildsInCall_;
    cut();
  }
  updateMasses();
  ++rebuildsInCall_;
  broadSeconds_ += MPI_Wtime() - t0;
}

void DistributedFire::checkCentres() {
  // FireMinimiser::broadPhaseBuild()'s faults, the first in slot order then axis order (where the serial loop
  // throws), found over the ranks: (key, axis, kind, id, coordinate, radius, force along the axis) of each
  // rank's first, the smallest key wins.
  constexpr int W = 7;
  double first[W] = {std::numeric_limits<double>::infinity(), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  for (const Index i : dem_.ownedSlots_) {
    for (int k = 0; k < 3 && !std::isfinite(first[0]); ++k) {
      const double xk = dem_.x_(k, i);
      const double L = dem_.box_.length(k);
      const bool nonFinite = !std::isfinite(xk);
      if (nonFinite || (!dem_.box_.periodic(k) && (xk < 0.0 || xk > L))) {
        first[0] = static_cast<double>(dem_.key_[static_cast<std::size_t>(i)]);
        first[1] = k;
        first[2] = nonFinite ? 1.0 : 0.0;
        first[3] = static_cast<double>(dem_.id_[static_cast<std::size_t>(i)]);
        first[4] = xk;
        first[5] = dem_.r_[i];
        first[6] = dem_.f_(k, i);
      }
    }
    if (std::isfinite(first[0])) break;  // owned slots ascend by key: the first fault of this rank
  }
  gathered_.resize(W * static_cast<std::size_t>(dem_.size_));
  {
    CommTimer timer(dem_.stats_.commSeconds);
    mpiCheck(MPI_Allgather(first, W, MPI_DOUBLE, gathered_.data(), W, MPI_DOUBLE, MPI_COMM_WORLD), "MPI_Allgather");
  }
  const double* worst = gathered_.data();
  for (std::size_t q = W; q < gathered_.size(); q += W) {
    if (gathered_[q] < worst[0]) worst = gathered_.data() + q;
  }
  if (!std::isfinite(worst[0])) return;
  const auto id = static_cast<Index>(worst[3]);
  if (worst[2] != 0.0)
    throw CollectiveError(fmt::format("minimiser: particle id {} reached a non-finite position", id));
  const int axis = static_cast<int>(worst[1]);
  throw CollectiveError(
      integrators::fire::leftWallMessage(id, worst[5], axis, worst[4], dem_.box_.length(axis), worst[6]));
}

// ---- fire::descend()'s system ------------------------------------------------------------------------------

void DistributedFire::prepare(const integrators::MinimiserReport& start) {
  if (dem_.model_.parameters().normal == contact::NormalModel::Hertz) {
    const double ratio = start.maxOverlapRatio > 0.0 ? start.maxOverlapRatio : 1e-4;
    if (ratio != hertzReferenceOverlap_) {
      hertzReferenceOverlap_ = ratio;
      updateMasses();
    }
  }
  dem_.v_.setZero();
}

integrators::fire::FireSums DistributedFire::sums() {
  using integrators::fire::FireSums;
  const double* f = dem_.f_.data();
  const double* v = dem_.v_.data();
  const double* im = dem_.invm_.data();
  extra_.assign(1, stopOnInterrupt_ && interruptRequested() ? 1.0 : 0.0);  // no allocation after the first step
  const std::vector<double>& r = chunks_.reduce(
      FireSums::kWidth, 7,
      [&](Index, Index begin, Index end, double* out) {
        integrators::fire::reduceChunk(begin, end, f, v, im).store(out);
      },
      [&](Index i, double* out) {
        for (int k = 0; k < 3; ++k) out[k] = f[3 * i + k];
        for (int k = 0; k < 3; ++k) out[3 + k] = v[3 * i + k];
        out[6] = im[i];
      },
      [&](Index, Index count, const double* packed, double* out) {
        unpack(count, packed, 7);
        const double* pf = packScratch_.data();
        integrators::fire::reduceChunk(0, count, pf, pf + 3 * count, pf + 6 * count).store(out);
      },
      extra_, &dem_.stats_.commSeconds);
  FireSums total;
  for (Index c = 0; c < chunks_.chunks(); ++c) total.add(FireSums::load(r.data() + c * FireSums::kWidth));
  interrupted_ = r.back() > 0.0;
  return total;
}

void DistributedFire::restart(double dt) {
  for (const Index i : dem_.ownedSlots_) {
    for (int k = 0; k < 3; ++k) {
      dem_.x_(k, i) -= 0.5 * dt * dem_.v_(k, i);
      dem_.v_(k, i) = 0.0;
    }
  }
}

void DistributedFire::advance(double dt, double keep, double toward) {
  const double t0 = MPI_Wtime();
  double* x = dem_.x_.data();
  double* v = dem_.v_.data();
  const double* f = dem_.f_.data();
  const double* im = dem_.invm_.data();
  const double* ref = innerReference_.data();
  integrators::fire::LargestTwo largest;
  for (const Index i : dem_.ownedSlots_) {
    largest.add(integrators::fire::kickMixDrift(i, dt, keep, toward, f, v, x, im, ref));
  }
  dem_.stats_.loopSeconds += MPI_Wtime() - t0;
  afterMove(largest);
}

void DistributedFire::afterMove(const integrators::fire::LargestTwo& largest) {
  gathered_.resize(2 * static_cast<std::size_t>(dem_.size_));
  const double mine[2] = {largest.first, largest.second};
  {
    CommTimer timer(dem_.stats_.commSeconds);
    mpiCheck(MPI_Allgather(mine, 2, MPI_DOUBLE, gathered_.data(), 2, MPI_DOUBLE, MPI_COMM_WORLD), "MPI_Allgather");
  }
  integrators::fire::LargestTwo global;
  for (const double d : gathered_) global.add(d);
  pairDrift_ = global.drift();
  // FireMinimiser::listStale().
  if (pairDrift_ + 2.0 * growthSinceBuild_ > skin_) {
    rebuild();
  } else {
    dem_.exchangeGhosts();
  }
  computeForces();
}

void DistributedFire::finish(integrators::FireResult& res) {
  res.rebuilds = rebuildsInCall_;
  res.broadPhaseBuilds = broadBuildsInCall_;
  dem_.v_.setZero();
  res.seconds.broadPhase = broadSeconds_ - broadAtStart_;
  res.seconds.force = forceSeconds_ - forceAtStart_;
  res.seconds.update =
      std::max(0.0, MPI_Wtime() - callStart_ - res.seconds.broadPhase - res.seconds.force - res.seconds.measure);
}

double DistributedFire::overlapFloor() const {
  return 64.0 * std::numeric_limits<double>::epsilon() * dem_.box_.lengths().maxCoeff();
}

// ---- conjugate gradients (fire::descendByCg): d in v_, M^-1 F of the last iteration in vp_ (both migrate) ---

void DistributedFire::resetPrevious() { dem_.vp_.setZero(); }

void DistributedFire::restartDirection() {
  for (const Index i : dem_.ownedSlots_) dem_.v_.col(i) = dem_.vp_.col(i);
}

std::array<double, 2> DistributedFire::precondition() {
  const double* f = dem_.f_.data();
  const double* im = dem_.invm_.data();
  double* previous = dem_.vp_.data();
  extra_.clear();
  const std::vector<double>& r = chunks_.reduce(
      2, 7,
      [&](Index, Index begin, Index end, double* out) {
        const std::array<double, 2> p = integrators::fire::preconditionChunk(begin, end, f, im, previous);
        out[0] = p[0];
        out[1] = p[1];
      },
      [&](Index i, double* out) {  // the values before the pass, then the pass on this particle (once per particle)
        for (int k = 0; k < 3; ++k) out[k] = f[3 * i + k];
        for (int k = 0; k < 3; ++k) out[3 + k] = previous[3 * i + k];
        out[6] = im[i];
        integrators::fire::preconditionChunk(i, i + 1, f, im, previous);
      },
      [&](Index, Index count, const double* packed, double* out) {
        unpack(count, packed, 7);
        const std::array<double, 2> p = integrators::fire::preconditionChunk(
            0, count, packScratch_.data(), packScratch_.data() + 6 * count, packScratch_.data() + 3 * count);
        out[0] = p[0];
        out[1] = p[1];
      },
      extra_, &dem_.stats_.commSeconds);
  double s = 0.0, change = 0.0;
  for (Index c = 0; c < chunks_.chunks(); ++c) {
    s += r[static_cast<std::size_t>(2 * c)];
    change += r[static_cast<std::size_t>(2 * c + 1)];
  }
  return {s, change};
}

std::array<double, 3> DistributedFire::direct(double beta, bool update) {
  const double* f = dem_.f_.data();
  double* d = dem_.v_.data();
  const double* previous = dem_.vp_.data();
  extra_.assign(1, stopOnInterrupt_ && interruptRequested() ? 1.0 : 0.0);
  const std::vector<double>& r = chunks_.reduce(
      3, 6,
      [&](Index, Index begin, Index end, double* out) {
        const std::array<double, 3> p = integrators::fire::directChunk(begin, end, f, d, previous, beta, update);
        std::copy(p.begin(), p.end(), out);
      },
      [&](Index i, double* out) {  // the update on this particle first (once per particle), then its values
        integrators::fire::directChunk(i, i + 1, f, d, previous, beta, update);
        for (int k = 0; k < 3; ++k) out[k] = f[3 * i + k];
        for (int k = 0; k < 3; ++k) out[3 + k] = d[3 * i + k];
      },
      [&](Index, Index count, const double* packed, double* out) {
        unpack(count, packed, 6);
        const std::array<double, 3> p = integrators::fire::directChunk(
            0, count, packScratch_.data(), packScratch_.data() + 3 * count, nullptr, 0.0, false);
        std::copy(p.begin(), p.end(), out);
      },
      extra_, &dem_.stats_.commSeconds);
  double g = 0.0, dmax = 0.0, fmax = 0.0;
  for (Index c = 0; c < chunks_.chunks(); ++c) {
    g += r[static_cast<std::size_t>(3 * c)];
    dmax = std::max(dmax, r[static_cast<std::size_t>(3 * c + 1)]);
    fmax = std::max(fmax, r[static_cast<std::size_t>(3 * c + 2)]);
  }
  interrupted_ = r.back() > 0.0;
  return {g, dmax, fmax};
}

double DistributedFire::along() {
  const double* f = dem_.f_.data();
  const double* d = dem_.v_.data();
  extra_.clear();
  const std::vector<double>& r = chunks_.reduce(
      1, 6, [&](Index, Index begin, Index end, double* out) { *out = integrators::fire::alongChunk(begin, end, f, d); },
      [&](Index i, double* out) {
        for (int k = 0; k < 3; ++k) out[k] = f[3 * i + k];
        for (int k = 0; k < 3; ++k) out[3 + k] = d[3 * i + k];
      },
      [&](Index, Index count, const double* packed, double* out) {
        unpack(count, packed, 6);
        *out = integrators::fire::alongChunk(0, count, packScratch_.data(), packScratch_.data() + 3 * count);
      },
      extra_, &dem_.stats_.commSeconds);
  double g = 0.0;
  for (Index c = 0; c < chunks_.chunks(); ++c) g += r[static_cast<std::size_t>(c)];
  return g;
}

void DistributedFire::unpack(Index count, const double* packed, int width) {
  // Records of `width` values (3-vectors first, then scalars) into arrays: the 3-vectors as 3 x count blocks
  // one after the other, then the scalars as count-long blocks.
  packScratch_.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(count));
  const int vectors = width / 3;
  for (Index i = 0; i < count; ++i) {
    const double* rec = packed + width * i;
    for (int v = 0; v < vectors; ++v) {
      for (int k = 0; k < 3; ++k) packScratch_[static_cast<std::size_t>(3 * count * v + 3 * i + k)] = rec[3 * v + k];
    }
    for (int s = 3 * vectors; s < width; ++s) {
      packScratch_[static_cast<std::size_t>(3 * count * vectors + count * (s - 3 * vectors) + i)] = rec[s];
    }
  }
}

void DistributedFire::moveAlong(double a) {
  // FireMinimiser::moveAlong(): x += a d with the displacement since the build, the list check, the forces.
  const double t0 = MPI_Wtime();
  double* x = dem_.x_.data();
  const double* d = dem_.v_.data();
  const double* ref = innerReference_.data();
  integrators::fire::LargestTwo largest;
  for (const Index i : dem_.ownedSlots_) largest.add(integrators::fire::moveParticle(i, a, d, x, ref));
  dem_.stats_.loopSeconds += MPI_Wtime() - t0;
  afterMove(largest);
}

// ---- the public operations -----------------------------------------------------------------------------------

integrators::FireResult DistributedFire::minimise(const Progress& progress, bool stopOnInterrupt) {
  settings_.fire.validate();
  rebuildsInCall_ = 0;
  broadBuildsInCall_ = 0;
  callStart_ = MPI_Wtime();
  broadAtStart_ = broadSeconds_;
  forceAtStart_ = forceSeconds_;
  stopOnInterrupt_ = stopOnInterrupt;
  if (settings_.method == integrators::MinimiserMethod::ConjugateGradient) {
    return integrators::fire::descendByCg(*this, settings_.fire, progress, stopOnInterrupt);
  }
  return integrators::fire::descend(*this, settings_.fire, progress, stopOnInterrupt);
}

void DistributedFire::scaleRadii(double factor) {
  if (!(factor > 0.0 && std::isfinite(factor))) {
    throw ConfigError(fmt::format("scaleRadii: factor must be > 0, got {}", factor));
  }
  if (factor > 1.0) {
    double rmax = 0.0;
    for (const Index i : dem_.ownedSlots_) rmax = std::max(rmax, dem_.r_[i]);
    {
      CommTimer timer(dem_.stats_.commSeconds);
      mpiCheck(MPI_Allreduce(MPI_IN_PLACE, &rmax, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD), "MPI_Allreduce");
    }
    growthSinceBuild_ += (factor - 1.0) * rmax;
    growthSinceOuter_ += (factor - 1.0) * rmax;
  }
  if (dynamic_cast<broadphase::AutoSelect*>(dem_.backend_.get()) != nullptr) {
    // `auto` chose for the system's radii (DistributedDem's constructor): the next build through the broad
    // phase chooses for the scaled ones, on every rank alike (as DistributedDem::growRadii()).
    if (dem_.sampleRadii_.size() == 0) dem_.sampleRadii_ = radii();
    dem_.sampleRadii_ *= factor;
    dem_.resample_ = true;
  }
  dem_.r_ *= factor;  // ghosts too: the same product as their owners'
  dem_.v_.setZero();
  if (pairDrift_ + 2.0 * growthSinceBuild_ > skin_) {
    rebuild();
  } else {
    updateMasses();
  }
  computeForces();
}

integrators::MinimiserReport DistributedFire::measure() {
  using integrators::fire::MeasureSums;
  const Index n = dem_.n_;
  part_.assign(3 * static_cast<std::size_t>(n), 0.0);
  const integrators::fire::ContactTally tally = integrators::fire::tallyContacts(
      dem_.model_, context(), [&](Index i) { return dem_.owned_[static_cast<std::size_t>(i)] != 0; }, part_.data());
  const double* part = part_.data();
  const double* r = dem_.r_.data();
  auto store = [](const MeasureSums& s, double* out) {
    out[0] = s.energy;
    out[1] = s.force;
    out[2] = s.virial;
    out[3] = s.volume;
  };
  const std::vector<double> extra = {static_cast<double>(tally.contacts), static_cast<double>(tally.wallContacts)};
  const std::vector<double>& sums = chunks_.reduce(
      MeasureSums::kWidth, 4,
      [&](Index, Index begin, Index end, double* out) {
        store(integrators::fire::measureChunk(begin, end, part, r), out);
      },
      [&](Index i, double* out) {
        for (int k = 0; k < 3; ++k) out[k] = part[3 * i + k];
        out[3] = r[i];
      },
      [&](Index, Index count, const double* packed, double* out) {
        packScratch_.resize(4 * static_cast<std::size_t>(count));
        double* pp = packScratch_.data();
        double* pr = pp + 3 * count;
        for (Index i = 0; i < count; ++i) {
          for (int k = 0; k < 3; ++k) pp[3 * i + k] = packed[4 * i + k];
          pr[i] = packed[4 * i + 3];
        }
        store(integrators::fire::measureChunk(0, count, pp, pr), out);
      },
      extra, &dem_.stats_.commSeconds);
  MeasureSums total;
  for (Index c = 0; c < chunks_.chunks(); ++c) {
    const double* s = sums.data() + c * MeasureSums::kWidth;
    total.energy += s[0];
    total.force += s[1];
    total.virial += s[2];
    total.volume += s[3];
  }
  integrators::fire::ContactTally all = tally;
  all.contacts = static_cast<std::size_t>(sums[sums.size() - 2]);
  all.wallContacts = static_cast<std::size_t>(sums[sums.size() - 1]);
  double maxima[4] = {tally.maxOverlapRatio, tally.maxOverlap, 0.0, 0.0};  // and max |F|^2, max step^2
  for (const Index i : dem_.ownedSlots_) {
    const double fi = integrators::fire::squaredNorm3(dem_.f_.data() + 3 * i);
    maxima[2] = std::max(maxima[2], fi);
    maxima[3] = std::max(maxima[3], fi * dem_.invm_[i] * dem_.invm_[i]);
  }
  {
    CommTimer timer(dem_.stats_.commSeconds);
    mpiCheck(MPI_Allreduce(MPI_IN_PLACE, maxima, 4, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD), "MPI_Allreduce");
  }
  all.maxOverlapRatio = maxima[0];
  all.maxOverlap = maxima[1];
  return integrators::fire::assembleReport(all, total, maxima[2], maxima[3], dem_.box_, pressureUnit_,
                                           settings_.fire.referenceForce);
}

double DistributedFire::packingFraction() {
  const double* r = dem_.r_.data();
  auto cubes = [](const double* radius, Index begin, Index end) {
    double s = 0.0;
    for (Index i = begin; i < end; ++i) s += radius[i] * radius[i] * radius[i];
    return s;
  };
  const std::vector<double>& sums = chunks_.reduce(
      1, 1, [&](Index, Index begin, Index end, double* out) { *out = cubes(r, begin, end); },
      [&](Index i, double* out) { *out = r[i]; },
      [&](Index, Index count, const double* packed, double* out) { *out = cubes(packed, 0, count); }, {},
      &dem_.stats_.commSeconds);
  double volume = 0.0;
  for (Index c = 0; c < chunks_.chunks(); ++c) volume += sums[static_cast<std::size_t>(c)];
  return 4.0 / 3.0 * kPi * volume / dem_.box_.volume();
}

Eigen::Matrix3Xd DistributedFire::positions() { return dem_.gatherOwned(dem_.x_); }

Eigen::VectorXd DistributedFire::radii() { return dem_.gatherOwned(dem_.r_.transpose()).row(0).transpose(); }

}  // namespace polydem::parallel
