// polydem relax: run a soft-sphere DEM relaxation described by a TOML scene file (see
// apps/polydem/relax_scene.hpp and examples/relax_uv10.toml), with command-line overrides, optional
// soft compression, outputs (HDF5/text snapshots, CSV time series, final state) and a closing report.
// `--sweep dt-factor=10,20,50` or `--sweep skin=...` reruns the scene per setting and tabulates error
// against wall time (CSV, and a PNG when gnuplot is installed).
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <numeric>
#include <random>
#include <sstream>

#include <fmt/format.h>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/common.hpp"
#include "apps/polydem/relax_scene.hpp"
#include "core/errors.hpp"
#include "core/initial_configuration.hpp"
#include "core/io/particle_file.hpp"
#include "integrators/dem_simulation.hpp"
#include "integrators/initial_velocities.hpp"
#include "integrators/soft_compression.hpp"

namespace polydem::app {

namespace {

struct RelaxOptions {
  std::string scene;
  std::vector<std::string> sets;
  std::optional<std::int64_t> steps;
  std::optional<double> dtFactor;
  std::optional<std::string> broadPhase;
  std::optional<double> skin;
  std::optional<std::string> kernel;
  std::optional<int> threads;
  std::string sweep;
  bool quiet = false;
};

double peakMemoryMiB() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // Linux: KiB
}

/// The starting state: read or generated, masses from density, optionally compressed, velocities set.
struct Start {
  ParticleStore particles;
  Box box;
  std::string origin;
  std::map<std::string, std::string> attributes;
};

Start prepare(const RelaxScene& scene, bool quiet) {
  Start s;
  const bool rotation = scene.dem.contact.usesFriction() || scene.dem.generalKernel;
  std::optional<Eigen::Matrix3Xd> fileVelocity;
  if (!scene.particleFile.empty()) {
    const auto path = scene.resolve(scene.particleFile);
    io::ParticleData data = io::readParticles(path, scene.boundaries);
    s.box = data.box;
    s.particles = ParticleStore(data.count(), Features{.rotation = rotation});
    s.particles.position() = data.position;
    s.particles.radius() = data.radius;
    s.particles.id() = data.id;
    fileVelocity = data.velocity;
    s.origin = fmt::format("read from {}", path.string());
    s.attributes = data.attributes;
  } else {
    const auto dist = makeDistribution(scene.distribution);
    PackingRequest request;
    request.radii = dist->sample(scene.count, scene.sampling == "random" ? Sampling::Random : Sampling::Systematic,
                                 scene.seed);
    std::mt19937_64 rng(scene.seed ^ 0x9e3779b97f4a7c15ULL);
    std::shuffle(request.radii.begin(), request.radii.end(), rng);
    const double target = scene.compression ? std::min(scene.packingFraction, scene.compression->targetPacking)
                                            : scene.packingFraction;
    request.packingFraction = target;
    request.aspect = scene.aspect;
    request.boundaries = scene.boundaries;
    request.seed = scene.seed;
    Stopwatch clock;
    const Configuration config = randomSequentialAddition(request);
    s.box = config.box;
    s.particles = ParticleStore(scene.count, Features{.rotation = rotation});
    s.particles.position() = config.position;
    s.particles.radius() = config.radius;
    s.origin = fmt::format("{} by random sequential addition at packing fraction {:g} ({:.2f} s)", dist->describe(),
                           target, clock.seconds());
    s.attributes["distribution"] = dist->describe();
  }
  s.particles.setMassesFromDensity(scene.density);

  if (scene.compression) {
    const auto& c = *scene.compression;
    Stopwatch clock;
    auto progress = [&](const integrators::DemSimulation& sim, bool growing) {
      if (!quiet) {
        fmt::print(stderr, "  compression: step {:>9}  {}  packing fraction {:.4f}  max overlap / r {:.4f}\n",
                   sim.step(), growing ? "growing " : "relaxing", sim.packingFraction(),
                   sim.contactStats().maxOverlapRatio);
      }
    };
    const integrators::CompressionResult r = integrators::softCompress(s.particles, s.box, scene.dem, c, progress);
    fmt::print("soft compression: packing fraction {:.4f} after {} growth + {} relaxation steps, max overlap / r "
               "{:.4g}, {} rebuilds, {:.1f} s\n",
               r.packingFraction, r.growthSteps, r.relaxSteps, r.maxOverlapRatio, r.rebuilds, clock.seconds());
  }

  if (scene.initialVelocities == "file") {
    if (!fileVelocity) {
      throw ConfigError(fmt::format("velocities.initial = \"file\" but {} has no velocity columns; use "
                                    "velocities.initial = \"impact\" or \"zero\"",
                                    scene.particleFile));
    }
    if (scene.compression) throw ConfigError("velocities.initial = \"file\" cannot follow [compression]");
    s.particles.velocity() = *fileVelocity;
  } else if (scene.initialVelocities == "impact") {
    const double v = integrators::assignImpactVelocities(contact::ContactModel(scene.dem.contact), s.particles,
                                                         scene.impactOverlap, scene.velocitySeed);
    fmt::print("velocities: Gaussian, equipartition, scaled so two smallest particles meet at v* = {:.4g} m/s "
               "(head-on overlap {:g} of their radius)\n",
               v, scene.impactOverlap);
  } else {
    s.particles.velocity().setZero();
  }
  return s;
}

/// Particle data in id order, for snapshots and the final state.
io::ParticleData snapshotOf(const integrators::DemSimulation& sim, const std::map<std::string, std::string>& attrs) {
  const ParticleStore& p = sim.particles();
  const Index n = p.count();
  std::vector<Index> order(static_cast<std::size_t>(n));
  std::iota(order.begin(), order.end(), Index{0});
  std::sort(order.begin(), order.end(), [&](Index a, Index b) { return p.id()[a] < p.id()[b]; });
  io::ParticleData d;
  d.box = sim.box();
  d.position.resize(3, n);
  d.radius.resize(n);
  d.velocity = Eigen::Matrix3Xd(3, n);
  d.id.resize(static_cast<std::size_t>(n));
  for (Index k = 0; k < n; ++k) {
    const Index i = order[static_cast<std::size_t>(k)];
    d.position.col(k) = sim.box().wrap(p.position().col(i));
    d.radius[k] = p.radius()[i];
    d.velocity->col(k) = p.velocity().col(i);
    d.id[static_cast<std::size_t>(k)] = p.id()[static_cast<std::size_t>(i)];
  }
  d.time = sim.time();
  d.attributes = attrs;
  d.attributes["step"] = std::to_string(sim.step());
  d.attributes["contact"] = sim.model().parameters().describe();
  d.attributes["dt"] = fmt::format("{:.17g}", sim.dt());
  return d;
}

std::string withStep(const std::string& pattern, std::int64_t step) {
  std::string out = pattern;
  const std::size_t at = out.find("{step}");
  if (at != std::string::npos) out.replace(at, 6, fmt::format("{:09d}", step));
  return out;
}

struct RunSummary {
  double wallSeconds = 0.0;  ///< the time loop only
  double finalEnergy = 0.0;
  double initialEnergy = 0.0;
  Eigen::Matrix3Xd positions;  ///< by id, for sweep comparisons
};

/// The time loop with outputs and progress; prints the closing report unless `brief`.
RunSummary runScene(const RelaxScene& scene, Start start, bool quiet, bool brief) {
  integrators::DemSimulation sim(std::move(start.particles), start.box, scene.dem);
  const Index n = sim.particles().count();
  const contact::ContactStats s0 = sim.contactStats();
  if (!brief) {
    fmt::print("particles: {} ({}), box {}, packing fraction {:.4f}\n", n, start.origin, sim.box().describe(),
               sim.packingFraction());
    fmt::print("contact: {}; kernel {}{}\n", sim.model().parameters().describe(), sim.kernel().name,
               scene.dem.threads > 1 ? fmt::format(", {} OpenMP threads", scene.dem.threads) : std::string(", serial"));
    fmt::print("time step: {}\n", sim.timeStepChoice().describe());
    fmt::print("broad phase: {} (skin {:.4g}, rebuilt when a particle moved skin/2)\n",
               sim.neighbours().backend().describe(), sim.neighbours().skin());
    fmt::print("start: {} contacts, max overlap / r {:.4g}, total energy {:.6g} J\n", s0.contacts, s0.maxOverlapRatio,
               sim.initialEnergy());
  }

  std::ofstream csv;
  if (!scene.timeseries.empty()) {
    csv.open(scene.timeseries);
    if (!csv) throw InputError(fmt::format("{}: cannot write the time series", scene.timeseries));
    csv << "step,time,kinetic,rotational,elastic,potential,total,contacts,wall_contacts,contacts_per_particle,"
           "max_overlap_ratio,rebuilds\n";
  }
  auto writeRow = [&] {
    const integrators::Energies e = sim.energies();
    const contact::ContactStats c = sim.contactStats();
    csv << fmt::format("{},{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},{:.12g},{},{},{:.6g},{:.6g},{}\n", sim.step(),
                       sim.time(), e.kinetic, e.rotational, e.elastic, e.potential, e.total(), c.contacts,
                       c.wallContacts, 2.0 * static_cast<double>(c.contacts) / n, c.maxOverlapRatio, sim.rebuilds());
  };
  auto writeSnapshot = [&] {
    io::writeParticles(withStep(scene.snapshot, sim.step()), snapshotOf(sim, start.attributes));
  };
  if (csv.is_open()) writeRow();
  if (!scene.snapshot.empty() && scene.snapshotInterval > 0) writeSnapshot();

  Stopwatch clock;
  double loopSeconds = 0.0, lastProgress = 0.0;
  const std::int64_t total = scene.steps;
  while (sim.step() < total) {
    std::int64_t next = std::min(total, sim.step() + 200);
    if (csv.is_open()) next = std::min(next, (sim.step() / scene.timeseriesInterval + 1) * scene.timeseriesInterval);
    if (scene.snapshotInterval > 0) {
      next = std::min(next, (sim.step() / scene.snapshotInterval + 1) * scene.snapshotInterval);
    }
    const double before = clock.seconds();
    sim.advance(next - sim.step());
    loopSeconds += clock.seconds() - before;
    if (csv.is_open() && sim.step() % scene.timeseriesInterval == 0) writeRow();
    if (scene.snapshotInterval > 0 && sim.step() % scene.snapshotInterval == 0) writeSnapshot();
    const double now = clock.seconds();
    if (!quiet && scene.progressInterval > 0.0 && now - lastProgress >= scene.progressInterval && sim.step() < total) {
      lastProgress = now;
      const double rate = static_cast<double>(sim.step()) / std::max(loopSeconds, 1e-9);
      fmt::print(stderr, "  step {:>10} / {} ({:4.1f}%)  {:.0f} steps/s  {:.3f} us/particle/step  ETA {:.0f} s\n",
                 sim.step(), total, 100.0 * static_cast<double>(sim.step()) / static_cast<double>(total), rate,
                 1e6 * loopSeconds / (static_cast<double>(sim.step()) * n), static_cast<double>(total - sim.step()) / rate);
    }
  }
  if (!scene.finalState.empty()) io::writeParticles(scene.finalState, snapshotOf(sim, start.attributes));
  if (!scene.snapshot.empty() && (scene.snapshotInterval == 0 || sim.step() % scene.snapshotInterval != 0)) {
    writeSnapshot();
  }

  const integrators::Energies e = sim.energies();
  RunSummary summary{loopSeconds, e.total(), sim.initialEnergy(), {}};
  {
    const ParticleStore& p = sim.particles();
    summary.positions.resize(3, n);
    std::vector<Index> order(static_cast<std::size_t>(n));
    std::iota(order.begin(), order.end(), Index{0});
    std::sort(order.begin(), order.end(), [&](Index a, Index b) { return p.id()[a] < p.id()[b]; });
    for (Index k = 0; k < n; ++k) summary.positions.col(k) = p.position().col(order[static_cast<std::size_t>(k)]);
  }
  if (brief) return summary;

  const contact::ContactStats c = sim.contactStats();
  const integrators::PhaseTimes& t = sim.times();
  const double perParticleStep = 1e6 / (static_cast<double>(std::max<std::int64_t>(1, sim.step())) * n);
  fmt::print("\n--- relax report ---\n");
  fmt::print("steps                 {} (dt = {:.6g} s, simulated time {:.6g} s)\n", sim.step(), sim.dt(), sim.time());
  fmt::print("contacts              {} particle pairs, {} with walls: {:.3f} contacts per particle (z = 2 C / N)\n",
             c.contacts, c.wallContacts, 2.0 * static_cast<double>(c.contacts) / n);
  fmt::print("max overlap / radius  {:.4g}\n", c.maxOverlapRatio);
  fmt::print("energy (J)            kinetic {:.6g}, rotational {:.6g}, elastic {:.6g}, potential {:.6g}\n", e.kinetic,
             e.rotational, e.elastic, e.potential);
  fmt::print("                      total {:.8g} (start {:.8g}, relative change {:+.3e})\n", e.total(),
             sim.initialEnergy(), (e.total() - sim.initialEnergy()) / std::abs(sim.initialEnergy()));
  fmt::print("time                  {:.4f} us/particle/step in the loop ({:.3f} s): broad phase {:.4f}, force {:.4f}, "
             "integration {:.4f}, checks {:.4f}\n",
             loopSeconds * perParticleStep, loopSeconds, t.broadPhase * perParticleStep, t.force * perParticleStep,
             t.integration * perParticleStep, t.check * perParticleStep);
  fmt::print("neighbour list        {} rebuilds ({:.1f} steps per rebuild), {} candidate pairs ({:.2f} per particle)\n",
             sim.rebuilds(), static_cast<double>(sim.step()) / std::max<std::int64_t>(1, sim.rebuilds() - 1),
             sim.neighbours().list().pairCount(),
             static_cast<double>(sim.neighbours().list().pairCount()) / n);
  fmt::print("memory                {:.1f} MiB held by the run ({:.0f} bytes/particle), peak RSS {:.1f} MiB\n",
             static_cast<double>(sim.memoryBytes()) / (1024.0 * 1024.0),
             static_cast<double>(sim.memoryBytes()) / n, peakMemoryMiB());
  if (!scene.finalState.empty()) fmt::print("final state           {}\n", scene.finalState);
  if (!scene.timeseries.empty()) fmt::print("time series           {}\n", scene.timeseries);
  return summary;
}

/// --sweep dt-factor=10,20,50 | skin=0.05,0.1: same scene (same start) per setting, same simulated time.
int runSweep(RelaxScene scene, const std::string& spec, bool quiet) {
  const std::size_t eq = spec.find('=');
  if (eq == std::string::npos) throw ConfigError(fmt::format("--sweep '{}': expected dt-factor=... or skin=...", spec));
  const std::string what = spec.substr(0, eq);
  if (what != "dt-factor" && what != "skin") {
    throw ConfigError(fmt::format("--sweep {}: only dt-factor and skin can be swept", what));
  }
  std::vector<double> values;
  std::stringstream in(spec.substr(eq + 1));
  for (std::string item; std::getline(in, item, ',');) {
    try {
      values.push_back(std::stod(item));
    } catch (const std::exception&) {
      throw ConfigError(fmt::format("--sweep {}: '{}' is not a number", what, item));
    }
  }
  if (values.empty()) throw ConfigError("--sweep: no values");
  if (what == "dt-factor" && scene.dem.timeStep > 0.0) throw ConfigError("--sweep dt-factor conflicts with run.dt");
  std::sort(values.begin(), values.end());

  const Start start = prepare(scene, quiet);
  const double baseFactor = scene.dem.stepsPerContact;
  const std::int64_t baseSteps = scene.steps;
  scene.timeseries.clear();
  scene.snapshot.clear();
  scene.finalState.clear();
  struct Row {
    double value;
    std::int64_t steps;
    RunSummary run;
  };
  std::vector<Row> rows;
  for (double v : values) {
    RelaxScene s = scene;
    if (what == "dt-factor") {
      s.dem.stepsPerContact = v;
      s.steps = static_cast<std::int64_t>(std::llround(static_cast<double>(baseSteps) * v / baseFactor));
    } else {
      s.dem.skin = v;
    }
    if (!quiet) fmt::print(stderr, "  sweep {} = {:g}: {} steps\n", what, v, s.steps);
    rows.push_back({v, s.steps, runScene(s, start, true, true)});
  }
  // Error: energy drift for elastic scenes, else distance to the finest setting (largest dt factor).
  const bool elastic = scene.dem.contact.elastic() && scene.dem.viscousDamping == 0.0;
  const Row& finest = what == "dt-factor" ? rows.back() : rows.front();
  const double rmin = start.particles.radius().minCoeff();
  const std::string stem = scene.source.stem().string();
  const std::string csvPath = fmt::format("{}_sweep_{}.csv", stem, what);
  std::ofstream csv(csvPath);
  csv << what << ",steps,wall_seconds,us_per_particle_step,energy_error,position_error\n";
  fmt::print("\n{:>10} {:>10} {:>12} {:>18} {:>16} {:>16}\n", what, "steps", "wall s", "us/particle/step",
             elastic ? "energy drift" : "energy vs finest", "max |dx| / r_min");
  const double n = static_cast<double>(start.particles.count());
  for (const Row& r : rows) {
    const double energyError = elastic ? std::abs(r.run.finalEnergy - r.run.initialEnergy) / std::abs(r.run.initialEnergy)
                                       : std::abs(r.run.finalEnergy - finest.run.finalEnergy) /
                                             std::abs(finest.run.initialEnergy);
    double positionError = 0.0;
    for (Index i = 0; i < r.run.positions.cols(); ++i) {
      positionError = std::max(positionError,
                               start.box.minimumImageAny(r.run.positions.col(i) - finest.run.positions.col(i)).norm());
    }
    positionError /= rmin;
    const double us = 1e6 * r.run.wallSeconds / (static_cast<double>(std::max<std::int64_t>(1, r.steps)) * n);
    fmt::print("{:>10g} {:>10} {:>12.3f} {:>18.4f} {:>16.4e} {:>16.4e}\n", r.value, r.steps, r.run.wallSeconds, us,
               energyError, positionError);
    csv << fmt::format("{},{},{:.6g},{:.6g},{:.6e},{:.6e}\n", r.value, r.steps, r.run.wallSeconds, us, energyError,
                       positionError);
  }
  csv.close();
  fmt::print("table: {}\n", csvPath);
  if (what == "dt-factor" && std::system("command -v gnuplot > /dev/null 2>&1") == 0) {
    const std::string png = fmt::format("{}_sweep_{}.png", stem, what);
    const std::string script = fmt::format("{}_sweep_{}.gp", stem, what);
    std::ofstream gp(script);
    gp << "set terminal pngcairo size 800,560\n"
       << "set output '" << png << "'\n"
       << "set datafile separator ','\n"
       << "set logscale xy\n"
       << "set xlabel 'wall time (s)'\n"
       << "set ylabel '" << (elastic ? "relative energy drift" : "energy error vs finest dt") << "'\n"
       << "set title 'polydem relax: error against run time, labels = steps per contact'\n"
       << "set key off\n"
       << "plot '" << csvPath << "' every ::1 using 3:($5 > 0 ? $5 : 1/0) with linespoints pt 7, "
       << "'' every ::1 using 3:($5 > 0 ? $5 : 1/0):1 with labels offset 1.5,0.8\n";
    gp.close();
    if (std::system(("gnuplot " + script).c_str()) == 0) fmt::print("plot: {}\n", png);
  }
  return 0;
}

}  // namespace

