// Deterministic cost counters of the event-driven engine (issue 24): events, neighbourhood exits, checks
// and pair predictions per collision, neighbours per sphere, and per size class of the skin rule, for a
// fixed-density run or a compression. Meant for `valgrind --tool=callgrind --toggle-collect=measuredPart`
// (instructions per collision on a shared machine, where wall-clock rates mean little) and for timing on
// a quiet one (it prints collisions per second too). docs/benchmarks/edmd/README.md has the commands.
//
// The start is made as `polydem jam` makes it: systematic sample of the distribution, shuffled, random
// sequential addition at phi 0.3, Maxwell-Boltzmann velocities (seed), for the fixed-density mode then
// compressed at rate 1e-2 to phi 0.5 (with the default, size-class skins) and cached in --start FILE, so
// that runs with and without --global-skin start from the same state.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/initial_configuration.hpp"
#include "core/io/particle_file.hpp"
#include "core/size_distribution.hpp"
#include "edmd/compression.hpp"
#include "edmd/hard_sphere_system.hpp"

namespace {

using namespace polydem;

struct Settings {
  DistributionSpec dist;
  Index count = 10000;
  std::uint64_t seed = 1;
  std::string mode = "fixed";
  double collisions = 20.0;  // per particle, measured
  double warmup = 10.0;      // per particle, fixed mode, not measured
  double phi = 0.5;
  std::string start;
  bool globalSkin = false;
  double lead = -1.0;      // < 0: the engine's default
  double exitWork = -1.0;  // < 0: the engine's default
  bool classes = false;
};

struct Measured {
  edmd::EventCounts counts;
  std::int64_t pairs = 0;
  double seconds = 0.0;
  double phi = 0.0;
};

// The part callgrind counts (--toggle-collect=measuredPart): the event loop and its synchronisations.
[[gnu::noinline]] Measured measuredPart(edmd::HardSphereSystem& system, const Settings& s) {
  const edmd::EventCounts before = system.counts();
  const std::int64_t pairsBefore = system.pairPredictions();
  const auto t0 = std::chrono::steady_clock::now();
  if (s.mode == "fixed") {
    edmd::runAtFixedDensity(system, s.collisions, 100.0);
  } else {
    edmd::CompressionOptions options;
    options.schedule = {{1e-2, edmd::HardSphereSystem::kInfinity}};
    options.targetPackingFraction = s.phi;
    options.maxCollisionsPerParticle = s.collisions;
    edmd::compress(system, options);
  }
  Measured m;
  m.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  m.counts = system.counts() - before;
  m.pairs = system.pairPredictions() - pairsBefore;
  m.phi = system.packingFraction();
  return m;
}

Configuration randomStart(const Settings& s) {
  StartPackingRequest request;
  request.count = s.count;
  request.sampling = Sampling::Systematic;
  request.packingFraction = 0.3;
  request.seed = s.seed;
  return makeStartPacking(*makeDistribution(s.dist), request).configuration;
}

// Fixed mode: the state at s.phi, from --start if it exists, else compressed and written there.
io::ParticleData denseStart(const Settings& s) {
  if (!s.start.empty() && std::filesystem::exists(s.start)) {
    io::ParticleData data = io::readParticles(s.start);
    if (!data.velocity)
      throw std::runtime_error(s.start + ": no velocities (write the start with them: jam --velocities)");
    return data;
  }
  const Configuration c = randomStart(s);
  edmd::HardSphereSystem system(c.box, c.position, c.radius, edmd::maxwellBoltzmannVelocities(c.radius, s.seed));
  edmd::CompressionOptions options;
  options.schedule = {{1e-2, edmd::HardSphereSystem::kInfinity}};
  options.targetPackingFraction = s.phi;
  options.maxCollisionsPerParticle = 1e9;
  edmd::compress(system, options);
  io::ParticleData data;
  data.box = system.box();
  data.position = system.positions();
  data.radius = system.radii();
  data.velocity = system.velocities();
  data.id.resize(static_cast<std::size_t>(system.count()));
  for (Index i = 0; i < system.count(); ++i) data.id[static_cast<std::size_t>(i)] = i;
  if (!s.start.empty()) io::writeParticles(s.start, data);
  return data;
}

// Builds the system (from --start or a fresh compression), runs the measured part, prints the counters.
int measure(const Settings& s) {
  edmd::SystemOptions options;
  options.classSkins = !s.globalSkin;
  if (s.lead >= 0.0) options.exitLead = s.lead;
  if (s.exitWork >= 0.0) options.exitWork = s.exitWork;
  std::unique_ptr<edmd::HardSphereSystem> system;
  if (s.mode == "fixed") {
    const io::ParticleData d = denseStart(s);
    system = std::make_unique<edmd::HardSphereSystem>(d.box, d.position, d.radius, *d.velocity, options);
    if (s.warmup > 0.0) edmd::runAtFixedDensity(*system, s.warmup, 100.0);
  } else {
    const Configuration c = randomStart(s);
    system = std::make_unique<edmd::HardSphereSystem>(c.box, c.position, c.radius,
                                                      edmd::maxwellBoltzmannVelocities(c.radius, s.seed), options);
  }
  const double phi0 = system->packingFraction();
  const std::vector<edmd::SkinClass> classesBefore = system->skinClasses();
  const Measured m = measuredPart(*system, s);
  const double coll = static_cast<double>(std::max<std::int64_t>(m.counts.collisions, 1));
  fmt::print(
      "mode {} dist {} omega {} sigma {} n {} skins {} phi {:.4f}->{:.4f} ratio {:.1f} collisions {} "
      "events/coll {:.3f} exits/coll {:.3f} checks/coll {:.3f} pairs/coll {:.1f} nb {:.2f} rebuilds {} "
      "coll/s {:.4g}\n",
      s.mode, s.dist.kind, s.dist.omega, s.dist.sigma, system->count(), s.globalSkin ? "global" : "class", phi0, m.phi,
      system->largestRadius() / system->smallestRadius(), m.counts.collisions,
      static_cast<double>(m.counts.events()) / coll, static_cast<double>(m.counts.exits) / coll,
      static_cast<double>(m.counts.checks) / coll, static_cast<double>(m.pairs) / coll, system->meanNeighbours(),
      m.counts.rebuilds, coll / m.seconds);
  // The same, machine-readable (scripts/edmd_wide_counters.sh).
  fmt::print("csv,{},{},{},{},{},{:.4f},{:.4f},{},{:.4f},{:.4f},{:.4f},{:.2f},{:.3f},{},{:.5g}\n", s.mode, s.dist.kind,
             s.dist.omega, s.dist.sigma, s.globalSkin ? "global" : "class", phi0, m.phi, system->count(),
             static_cast<double>(m.counts.events()) / coll, static_cast<double>(m.counts.exits) / coll,
             static_cast<double>(m.counts.checks) / coll, static_cast<double>(m.pairs) / coll, system->meanNeighbours(),
             m.counts.collisions, coll / m.seconds);
  if (s.classes) {
    fmt::print("{:>5} {:>7} {:>9} {:>9} {:>8} {:>12} {:>12} {:>12} {:>11} {:>12}\n", "class", "count", "floor",
               "skin/rmin", "nb", "exits/coll", "pairs/pred", "share exits", "share coll", "share scans");
    // Counters of the measured part only; floor, skin and list length as they stand at its end.
    std::vector<edmd::SkinClass> after = system->skinClasses();
    std::int64_t exits = 0, collisions = 0, scans = 0;
    for (std::size_t c = 0; c < after.size(); ++c) {
      edmd::SkinClass& k = after[c];
      k.exits -= classesBefore[c].exits;
      k.collisions -= classesBefore[c].collisions;
      k.predictions -= classesBefore[c].predictions;
      k.scans -= classesBefore[c].scans;
      exits += k.exits;
      collisions += k.collisions;
      scans += k.scans;
    }
    for (std::size_t c = 0; c < after.size(); ++c) {
      const edmd::SkinClass& k = after[c];
      fmt::print("{:>5} {:>7} {:>9.3g} {:>9.3g} {:>8.1f} {:>12.3f} {:>12.1f} {:>12.3f} {:>11.3f} {:>12.3f}\n", c,
                 k.count, k.floor, k.meanSkin, k.meanNeighbours,
                 static_cast<double>(k.exits) / static_cast<double>(std::max<std::int64_t>(k.collisions, 1)),
                 static_cast<double>(k.scans) / static_cast<double>(std::max<std::int64_t>(k.predictions, 1)),
                 static_cast<double>(k.exits) / static_cast<double>(std::max<std::int64_t>(exits, 1)),
                 static_cast<double>(k.collisions) / static_cast<double>(std::max<std::int64_t>(collisions, 1)),
                 static_cast<double>(k.scans) / static_cast<double>(std::max<std::int64_t>(scans, 1)));
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Settings s;
  CLI::App app{"EDMD cost counters per collision (fixed density or compression)"};
  app.add_option("--dist", s.dist.kind, "mono, uniform-radius, uniform-volume, log-normal, ...");
  app.add_option("--omega", s.dist.omega, "size ratio (log-normal: 0 = untruncated)");
  app.add_option("--sigma", s.dist.sigma, "log-normal width");
  app.add_option("--rmin", s.dist.rmin, "smallest radius (log-normal: lower cut, 0 = none)");
  app.add_option("-n,--count", s.count);
  app.add_option("--seed", s.seed);
  app.add_option("--mode", s.mode, "fixed: run at phi; compress: from the RSA start at 0.3 to phi at rate 1e-2")
      ->check(CLI::IsMember({"fixed", "compress"}));
  app.add_option("--collisions", s.collisions, "measured collisions per particle (compress: the budget)");
  app.add_option("--warmup", s.warmup, "fixed: unmeasured collisions per particle first (skins settle)");
  app.add_option("--phi", s.phi, "packing fraction of the fixed-density state / compression target");
  app.add_option("--start", s.start, "fixed: cache of the dense start (read if it exists, else written)");
  app.add_option("--lead", s.lead, "SystemOptions::exitLead (default: the engine's)");
  app.add_option("--exit-work", s.exitWork, "SystemOptions::exitWork (default: the engine's)");
  app.add_flag("--global-skin", s.globalSkin, "one skin floor for all sizes (SystemOptions::classSkins = false)");
  app.add_flag("--classes", s.classes, "print the per-size-class table");
  CLI11_PARSE(app, argc, argv);
  if (s.dist.kind == "log-normal") {  // untruncated unless cut explicitly
    if (!app.count("--omega")) s.dist.omega = 0.0;
    if (!app.count("--rmin")) s.dist.rmin = 0.0;
  }

  try {
    return measure(s);
  } catch (const std::exception& e) {  // a bad start file, an engine error: a message and a non-zero exit
    fmt::print(stderr, "error: {}\n", e.what());
    return 2;
  }
}
