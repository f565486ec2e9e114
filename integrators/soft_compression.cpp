#include "integrators/soft_compression.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "core/errors.hpp"
#include "core/interrupt.hpp"

namespace polydem::integrators {

void CompressionSettings::validate() const {
  if (!(targetPacking > 0.0 && targetPacking < 1.0)) {
    throw ConfigError(fmt::format("compression.packing_fraction must be in (0, 1), got {}", targetPacking));
  }
  if (!(growthRate > 0.0 && growthRate <= 0.1)) {
    throw ConfigError(fmt::format("compression.growth_rate must be in (0, 0.1] (relative radius growth per contact "
                                  "duration), got {}",
                                  growthRate));
  }
  if (!(damping > 0.0 && std::isfinite(damping))) {
    throw ConfigError(fmt::format("compression.damping must be > 0, got {}", damping));
  }
  if (!(relaxedOverlap > 0.0 && std::isfinite(relaxedOverlap))) {
    throw ConfigError(fmt::format("compression.max_overlap must be > 0, got {}", relaxedOverlap));
  }
  if (maxSteps < 1) throw ConfigError(fmt::format("compression.max_steps must be >= 1, got {}", maxSteps));
}

CompressionResult softCompress(ParticleStore& particles, const Box& box, DemSettings settings,
                               const CompressionSettings& compression,
                               const std::function<void(const DemSimulation&, bool growing)>& progress,
                               bool stopOnInterrupt) {
  compression.validate();
  particles.velocity().setZero();
  if (particles.features().rotation) particles.angularVelocity().setZero();
  settings.gravity.setZero();
  // gamma needs t_c,min, which the simulation computes: build once to learn it (cheap), then for real.
  settings.viscousDamping = 1.0;
  const double tc = DemSimulation(particles, box, settings).timeStepChoice().contactDuration;
  settings.viscousDamping = compression.damping / tc;
  DemSimulation sim(std::move(particles), box, settings);

  CompressionResult result;
  constexpr std::int64_t kChunk = 20;
  const double perChunk = 1.0 + compression.growthRate * kChunk * sim.dt() / tc;
  // Growth pauses while the overlaps are large (the damping has not caught up): a fixed stiffness gets
  // relatively softer as radii and masses grow, and jammed regions need time to rearrange.
  const double pauseAbove = std::max(5.0 * compression.relaxedOverlap, 0.05);
  std::int64_t steps = 0;
  while (sim.packingFraction() < compression.targetPacking * (1.0 - 1e-12)) {
    if (sim.contactStats().maxOverlapRatio < pauseAbove) {
      const double needed = std::cbrt(compression.targetPacking / sim.packingFraction());
      sim.growRadii(std::min(perChunk, needed));
    }
    steps += sim.advance(kChunk, stopOnInterrupt);
    if (progress && steps % 1000 == 0) progress(sim, true);
    if (steps > compression.maxSteps || (stopOnInterrupt && interruptRequested())) break;
  }
  result.growthSteps = steps;
  // Relax: damped motion until the overlaps are small (or the step budget is spent).
  constexpr std::int64_t kRelaxChunk = 100;
  double overlap = sim.contactStats().maxOverlapRatio;
  const bool packed = sim.packingFraction() >= compression.targetPacking * (1.0 - 1e-12);
  while (packed && overlap > compression.relaxedOverlap && steps < compression.maxSteps &&
         !(stopOnInterrupt && interruptRequested())) {
    const std::int64_t done = sim.advance(kRelaxChunk, stopOnInterrupt);
    steps += done;
    result.relaxSteps += done;
    overlap = sim.contactStats().maxOverlapRatio;
    if (progress && result.relaxSteps % 1000 == 0) progress(sim, false);
  }
  result.interrupted = stopOnInterrupt && interruptRequested();
  if (result.interrupted) {
    result.reachedTarget = false;
    result.reason = fmt::format("interrupted after {} steps at packing fraction {:.4f}", steps, sim.packingFraction());
  } else if (!packed) {
    result.reachedTarget = false;
    result.reason = fmt::format(
        "compression.max_steps = {} spent at packing fraction {:.4f} below the target {} (largest overlap {:.3g} of "
        "the smaller radius): the target is probably above jamming for this size distribution; lower "
        "compression.packing_fraction or raise compression.max_steps / compression.growth_rate",
        compression.maxSteps, sim.packingFraction(), compression.targetPacking, overlap);
  } else if (overlap > compression.relaxedOverlap) {
    result.reachedTarget = false;
    result.reason = fmt::format(
        "after {} steps the largest overlap is still {:.3g} of the smaller radius (target {}) at packing fraction "
        "{:.4f}: the target is probably above jamming for this size distribution; lower "
        "compression.packing_fraction or raise compression.max_overlap / compression.max_steps",
        steps, overlap, compression.relaxedOverlap, sim.packingFraction());
  }
  result.packingFraction = sim.packingFraction();
  result.maxOverlapRatio = overlap;
  result.rebuilds = sim.rebuilds();
  particles = sim.particles();
  particles.velocity().setZero();
  if (particles.features().rotation) particles.angularVelocity().setZero();
  return result;
}

}  // namespace polydem::integrators
