#include "integrators/soft_compression.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/errors.hpp"
#include "core/interrupt.hpp"

namespace polydem::integrators {

namespace {

constexpr std::int64_t kGrowthChunk = 20;
constexpr std::int64_t kRelaxChunk = 100;

/// t_c,min of the starting state (the rates are in its units). gamma needs t_c,min, which the
/// simulation computes: build once to learn it (cheap).
double startingContactDuration(ParticleStore& particles, const Box& box, DemSettings settings) {
  particles.velocity().setZero();
  if (particles.features().rotation) particles.angularVelocity().setZero();
  settings.gravity.setZero();
  settings.viscousDamping = 1.0;
  return DemSimulation(particles, box, settings).timeStepChoice().contactDuration;
}

}  // namespace

DemSettings SoftCompression::compressionSettings(DemSettings settings, double viscousDamping) const {
  settings.gravity.setZero();
  settings.viscousDamping = viscousDamping;
  return settings;
}

SoftCompression::SoftCompression(ParticleStore particles, const Box& box, DemSettings settings,
                                 const CompressionSettings& compression)
    : compression_((compression.validate(), compression)),
      progress_{.contactDuration = startingContactDuration(particles, box, settings)},
      sim_(std::move(particles), box, compressionSettings(settings, compression.damping / progress_.contactDuration)) {
  progress_.viscousDamping = sim_.settings().viscousDamping;
}

SoftCompression::SoftCompression(const DemState& state, DemSettings settings, const CompressionSettings& compression,
                                 const CompressionProgress& progress)
    : compression_((compression.validate(), compression)),
      progress_(progress),
      sim_(DemSimulation::restore(state, compressionSettings(settings, progress.viscousDamping))) {}

double SoftCompression::packingFraction() const {
  return engine_ && radii_.size() > 0 ? DemSimulation::packingFraction(radii_, sim_.box()) : sim_.packingFraction();
}

double SoftCompression::maxOverlapRatio() const {
  return engine_ ? engine_->maxOverlapRatio() : sim_.contactStats().maxOverlapRatio;
}

void SoftCompression::growRadii(double factor) {
  if (!engine_) {
    sim_.growRadii(factor);
    return;
  }
  engine_->growRadii(factor);
  if (radii_.size() == 0) radii_ = sim_.particles().radius();
  radii_ *= factor;  // DemSimulation::growRadii's expression: the engine's radii, byte for byte
}

void SoftCompression::sync() {
  if (!engine_) return;
  engine_->sync(sim_);
  radii_.resize(0);  // the simulation holds the grown radii now
}

bool SoftCompression::advance() {
  using Phase = CompressionProgress::Phase;
  CompressionProgress& p = progress_;
  auto run = [&](std::int64_t steps) {
    if (engine_) {
      engine_->advance(steps);
    } else {
      sim_.advance(steps);
    }
  };
  if (p.phase == Phase::Growing) {
    if (packingFraction() < compression_.targetPacking * (1.0 - 1e-12) && p.steps <= compression_.maxSteps) {
      // Growth pauses while the overlaps are large (the damping has not caught up): a fixed stiffness gets
      // relatively softer as radii and masses grow, and jammed regions need time to rearrange.
      const double pauseAbove = std::max(5.0 * compression_.relaxedOverlap, 0.05);
      if (maxOverlapRatio() < pauseAbove) {
        const double perChunk =
            1.0 + compression_.growthRate * static_cast<double>(kGrowthChunk) * sim_.dt() / p.contactDuration;
        const double needed = std::cbrt(compression_.targetPacking / packingFraction());
        growRadii(std::min(perChunk, needed));
      }
      run(kGrowthChunk);
      p.steps += kGrowthChunk;
      return true;
    }
    p.growthSteps = p.steps;
    p.phase = Phase::Relaxing;
    p.overlap = maxOverlapRatio();
    p.packed = packingFraction() >= compression_.targetPacking * (1.0 - 1e-12);
  }
  if (p.phase == Phase::Relaxing) {
    // Relax: damped motion until the overlaps are small (or the step budget is spent).
    if (p.packed && p.overlap > compression_.relaxedOverlap && p.steps < compression_.maxSteps) {
      run(kRelaxChunk);
      p.steps += kRelaxChunk;
      p.relaxSteps += kRelaxChunk;
      p.overlap = maxOverlapRatio();
      return true;
    }
    p.phase = Phase::Done;
  }
  return false;
}

CompressionResult SoftCompression::result() const {
  const CompressionProgress& p = progress_;
  CompressionResult result;
  result.growthSteps = growing() ? p.steps : p.growthSteps;
  result.relaxSteps = p.relaxSteps;
  result.packingFraction = packingFraction();
  result.maxOverlapRatio = growing() ? maxOverlapRatio() : p.overlap;
  result.rebuilds = sim_.rebuilds();
  if (!finished()) {
    result.reachedTarget = false;
    result.reason = fmt::format("stopped after {} steps at packing fraction {:.4f}", p.steps, result.packingFraction);
  } else if (!p.packed) {
    result.reachedTarget = false;
    result.reason = fmt::format(
        "compression.max_steps = {} spent at packing fraction {:.4f} below the target {} (largest overlap {:.3g} of "
        "the smaller radius): the target is probably above jamming for this size distribution; lower "
        "compression.packing_fraction or raise compression.max_steps / compression.growth_rate",
        compression_.maxSteps, result.packingFraction, compression_.targetPacking, p.overlap);
  } else if (p.overlap > compression_.relaxedOverlap) {
    result.reachedTarget = false;
    result.reason = fmt::format(
        "after {} steps the largest overlap is still {:.3g} of the smaller radius (target {}) at packing fraction "
        "{:.4f}: the target is probably above jamming for this size distribution; lower "
        "compression.packing_fraction or raise compression.max_overlap / compression.max_steps",
        p.steps, p.overlap, compression_.relaxedOverlap, result.packingFraction);
  }
  return result;
}

ParticleStore SoftCompression::particles() const {
  ParticleStore out = sim_.particles();
  out.velocity().setZero();
  if (out.features().rotation) out.angularVelocity().setZero();
  return out;
}

CompressionResult softCompress(ParticleStore& particles, const Box& box, DemSettings settings,
                               const CompressionSettings& compression,
                               const std::function<void(const DemSimulation&, bool growing)>& progress,
                               bool stopOnInterrupt) {
  SoftCompression c(std::move(particles), box, settings, compression);
  std::int64_t reported = 0;
  while (c.advance()) {
    if (progress && c.progress().steps / 1000 > reported) {
      reported = c.progress().steps / 1000;
      progress(c.simulation(), c.growing());
    }
    if (stopOnInterrupt && interruptRequested()) break;
  }
  CompressionResult result = c.result();
  if (!c.finished()) {
    result.interrupted = true;
    result.reason = "interrupted: " + result.reason;
  }
  particles = c.particles();
  return result;
}

}  // namespace polydem::integrators