Runner addRelax(CLI::App& app) {
  auto opt = std::make_shared<RelaxOptions>();
  CLI::App* cmd = app.add_subcommand("relax", "soft-sphere DEM relaxation of a scene file (TOML)");
  cmd->add_option("scene", opt->scene, "scene file, e.g. examples/relax_uv10.toml")->required();
  cmd->add_option("--set", opt->sets, "override a scene key, section.key=value (repeatable), e.g. --set contact.restitution=0.5")
      ->allow_extra_args(false);  // one value per --set, so the scene file is never swallowed
  cmd->add_option("--steps", opt->steps, "run.steps");
  cmd->add_option("--dt-factor", opt->dtFactor, "run.dt_factor: steps per shortest contact (>= 5)");
  cmd->add_option("--broadphase", opt->broadPhase, "run.broadphase: brute, linked-cell, hgrid-td, ..., auto");
  cmd->add_option("--skin", opt->skin, "run.skin: Verlet skin (m)");
  cmd->add_option("--kernel", opt->kernel, "run.kernel: specialised or general (for comparisons)");
  cmd->add_option("--threads", opt->threads, "run.threads: OpenMP threads for forces and kicks (1 = serial)");
  cmd->add_option("--sweep", opt->sweep, "dt-factor=10,20,50,100,200 or skin=...: error against wall time");
  cmd->add_flag("-q,--quiet", opt->quiet, "no progress lines");
  return [opt]() {
    std::vector<std::string> overrides = opt->sets;
    if (opt->steps) overrides.push_back(fmt::format("run.steps={}", *opt->steps));
    if (opt->dtFactor) overrides.push_back(fmt::format("run.dt_factor={:.17g}", *opt->dtFactor));
    if (opt->broadPhase) overrides.push_back(fmt::format("run.broadphase=\"{}\"", *opt->broadPhase));
    if (opt->skin) overrides.push_back(fmt::format("run.skin={:.17g}", *opt->skin));
    if (opt->kernel) overrides.push_back(fmt::format("run.kernel=\"{}\"", *opt->kernel));
    if (opt->threads) overrides.push_back(fmt::format("run.threads={}", *opt->threads));
    const RelaxScene scene = loadRelaxScene(opt->scene, overrides);
    fmt::print("polydem relax {}\n", opt->scene);
    if (!opt->sweep.empty()) return runSweep(scene, opt->sweep, opt->quiet);
    runScene(scene, prepare(scene, opt->quiet), opt->quiet, false);
    return 0;
  };
}

}  // namespace polydem::app
