// polydem relax: the starting state. The particles are read from the scene's particle file or
// generated (random sequential addition), optionally softly compressed, then given their initial
// velocities (from the file, the impact rule, or zero).
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <random>

#include "apps/polydem/common.hpp"
#include "apps/polydem/relax.hpp"
#include "core/errors.hpp"
#include "core/initial_configuration.hpp"
#include "core/interrupt.hpp"
#include "integrators/initial_velocities.hpp"

namespace polydem::app {

namespace {

/// The particle file of `scene`, its boundaries checked against box.boundaries.
io::ParticleData readInput(const RelaxScene& scene) {
  const auto path = scene.resolve(scene.particleFile);
  io::ParticleData data = io::readParticles(path, scene.boundaries);
  // box.boundaries with a file that states its own boundaries (HDF5 always, text with a header): a
  // conflict is refused, never settled silently in favour of either (issue 15).
  std::array<Boundary, 3> fileBoundaries{};
  for (int k = 0; k < 3; ++k) fileBoundaries[static_cast<std::size_t>(k)] = data.box.boundary(k);
  if (scene.boundariesGiven && fileBoundaries != scene.boundaries) {
    auto words = [](const std::array<Boundary, 3>& b) {
      std::string t;
      for (Boundary x : b) t += std::string(t.empty() ? "" : ",") + (x == Boundary::Periodic ? "periodic" : "wall");
      return t;
    };
    throw ConfigError(
        fmt::format("box.boundaries = \"{}\" conflicts with {}, which stores boundaries {}: remove "
                    "box.boundaries from the scene to use the file's, or write the file with the "
                    "boundaries you want",
                    words(scene.boundaries), path.string(), words(fileBoundaries)));
  }
  return data;
}

}  // namespace

Start prepare(const RelaxScene& scene) {
  Start s;
  const bool rotation = scene.dem.needsRotation();
  std::optional<Eigen::Matrix3Xd> fileVelocity, fileAngularVelocity;
  if (!scene.particleFile.empty()) {
    const auto path = scene.resolve(scene.particleFile);
    io::ParticleData data = readInput(scene);
    if (data.count() == 0) throw InputError(fmt::format("{}: no particles to simulate", path.string()));
    s.box = data.box;
    s.particles = ParticleStore(data.count(), Features{.rotation = rotation});
    s.particles.position() = data.position;
    s.particles.radius() = data.radius;
    s.particles.id() = data.id;
    fileVelocity = data.velocity;
    fileAngularVelocity = data.angularVelocity;
    s.fileTime = data.time;
    s.origin = fmt::format("read from {}", path.string());
    s.attributes = data.attributes;
    s.attributes.erase("target_not_reached");  // a mark of the run that wrote the file, not of this one
  } else {
    const auto dist = makeDistribution(scene.distribution);
    const double target =
        scene.compression ? scene.compression->startPacking(scene.packingFraction) : scene.packingFraction;
    StartPackingRequest request;
    request.count = scene.count;
    request.sampling = scene.sampling == "random" ? Sampling::Random : Sampling::Systematic;
    request.packingFraction = target;
    request.aspect = scene.aspect;
    request.boundaries = scene.boundaries;
    request.seed = scene.seed;
    Stopwatch clock;
    StartPacking start = makeStartPacking(*dist, request);
    s.box = start.configuration.box;
    s.particles = ParticleStore(scene.count, Features{.rotation = rotation});
    s.particles.position() = start.configuration.position;
    s.particles.radius() = start.configuration.radius;
    s.origin = fmt::format("{} by random sequential addition at packing fraction {:g} ({:.2f} s)", dist->describe(),
                           target, clock.seconds());
    s.attributes["distribution"] = dist->describe();
  }
  s.particles.setMassesFromDensity(scene.density);
  s.fileVelocity = fileVelocity;
  s.fileAngularVelocity = fileAngularVelocity;
  return s;
}

void setVelocities(const RelaxScene& scene, Start& s) {
  const bool rotation = scene.dem.needsRotation();
  if (scene.initialVelocities == "file") {
    if (!s.fileVelocity) {
      throw ConfigError(
          fmt::format("velocities.initial = \"file\" but {} has no velocity columns; use "
                      "velocities.initial = \"impact\" or \"zero\"",
                      scene.particleFile));
    }
    if (scene.compression) throw ConfigError("velocities.initial = \"file\" cannot follow [compression]");
    s.particles.velocity() = *s.fileVelocity;
    // A snapshot of a frictional run carries the spins: restarting from it is faithful.
    if (rotation && s.fileAngularVelocity) s.particles.angularVelocity() = *s.fileAngularVelocity;
  } else if (scene.initialVelocities == "impact") {
    const double v = integrators::assignImpactVelocities(contact::ContactModel(scene.dem.contact), s.particles,
                                                         scene.impactOverlap, scene.velocitySeed);
    fmt::print(
        "velocities: Gaussian, equipartition, scaled so two smallest particles meet at v* = {:.4g} m/s "
        "(head-on overlap {:g} of their radius)\n",
        v, scene.impactOverlap);
  } else {
    s.particles.velocity().setZero();
  }
}

void compressStart(const RelaxScene& scene, integrators::SoftCompression& c, Start& start, const RunContext& run,
                   bool quiet, bool checkpoints) {
  Stopwatch clock;
  double lastCheckpoint = 0.0;
  std::int64_t reported = c.progress().steps / 1000;
  auto writeCheckpoint = [&] {
    c.sync();  // several MPI ranks: the state gathered to rank 0
    io::writeCheckpoint(scene.checkpoint, makeCheckpoint(c.simulation(), run, &c.progress()));
    lastCheckpoint = clock.seconds();
  };
  checkpoints = checkpoints && !scene.checkpoint.empty();
  bool interrupted = interruptRequested();
  while (!interrupted) {
    const std::int64_t before = c.progress().steps;
    if (!c.advance()) break;
    const std::int64_t steps = c.progress().steps;
    if (!quiet && steps / 1000 > reported) {
      fmt::print(stderr, "  compression: step {:>9}  {}  packing fraction {:.4f}  max overlap / r {:.4f}\n", steps,
                 c.growing() ? "growing " : "relaxing", c.packingFraction(), c.maxOverlapRatio());
    }
    const std::int64_t interval = scene.checkpointInterval;
    const bool byStep = interval > 0 && steps / interval != before / interval;  // crossed a multiple
    reported = std::max(reported, steps / 1000);
    interrupted = interruptRequested();
    if (checkpoints && !interrupted &&
        (byStep || (scene.checkpointSeconds > 0.0 && clock.seconds() - lastCheckpoint >= scene.checkpointSeconds))) {
      writeCheckpoint();
    }
  }
  if (interrupted && checkpoints) writeCheckpoint();
  c.sync();  // several MPI ranks: the state gathered to rank 0, before the result reads it
  const integrators::CompressionResult r = c.result();
  fmt::print(
      "soft compression: packing fraction {:.4f} after {} growth + {} relaxation steps, max overlap / r "
      "{:.4g}, {} rebuilds, {:.1f} s\n",
      r.packingFraction, r.growthSteps, r.relaxSteps, r.maxOverlapRatio, r.rebuilds, clock.seconds());
  if (interrupted) {
    start.interrupted = true;
    start.targetNotReached = "soft compression interrupted: " + r.reason;
  } else if (!r.reachedTarget) {
    start.targetNotReached = "soft compression: " + r.reason;
  }
  start.particles = c.particles();
  start.box = c.simulation().box();
}

}  // namespace polydem::app
