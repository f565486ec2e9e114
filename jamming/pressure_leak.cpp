#include "jamming/pressure_leak.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/errors.hpp"
#include "edmd/compression.hpp"

namespace polydem::jamming {

namespace {

// The block's mean and largest displacement of the watched spheres from `origin`, in own diameters.
void measureDisplacements(const Box& box, const Eigen::Matrix3Xd& now, const Eigen::Matrix3Xd& origin,
                          const Eigen::VectorXd& radius, const std::vector<char>& rattler, LeakBlock& block) {
  // Displacements relative to the backbone's mean displacement: the backbone as a whole may translate
  // (momentum goes back and forth between it and the rattlers), which is no unjamming motion.
  const Index n = static_cast<Index>(radius.size());
  Eigen::Matrix3Xd moved(3, n);
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Index watched = 0;
  for (Index i = 0; i < n; ++i) {
    moved.col(i) = box.minimumImage(now.col(i) - origin.col(i));
    if (!rattler.empty() && rattler[static_cast<std::size_t>(i)]) continue;
    translation += moved.col(i);
    ++watched;
  }
  if (watched > 0) translation /= static_cast<double>(watched);
  for (Index i = 0; i < n; ++i) {
    if (!rattler.empty() && rattler[static_cast<std::size_t>(i)]) continue;
    const double d = (moved.col(i) - translation).norm() / (2.0 * radius[i]);
    block.meanDisplacement += d;
    if (d > block.maxDisplacement) {
      block.maxDisplacement = d;
      block.maxSphere = i;
    }
  }
  if (watched > 0) block.meanDisplacement /= static_cast<double>(watched);
}

}  // namespace

LeakTestResult testPressureLeak(const Eigen::Matrix3Xd& position, const Eigen::VectorXd& radius, const Box& box,
                                const std::vector<char>& rattler, const LeakTestOptions& options) {
  if (!(options.collisionsPerParticle > 0.0) || options.blocks < 4 || !(options.pressureTolerance > 0.0) ||
      !(options.driftFactor > 1.0)) {
    throw ConfigError(fmt::format(
        "leak test: collisions per particle {} must be positive, blocks {} at least 4, pressure tolerance {} "
        "positive and drift factor {} above 1",
        options.collisionsPerParticle, options.blocks, options.pressureTolerance, options.driftFactor));
  }
  const Index n = static_cast<Index>(radius.size());
  if (!rattler.empty() && static_cast<Index>(rattler.size()) != n) {
    throw ConfigError(fmt::format("leak test: {} rattler flags for {} spheres", rattler.size(), n));
  }
  LeakTestResult out;
  if (n == 0) {
    out.verdict = "not tested: no spheres";
    return out;
  }
  if (n < 2) {
    out.verdict = "not tested: a single sphere collides with nothing, so there is no pressure to watch";
    return out;
  }
  // A gas keeps its pressure too: without a backbone the test has nothing jammed to watch, and its
  // "no leak, no drift" would be a vacuous "jammed".
  if (!rattler.empty() && std::count(rattler.begin(), rattler.end(), 0) == 0) {
    out.verdict = "not tested: every sphere is a rattler (empty backbone), and the test watches the backbone";
    return out;
  }
  const auto start = std::chrono::steady_clock::now();
  edmd::HardSphereSystem system(box, position, radius, edmd::maxwellBoltzmannVelocities(radius, options.seed),
                                options.system);
  system.setGrowthRate(0.0);
  system.setThermalSpeed(1.0);
  const edmd::EventCounts initial = system.counts();
  const Eigen::Matrix3Xd origin = system.positions();

  const double perBlock = options.collisionsPerParticle / options.blocks;
  const std::int64_t blockCollisions = std::max<std::int64_t>(1, static_cast<std::int64_t>(perBlock * n));
  double done = 0.0;
  for (int b = 0; b < options.blocks; ++b) {
    system.resetPressureWindow();
    const edmd::EventCounts c = system.run(blockCollisions);
    system.synchronise();
    done += static_cast<double>(c.collisions) / static_cast<double>(std::max<Index>(n, 1));
    LeakBlock block;
    block.collisionsPerParticle = done;
    block.pressure = system.pressureWindow().reducedPressure();
    measureDisplacements(box, system.positions(), origin, radius, rattler, block);
    out.blocks.push_back(block);
    if (options.progress) {
      options.progress(fmt::format(
          "block {:>3}: {:>9.0f} collisions per particle, p {:.6e} ({:+.2e} from block 1), backbone displacement "
          "mean {:.3e} max {:.3e} D_i (sphere {})",
          b + 1, done, block.pressure,
          out.blocks.front().pressure > 0.0 ? block.pressure / out.blocks.front().pressure - 1.0 : 0.0,
          block.meanDisplacement, block.maxDisplacement, block.maxSphere));
    }
    if (c.collisions == 0) break;  // nothing collides (a gas of one sphere): nothing to watch
  }
  out.counts = system.counts() - initial;
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  const std::size_t m = out.blocks.size();
  const std::size_t quarter = std::max<std::size_t>(1, m / 4);
  double first = 0.0, last = 0.0;
  for (std::size_t k = 0; k < quarter; ++k) {
    first += out.blocks[k].pressure;
    last += out.blocks[m - 1 - k].pressure;
  }
  // No collision in the first quarter: the pressure is zero there and the change is undefined.
  out.pressureChange = first > 0.0 ? last / first - 1.0 : 0.0;
  // Drift: the last quarter's displacements against the largest of the first half. Inside a polytope the
  // block means scatter around a plateau reached in the first block (by up to ~3x for a hundred spheres),
  // and the largest early value bounds the later ones; a drift linear in time gives (7/8) / (1/2) = 1.75.
  double early = 0.0, late = 0.0;
  for (std::size_t k = 0; k < std::max<std::size_t>(1, m / 2); ++k) {
    early = std::max(early, out.blocks[k].meanDisplacement);
  }
  for (std::size_t k = 0; k < quarter; ++k) late += out.blocks[m - 1 - k].meanDisplacement;
  late /= static_cast<double>(quarter);
  const double end = out.blocks.back().meanDisplacement;
  out.driftRatio = early > 0.0 ? late / early : (late > 0.0 ? edmd::HardSphereSystem::kInfinity : 1.0);
  const bool leak = !(out.pressureChange >= -options.pressureTolerance);
  const bool drift = !(out.driftRatio <= options.driftFactor);
  if (out.counts.collisions == 0 || !(first > 0.0)) {
    out.verdict = fmt::format("not tested: {} in {} blocks, so there is no pressure to watch",
                              out.counts.collisions == 0 ? "no collisions" : "no collisions in the first quarter", m);
    return out;
  }
  out.leaks = leak || drift;
  out.outcome = out.leaks ? JammingVerdict::Unjammed : JammingVerdict::Jammed;
  out.verdict = fmt::format(
      "{}: over {:.0f} collisions per particle the block pressure changed by {:+.2e} (last quarter against first; "
      "a leak below {:.0e}), the mean backbone displacement of the last quarter is {:.3g}x the largest of the first "
      "half (a drift above {:.3g}x); at the end mean {:.3e} D_i, largest {:.3e} D_i",
      leak && drift ? "pressure leak and drift (not jammed)"
      : leak        ? "pressure leak (not jammed)"
      : drift       ? "drift away from the start (not jammed)"
                    : "no pressure leak, no drift (jammed)",
      done, out.pressureChange, -options.pressureTolerance, out.driftRatio, options.driftFactor, end,
      out.blocks.back().maxDisplacement);
  return out;
}

LeakTestResult testPressureLeakWithout(const Eigen::Matrix3Xd& position, const Eigen::VectorXd& radius, const Box& box,
                                       const std::vector<char>& rattler, Index removed,
                                       const LeakTestOptions& options) {
  if (removed < 0) return testPressureLeak(position, radius, box, rattler, options);
  const Index n = static_cast<Index>(radius.size());
  if (removed >= n) {
    throw ConfigError(fmt::format("leak test: sphere {} to remove, but there are {} spheres", removed, n));
  }
  if (!rattler.empty() && static_cast<Index>(rattler.size()) != n) {
    throw ConfigError(fmt::format("leak test: {} rattler flags for {} spheres", rattler.size(), n));
  }
  Eigen::Matrix3Xd x = position;
  Eigen::VectorXd r = radius;
  std::vector<char> watched = rattler;
  const Index last = n - 1;
  x.col(removed) = x.col(last);
  r[removed] = r[last];
  x.conservativeResize(3, last);
  r.conservativeResize(last);
  if (!watched.empty()) {
    watched[static_cast<std::size_t>(removed)] = watched[static_cast<std::size_t>(last)];
    watched.pop_back();
  }
  return testPressureLeak(x, r, box, watched, options);
}

}  // namespace polydem::jamming
