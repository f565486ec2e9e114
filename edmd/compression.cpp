#include "edmd/compression.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <sstream>

#include "core/errors.hpp"

namespace polydem::edmd {

namespace {

double seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

double parseNumber(const std::string& word, const std::string& text) {
  try {
    std::size_t used = 0;
    const double value = std::stod(word, &used);
    if (used != word.size()) throw std::invalid_argument(word);
    return value;
  } catch (const std::exception&) {
    throw ConfigError(fmt::format("schedule '{}': '{}' is not a number (expected rate:pressure,...)", text, word));
  }
}

}  // namespace

std::vector<Stage> parseSchedule(const std::string& text) {
  std::vector<Stage> stages;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    Stage stage;
    const std::size_t colon = item.find(':');
    stage.rate = parseNumber(item.substr(0, colon), text);
    if (colon != std::string::npos) stage.untilPressure = parseNumber(item.substr(colon + 1), text);
    stages.push_back(stage);
  }
  if (stages.empty()) throw ConfigError(fmt::format("schedule '{}' has no stages (expected e.g. 1e-3:1e4,1e-4)", text));
  for (std::size_t k = 0; k < stages.size(); ++k) {
    if (!(stages[k].rate > 0.0) || !std::isfinite(stages[k].rate)) {
      throw ConfigError(
          fmt::format("schedule '{}': stage {} rate must be positive and finite, got {}", text, k + 1, stages[k].rate));
    }
    if (k > 0 && !(stages[k].untilPressure > stages[k - 1].untilPressure)) {
      throw ConfigError(fmt::format("schedule '{}': the pressures ending the stages must increase", text));
    }
  }
  return stages;
}

std::string formatSchedule(const std::vector<Stage>& schedule) {
  std::string out;
  for (const Stage& s : schedule) {
    if (!out.empty()) out += ',';
    out += fmt::format("{:g}", s.rate);
    if (std::isfinite(s.untilPressure)) out += fmt::format(":{:g}", s.untilPressure);
  }
  return out;
}

double maxResolvablePressure(const HardSphereSystem& system) {
  if (system.count() == 0) return std::numeric_limits<double>::infinity();
  double length = 0.0;
  for (int k = 0; k < 3; ++k) length = std::max(length, system.box().length(k));
  const double phi = system.packingFraction();
  const double rmin = system.smallestRadius() * std::cbrt(1.0 / std::max(phi, 1e-300));
  const double ulp = std::nextafter(length, std::numeric_limits<double>::infinity()) - length;
  return 2.0 * rmin / (kGapUlps * ulp);
}

void validateCompression(const HardSphereSystem& system, const CompressionOptions& options) {
  if (options.schedule.empty()) throw ConfigError("compression schedule is empty");
  for (std::size_t k = 0; k < options.schedule.size(); ++k) {
    const Stage& s = options.schedule[k];
    if (!(s.rate >= kMinRate && s.rate <= kMaxRate)) {
      throw ConfigError(fmt::format(
          "schedule stage {}: growth rate {} is outside [{:g}, {:g}] (a rate is the growth speed of the largest "
          "radius over the thermal speed: above {:g} the spheres grow faster than they move, below {:g} jamming "
          "would take more than ~1e9 collisions per particle)",
          k + 1, s.rate, kMinRate, kMaxRate, kMaxRate, kMinRate));
    }
    if (!(s.untilPressure > 1.0)) {
      throw ConfigError(fmt::format("schedule stage {}: the pressure ending it must be > 1 (the ideal gas), got {}",
                                    k + 1, s.untilPressure));
    }
    if (k > 0 && !(s.untilPressure > options.schedule[k - 1].untilPressure)) {
      throw ConfigError("schedule: the pressures ending the stages must increase");
    }
  }
  if (!(options.targetPressure > 3.0) || !std::isfinite(options.targetPressure)) {
    throw ConfigError(
        fmt::format("target pressure must be finite and > 3 (free-volume regime), got {}", options.targetPressure));
  }
  const double limit = maxResolvablePressure(system);
  const bool densityTarget = options.targetPackingFraction != 0.0;
  // With a density target the pressure is only the jamming guard, capped at the limit in compress().
  if (options.checkPrecision && !densityTarget && options.targetPressure > limit) {
    throw ConfigError(fmt::format(
        "target pressure {:g} is beyond what double precision resolves for this system: near jamming the "
        "gaps of the smallest spheres are 2 r_min / p, and at p > {:.2g} they are fewer than {:g} units in the "
        "last place of the box coordinates (the measured pressure stops rising there, at round-off); use a "
        "target of at most {:.2g}",
        options.targetPressure, limit, kGapUlps, limit));
  }
  const double phi0 = system.packingFraction();
  const bool toDensity = options.targetPackingFraction != 0.0;
  if (toDensity && !(options.targetPackingFraction > phi0 && options.targetPackingFraction < 1.0)) {
    throw ConfigError(
        fmt::format("target packing fraction must lie in ({}, 1) (the current one and space filling), "
                    "got {}",
                    phi0, options.targetPackingFraction));
  }
  if (!(options.maxCollisionsPerParticle > 0.0) || !std::isfinite(options.maxCollisionsPerParticle)) {
    throw ConfigError(
        fmt::format("collision budget must be positive and finite, got {}", options.maxCollisionsPerParticle));
  }
  if (!(options.blockCollisionsPerParticle == 0.0 ||
        (options.blockCollisionsPerParticle >= 1.0 && options.blockCollisionsPerParticle <= 1e6))) {
    throw ConfigError(fmt::format(
        "block must be 0 (automatic) or 1 to 1e6 collisions per particle, got {} (smaller blocks spend the run "
        "synchronising, O(N) each)",
        options.blockCollisionsPerParticle));
  }
  if (!(options.thermalSpeed > 0.0) || !std::isfinite(options.thermalSpeed)) {
    throw ConfigError(fmt::format("thermal speed must be > 0, got {}", options.thermalSpeed));
  }
  if (system.count() < 2) {
    throw ConfigError(fmt::format(
        "a compression needs at least 2 spheres, got {}: a lone sphere has no binary collisions, so neither a "
        "pressure nor a collision budget can end its run",
        system.count()));
  }
}

