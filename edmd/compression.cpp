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

CompressionResult compress(HardSphereSystem& system, const CompressionOptions& options,
                           const std::function<void(const Progress&)>& onBlock) {
  if (options.schedule.empty()) throw ConfigError("compression schedule is empty");
  for (const Stage& s : options.schedule) {
    if (!(s.rate > 0.0) || !std::isfinite(s.rate)) {
      throw ConfigError(fmt::format("compression rate must be positive and finite, got {}", s.rate));
    }
  }
  if (!(options.targetPressure > 3.0)) {
    throw ConfigError(fmt::format("target pressure must be > 3 (free-volume regime), got {}", options.targetPressure));
  }
  const double phi0 = system.packingFraction();
  const bool toDensity = options.targetPackingFraction > 0.0;
  if (toDensity && !(options.targetPackingFraction > phi0 && options.targetPackingFraction < 1.0)) {
    throw ConfigError(
        fmt::format("target packing fraction must lie in ({}, 1) (the current one and space filling), "
                    "got {}",
                    phi0, options.targetPackingFraction));
  }
  if (!(options.thermalSpeed > 0.0)) {
    throw ConfigError(fmt::format("thermal speed must be > 0, got {}", options.thermalSpeed));
  }
  const Index n = system.count();
  CompressionResult result;
  if (n == 0) {
    result.stopReason = "no particles";
    return result;
  }
  const auto start = std::chrono::steady_clock::now();
  const EventCounts initial = system.counts();
  system.setThermalSpeed(options.thermalSpeed);
  std::size_t stage = 0;
  Progress progress;
  for (;;) {
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
    const auto blockStart = std::chrono::steady_clock::now();
    const EventCounts block = system.run(static_cast<std::int64_t>(std::ceil(perParticle * n)), duration);
    const double blockSeconds = std::max(seconds(blockStart), 1e-9);
    const PressureWindow window = system.pressureWindow();
    system.setThermalSpeed(options.thermalSpeed);  // synchronises

    const EventCounts all = system.counts() - initial;
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
    ++progress.blocks;
    progress.meanNeighbours = system.meanNeighbours();
    progress.exitsPerCollision =
        block.collisions > 0 ? static_cast<double>(block.exits) / static_cast<double>(block.collisions) : 0.0;
    progress.rebuilds = block.rebuilds;
    if (onBlock) onBlock(progress);

    if (toDensity && progress.packingFraction >= options.targetPackingFraction * (1.0 - 1e-12)) {
      result.stopReason = "packing fraction";
      break;
    }
    if (progress.pressure >= options.targetPressure) {
      result.stopReason = toDensity ? "pressure (target packing fraction beyond jamming)" : "pressure";
      break;
    }
    if (progress.collisionsPerParticle >= options.maxCollisionsPerParticle) {
      result.stopReason = "collision budget";
      break;
    }
    if (block.events() == 0) {
      result.stopReason = "no events (every particle at rest)";
      break;
    }
    while (stage + 1 < options.schedule.size() && progress.pressure >= options.schedule[stage].untilPressure) ++stage;
  }
  system.setGrowthRate(0.0);
  result.last = progress;
  result.counts = system.counts() - initial;
  result.wallSeconds = seconds(start);
  return result;
}

EquilibriumRun runAtFixedDensity(HardSphereSystem& system, double collisionsPerParticle,
                                 double blockCollisionsPerParticle) {
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
    if (c.events() == 0) break;
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

}  // namespace polydem::edmd