CompressionResult compress(HardSphereSystem& system, const CompressionOptions& options,
                           const std::function<void(const Progress&)>& onBlock, const BoundaryHook& atBoundary,
                           CompressionState* state) {
  CompressionState local;
  CompressionState& cs = state ? *state : local;
  if (!cs.begun) validateCompression(system, options);
  if (cs.stage < 0 || cs.stage >= static_cast<std::int64_t>(options.schedule.size())) {
    throw ConfigError(fmt::format("compression state: stage {} outside the schedule of {} stages", cs.stage + 1,
                                  options.schedule.size()));
  }
  const bool toDensity = options.targetPackingFraction > 0.0;
  const Index n = system.count();
  CompressionResult result;
  const auto start = std::chrono::steady_clock::now();
  if (!cs.begun) {
    cs.initial = system.counts();
    cs.pressureLimit = maxResolvablePressure(system);
    system.setThermalSpeed(options.thermalSpeed);
    cs.begun = true;
  }
  const std::int64_t budget = options.maxCollisionsPerParticle * n < 9e18
                                  ? static_cast<std::int64_t>(std::ceil(options.maxCollisionsPerParticle * n))
                                  : std::numeric_limits<std::int64_t>::max();
  Progress progress;
  progress.blocks = cs.blocks;
  for (;;) {
    const std::size_t stage = static_cast<std::size_t>(cs.stage);
    const double rate = options.schedule[stage].rate;
    const double g = rate * options.thermalSpeed / system.largestRadius();
    system.setGrowthRate(g);
    system.resetPressureWindow();
    const double perParticle = options.blockCollisionsPerParticle > 0.0 ? options.blockCollisionsPerParticle
                                                                        : std::clamp(0.01 / rate, 10.0, 1000.0);
    double duration = HardSphereSystem::kInfinity;
    if (toDensity) {
      duration = (std::cbrt(options.targetPackingFraction / system.packingFraction()) - 1.0) / g;
    }
    // The last block stops at the budget (a block of 1000 collisions per particle would overshoot it).
    const std::int64_t done = (system.counts() - cs.initial).collisions;
    const std::int64_t blockCollisions =
        std::min(static_cast<std::int64_t>(std::ceil(perParticle * n)), std::max<std::int64_t>(budget - done, 1));
    const auto blockStart = std::chrono::steady_clock::now();
    const EventCounts block = system.run(blockCollisions, duration);
    const double blockSeconds = std::max(seconds(blockStart), 1e-9);
    const PressureWindow window = system.pressureWindow();
    system.setThermalSpeed(options.thermalSpeed);  // synchronises

    const EventCounts all = system.counts() - cs.initial;
    progress.packingFraction = system.packingFraction();
    progress.pressure = window.reducedPressure();
    progress.jammingEstimate = jammingDensityEstimate(progress.packingFraction, progress.pressure);
    progress.rate = rate;
    progress.stage = static_cast<int>(stage);
    progress.collisionsPerParticle = static_cast<double>(all.collisions) / n;
    progress.eventsPerSecond = static_cast<double>(block.events()) / blockSeconds;
    progress.collisionsPerSecond = static_cast<double>(block.collisions) / blockSeconds;
    progress.wallSeconds = seconds(start);
    progress.time = system.time();
    progress.blocks = ++cs.blocks;
    progress.meanNeighbours = system.meanNeighbours();
    progress.exitsPerCollision =
        block.collisions > 0 ? static_cast<double>(block.exits) / static_cast<double>(block.collisions) : 0.0;
    progress.rebuilds = block.rebuilds;
    if (onBlock) onBlock(progress);

    if (toDensity && progress.packingFraction >= options.targetPackingFraction * (1.0 - 1e-12)) {
      result.stopReason = "packing fraction";
      result.targetReached = true;
      break;
    }
    if (progress.pressure >=
        (toDensity ? std::min(options.targetPressure, cs.pressureLimit) : options.targetPressure)) {
      // With a density target the pressure bound is the jamming guard: the pressure diverges at phi_J.
      result.stopReason = toDensity ? "jammed before the target packing fraction" : "pressure";
      result.targetReached = !toDensity;
      break;
    }
    if (all.collisions >= budget) {
      result.stopReason = "collision budget";
      break;
    }
    if (block.events() == 0) {
      result.stopReason = "no events (every particle at rest)";
      break;
    }
    if (std::isfinite(progress.pressure)) cs.windowMax = std::max(cs.windowMax, progress.pressure);
    if (++cs.windowBlocks >= kPlateauBlocks &&
        static_cast<double>(all.collisions - cs.windowStart) >= kPlateauGrowth / rate * static_cast<double>(n)) {
      const bool stuck = cs.previousWindowMax > 0.0 && cs.windowMax >= kPlateauBand * cs.pressureLimit &&
                         cs.windowMax < kPlateauRise * cs.previousWindowMax;
      cs.previousWindowMax = cs.windowMax;
      cs.windowMax = 0.0;
      cs.windowBlocks = 0;
      cs.windowStart = all.collisions;
      if (stuck) {
        result.stopReason = "pressure plateau at round-off";
        break;
      }
    }
    while (static_cast<std::size_t>(cs.stage) + 1 < options.schedule.size() &&
           progress.pressure >= options.schedule[static_cast<std::size_t>(cs.stage)].untilPressure) {
      ++cs.stage;
    }
    if (atBoundary && atBoundary(system, cs)) {
      result.stopReason = "interrupted";
      break;
    }
  }
  system.setGrowthRate(0.0);
  result.last = progress;
  result.counts = system.counts() - cs.initial;
  result.wallSeconds = seconds(start);
  return result;
}

EquilibriumRun runAtFixedDensity(HardSphereSystem& system, double collisionsPerParticle,
                                 double blockCollisionsPerParticle, const std::function<bool()>& stop) {
  if (!(collisionsPerParticle >= 0.0) || !(blockCollisionsPerParticle > 0.0)) {
    throw ConfigError(fmt::format("fixed-density run: collisions per particle {} and block {} must be positive",
                                  collisionsPerParticle, blockCollisionsPerParticle));
  }
  EquilibriumRun out;
  const Index n = system.count();
  if (n == 0) return out;
  system.setGrowthRate(0.0);
  system.resetPressureWindow();
  const EventCounts initial = system.counts();
  const std::int64_t total = static_cast<std::int64_t>(std::ceil(collisionsPerParticle * n));
  const std::int64_t block = std::max<std::int64_t>(1, static_cast<std::int64_t>(blockCollisionsPerParticle * n));
  const auto start = std::chrono::steady_clock::now();
  std::int64_t done = 0;
  while (done < total) {
    const EventCounts c = system.run(std::min(block, total - done));
    done += c.collisions;
    system.synchronise();  // keeps the clock small; energy is conserved without growth
    if (c.events() == 0 || (stop && stop())) break;
  }
  out.wallSeconds = std::max(seconds(start), 1e-9);
  out.counts = system.counts() - initial;
  out.pressure = system.pressureWindow().reducedPressure();
  out.collisionsPerSecond = static_cast<double>(out.counts.collisions) / out.wallSeconds;
  out.eventsPerSecond = static_cast<double>(out.counts.events()) / out.wallSeconds;
  return out;
}

Eigen::Matrix3Xd maxwellBoltzmannVelocities(const Eigen::VectorXd& radius, std::uint64_t seed) {
  const Index n = static_cast<Index>(radius.size());
  std::mt19937_64 rng(seed ^ 0x5851f42d4c957f2dULL);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::Matrix3Xd v(3, n);
  const Eigen::VectorXd mass = radius.array().cube();
  Eigen::Vector3d momentum = Eigen::Vector3d::Zero();
  for (Index i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) v(k, i) = normal(rng) / std::sqrt(mass[i]);
    momentum += mass[i] * v.col(i);
  }
  if (n > 1) v.colwise() -= momentum / mass.sum();
  return v;
}

double reopenRadiusFactor(double pressure) {
  if (!(pressure > 3.0) || !std::isfinite(pressure)) {
    throw ConfigError(
        fmt::format("reopening to reduced pressure {}: must be finite and > 3 (the free-volume law "
                    "p ~ 3 / (1 - phi / phi_J) has no solution below)",
                    pressure));
  }
  return std::cbrt(1.0 - 3.0 / pressure);
}

}  // namespace polydem::edmd
