// polydem relax: run a soft-sphere DEM relaxation described by a TOML scene file (see
// apps/polydem/relax_scene.hpp and examples/relax_uv10.toml), with command-line overrides, optional
// soft compression, outputs (HDF5/text snapshots, CSV time series, final state) and a closing report.
// `--sweep dt-factor=10,20,50` or `--sweep skin=...` reruns the scene per setting and tabulates error
// against wall time (CSV, and a PNG when gnuplot is installed).
//
// No lost work (issue 15): every output path is checked before anything is computed; files are written
// atomically; time-series rows are flushed every few seconds. With output.checkpoint the complete state
// (DemState: particles, forces, contact springs, the neighbour list's build positions, step, time, the
// scene) is saved every output.checkpoint_interval steps, every output.checkpoint_seconds of wall time,
// at the end and when SIGINT/SIGTERM arrives (exit 130); `relax --resume FILE.h5` continues the run
// bit-identically. Wall-clock timing (progress lines, timed checkpoints) only decides when the state is
// read, never what it becomes. The time loop has no random numbers: the RNGs (generation, impact
// velocities) are used up before step 0, so the checkpoint needs no RNG state.
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <fstream>
#include <numeric>
#include <random>
#include <sstream>

#include <fmt/format.h>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/common.hpp"
#include "apps/polydem/exit_codes.hpp"
#include "apps/polydem/validators.hpp"
#include "apps/polydem/relax_scene.hpp"
#include "core/errors.hpp"
#include "core/initial_configuration.hpp"
#include "core/interrupt.hpp"
#include "core/io/attributes.hpp"
#include "core/io/checkpoint.hpp"
#include "core/io/safe_output.hpp"
#include "core/io/particle_file.hpp"
#include "integrators/dem_simulation.hpp"
#include "integrators/initial_velocities.hpp"
#include "integrators/soft_compression.hpp"
#include "polydem/config.hpp"

namespace polydem::app {

namespace {

struct RelaxOptions {
  std::string scene;
  std::string resume;
  bool printDefaults = false;
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

/// The starting state: read or generated, masses from density; then compressed (compressStart) and
/// given velocities (setVelocities).
struct Start {
  ParticleStore particles;
  Box box;
  std::string origin;
  std::map<std::string, std::string> attributes;
  std::optional<std::string> targetNotReached;  ///< the soft compression stopped before its target: why
  bool interrupted = false;                      ///< SIGINT/SIGTERM during the soft compression
  std::optional<Eigen::Matrix3Xd> fileVelocity, fileAngularVelocity;  ///< from the particle file
};

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
    throw ConfigError(fmt::format("box.boundaries = \"{}\" conflicts with {}, which stores boundaries {}: remove "
                                  "box.boundaries from the scene to use the file's, or write the file with the "
                                  "boundaries you want",
                                  words(scene.boundaries), path.string(), words(fileBoundaries)));
  }
  return data;
}

/// Read or generate the particles of `scene` and set their masses.
Start prepare(const RelaxScene& scene) {
  Start s;
  const bool rotation = scene.dem.contact.usesFriction() || scene.dem.generalKernel;
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
    s.origin = fmt::format("read from {}", path.string());
    s.attributes = data.attributes;
    s.attributes.erase("target_not_reached");  // a mark of the run that wrote the file, not of this one
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
  s.fileVelocity = fileVelocity;
  s.fileAngularVelocity = fileAngularVelocity;
  return s;
}

/// The initial velocities of the run (after the compression, if any).
void setVelocities(const RelaxScene& scene, Start& s) {
  const bool rotation = scene.dem.contact.usesFriction() || scene.dem.generalKernel;
  if (scene.initialVelocities == "file") {
    if (!s.fileVelocity) {
      throw ConfigError(fmt::format("velocities.initial = \"file\" but {} has no velocity columns; use "
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
    fmt::print("velocities: Gaussian, equipartition, scaled so two smallest particles meet at v* = {:.4g} m/s "
               "(head-on overlap {:g} of their radius)\n",
               v, scene.impactOverlap);
  } else {
    s.particles.velocity().setZero();
  }
}

/// Particle data in id order, for snapshots and the final state: positions, velocities, angular
/// velocities (rotation on), time and step.
io::ParticleData snapshotOf(const integrators::DemSimulation& sim, const std::map<std::string, std::string>& attrs) {
  const ParticleStore& p = sim.particles();
  const Index n = p.count();
  std::vector<Index> order(static_cast<std::size_t>(n));
  std::iota(order.begin(), order.end(), Index{0});
  std::sort(order.begin(), order.end(), [&](Index a, Index b) { return p.id()[a] < p.id()[b]; });
  const bool rotation = p.features().rotation;
  io::ParticleData d;
  d.box = sim.box();
  d.position.resize(3, n);
  d.radius.resize(n);
  d.velocity = Eigen::Matrix3Xd(3, n);
  if (rotation) d.angularVelocity = Eigen::Matrix3Xd(3, n);
  d.id.resize(static_cast<std::size_t>(n));
  for (Index k = 0; k < n; ++k) {
    const Index i = order[static_cast<std::size_t>(k)];
    d.position.col(k) = sim.box().wrap(p.position().col(i));
    d.radius[k] = p.radius()[i];
    d.velocity->col(k) = p.velocity().col(i);
    if (rotation) d.angularVelocity->col(k) = p.angularVelocity().col(i);
    d.id[static_cast<std::size_t>(k)] = p.id()[static_cast<std::size_t>(i)];
  }
  d.time = sim.time();
  d.attributes = attrs;
  d.attributes["step"] = std::to_string(sim.step());
  d.attributes["time"] = fmt::format("{:.17g}", sim.time());
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

// ---- checkpoints ---------------------------------------------------------------------------------

constexpr const char* kCheckpointKind = "relax";

std::vector<std::int64_t> asInt64(const std::vector<std::uint64_t>& keys) {
  std::vector<std::int64_t> out(keys.size());
  std::memcpy(out.data(), keys.data(), keys.size() * sizeof(std::uint64_t));  // bit pattern kept
  return out;
}
std::vector<std::uint64_t> asUint64(const std::vector<std::int64_t>& keys) {
  std::vector<std::uint64_t> out(keys.size());
  std::memcpy(out.data(), keys.data(), keys.size() * sizeof(std::uint64_t));
  return out;
}

/// What a resumed run needs besides the simulation state: the scene (as given: file text and overrides,
/// so it is parsed exactly as the first time), the attributes written into outputs, and the origin line.
struct RunContext {
  std::string sceneText;
  std::string sceneSource;
  std::vector<std::string> overrides;
  std::map<std::string, std::string> attributes;
  std::string origin;
  std::string checkpointNote;  ///< non-empty: the report's checkpoint line (a checkpoint written elsewhere)
};

/// `compression` non-null: the run is in its soft compression (phase "compression"), else in the time
/// loop (phase "run").
io::Checkpoint makeCheckpoint(const integrators::DemSimulation& sim, const RunContext& run,
                              const integrators::CompressionProgress* compression = nullptr) {
  const integrators::DemState st = sim.state();
  io::Checkpoint c;
  c.kind = kCheckpointKind;
  c.text["phase"] = compression ? "compression" : "run";
  if (compression) {
    const integrators::CompressionProgress& p = *compression;
    c.integer["compression_progress"] = {static_cast<std::int64_t>(p.phase), p.steps, p.growthSteps, p.relaxSteps,
                                         p.packed ? 1 : 0};
    c.real["compression_values"] = {p.overlap, p.contactDuration, p.viscousDamping};
  }
  c.text["scene"] = run.sceneText;
  c.text["scene_source"] = run.sceneSource;
  std::string overrides, attributes;
  for (const std::string& o : run.overrides) overrides += o + "\n";
  for (const auto& [k, v] : run.attributes) attributes += k + "\t" + v + "\n";
  c.text["overrides"] = overrides;
  c.text["attributes"] = attributes;
  c.text["origin"] = run.origin;
  c.putMatrix("position", st.position);
  c.putMatrix("velocity", st.velocity);
  c.putMatrix("force", st.force);
  c.putVector("radius", st.radius);
  c.putVector("inverse_mass", st.inverseMass);
  c.putInteger("rotation", st.rotation ? 1 : 0);
  if (st.rotation) {
    c.putMatrix("angular_velocity", st.angularVelocity);
    c.putMatrix("torque", st.torque);
    c.putVector("inverse_inertia", st.inverseInertia);
  }
  c.integer["id"] = std::vector<std::int64_t>(st.id.begin(), st.id.end());
  c.putMatrix("reference_position", st.referencePosition);
  c.putVector("reference_radius", st.referenceRadius);
  c.integer["pair_keys"] = asInt64(st.pairKeys);
  c.integer["wall_keys"] = asInt64(st.wallKeys);
  c.real["pair_values"] = st.pairValues;
  c.real["wall_values"] = st.wallValues;
  c.real["box_lengths"] = {st.box.length(0), st.box.length(1), st.box.length(2)};
  c.integer["box_periodic"] = {st.box.periodic(0), st.box.periodic(1), st.box.periodic(2)};
  c.putInteger("step", st.step);
  c.putInteger("builds", st.builds);
  c.putScalar("skin", st.skin);
  c.putScalar("initial_energy", st.initialEnergy);
  c.putScalar("growth_since_build", st.growthSinceBuild);
  const integrators::TimeStepChoice& t = st.timeStep;
  c.real["time_step"] = {t.dt, t.contactDuration, t.stepsPerContact, t.radiusA, t.radiusB};
  c.integer["time_step_pair"] = {t.slotA, t.slotB, t.idA, t.idB};
  return c;
}

integrators::DemState stateFrom(const io::Checkpoint& c) {
  integrators::DemState st;
  const std::int64_t n = static_cast<std::int64_t>(c.vector("radius").size());
  st.radius = c.vector("radius");
  st.position = c.matrix("position", n);
  st.velocity = c.matrix("velocity", n);
  st.force = c.matrix("force", n);
  st.inverseMass = c.vector("inverse_mass");
  st.rotation = c.integerScalar("rotation") != 0;
  if (st.rotation) {
    st.angularVelocity = c.matrix("angular_velocity", n);
    st.torque = c.matrix("torque", n);
    st.inverseInertia = c.vector("inverse_inertia");
  }
  const auto& id = c.integers("id");
  st.id.assign(id.begin(), id.end());
  st.referencePosition = c.matrix("reference_position", n);
  st.referenceRadius = c.vector("reference_radius");
  st.pairKeys = asUint64(c.integers("pair_keys"));
  st.wallKeys = asUint64(c.integers("wall_keys"));
  st.pairValues = c.reals("pair_values");
  st.wallValues = c.reals("wall_values");
  const auto& L = c.reals("box_lengths");
  const auto& periodic = c.integers("box_periodic");
  if (L.size() != 3 || periodic.size() != 3) {
    throw InputError(
        fmt::format("{}: checkpoint entry box_lengths / box_periodic: expected 3 values", c.source.string()));
  }
  std::array<Boundary, 3> b{};
  for (std::size_t k = 0; k < 3; ++k) b[k] = periodic[k] ? Boundary::Periodic : Boundary::Wall;
  st.box = Box(Eigen::Vector3d(L[0], L[1], L[2]), b);
  st.step = c.integerScalar("step");
  st.builds = c.integerScalar("builds");
  st.skin = c.scalar("skin");
  st.initialEnergy = c.scalar("initial_energy");
  st.growthSinceBuild = c.scalar("growth_since_build");
  const auto& t = c.reals("time_step");
  const auto& pair = c.integers("time_step_pair");
  if (t.size() != 5 || pair.size() != 4) {
    throw InputError(fmt::format("{}: checkpoint entry time_step: wrong length", c.source.string()));
  }
  st.timeStep.dt = t[0];
  st.timeStep.contactDuration = t[1];
  st.timeStep.stepsPerContact = t[2];
  st.timeStep.radiusA = t[3];
  st.timeStep.radiusB = t[4];
  st.timeStep.slotA = static_cast<Index>(pair[0]);
  st.timeStep.slotB = static_cast<Index>(pair[1]);
  st.timeStep.idA = static_cast<Index>(pair[2]);
  st.timeStep.idB = static_cast<Index>(pair[3]);
  return st;
}

integrators::CompressionProgress compressionFrom(const io::Checkpoint& c) {
  const auto& i = c.integers("compression_progress");
  const auto& r = c.reals("compression_values");
  if (i.size() != 5 || r.size() != 3 || i[0] < 0 || i[0] > 2) {
    throw InputError(fmt::format("{}: checkpoint entry compression_progress / compression_values: malformed",
                                 c.source.string()));
  }
  integrators::CompressionProgress p;
  p.phase = static_cast<integrators::CompressionProgress::Phase>(i[0]);
  p.steps = i[1];
  p.growthSteps = i[2];
  p.relaxSteps = i[3];
  p.packed = i[4] != 0;
  p.overlap = r[0];
  p.contactDuration = r[1];
  p.viscousDamping = r[2];
  return p;
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (!line.empty()) out.push_back(line);
  }
  return out;
}

/// Keys a resumed run may change: they decide how long it runs, on how many threads (bit-identical for
/// any count) and what it writes, never the trajectory.
bool resumableKey(const std::string& assignment) {
  const std::string key = assignment.substr(0, assignment.find('='));
  return key == "run.steps" || key == "run.threads" || key == "run.progress_interval" || key.starts_with("output.");
}

// ---- the run -------------------------------------------------------------------------------------

struct RunSummary {
  double wallSeconds = 0.0;  ///< the time loop only
  double finalEnergy = 0.0;
  double initialEnergy = 0.0;
  Eigen::Matrix3Xd positions;  ///< by id, for sweep comparisons
  bool interrupted = false;
};

/// Every output of the scene (and the sweep's), checked before anything is computed.
void checkOutputs(const RelaxScene& scene, const std::vector<std::filesystem::path>& inputs,
                  const std::vector<std::pair<std::filesystem::path, std::string>>& extra = {}) {
  if (!scene.checkpoint.empty() && !POLYDEM_WITH_HDF5) {
    throw ConfigError(fmt::format("output.checkpoint = \"{}\": checkpoints are HDF5 files, and this polydem was "
                                  "built with POLYDEM_WITH_HDF5=OFF",
                                  scene.checkpoint));
  }
  std::vector<std::pair<std::filesystem::path, std::string>> outputs = extra;
  if (!scene.finalState.empty()) outputs.emplace_back(scene.finalState, "output.final");
  if (!scene.timeseries.empty()) outputs.emplace_back(scene.timeseries, "output.timeseries");
  if (!scene.snapshot.empty()) outputs.emplace_back(withStep(scene.snapshot, 0), "output.snapshot");
  if (!scene.checkpoint.empty()) outputs.emplace_back(scene.checkpoint, "output.checkpoint");
  for (std::size_t a = 0; a < outputs.size(); ++a) {
    io::checkOutputPath(outputs[a].first, outputs[a].second, inputs);
    for (std::size_t b = 0; b < a; ++b) {
      if (io::samePath(outputs[a].first, outputs[b].first)) {
        throw ConfigError(fmt::format("{} and {} are the same file '{}': give each output its own name",
                                      outputs[b].second, outputs[a].second, outputs[a].first.string()));
      }
    }
  }
}

/// The time series of a resumed run: the rows up to the checkpoint's step are kept (a run interrupted
/// after its last checkpoint wrote rows beyond it, which the resumed run writes again), and a last line
/// without its newline (a run killed mid-write) is dropped.
void truncateTimeSeries(const std::string& file, std::int64_t step) {
  std::ifstream in(file);
  if (!in) return;
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  std::string kept;
  std::size_t begin = 0;
  for (std::size_t end = text.find('\n'); end != std::string::npos; begin = end + 1, end = text.find('\n', begin)) {
    const std::string line = text.substr(begin, end - begin);
    if (!kept.empty()) {  // the header is always kept
      const auto rowStep = io::parseFiniteDouble(line.substr(0, line.find(',')));
      if (!rowStep || *rowStep > static_cast<double>(step)) break;
    }
    kept += line + "\n";
  }
  in.close();
  io::writeFileAtomically(file, kept);
}

/// The time loop with outputs, checkpoints and progress; prints the closing report unless `brief`.
RunSummary runScene(const RelaxScene& scene, integrators::DemSimulation sim, const RunContext& run, bool quiet,
                    bool brief, bool resumed, const std::optional<std::string>& targetNotReached = {}) {
  const Index n = sim.particles().count();
  const contact::ContactStats s0 = sim.contactStats();
  if (!brief) {
    fmt::print("particles: {} ({}), box {}, packing fraction {:.4f}\n", n, run.origin, sim.box().describe(),
               sim.packingFraction());
    fmt::print("contact: {}; kernel {}{}\n", sim.model().parameters().describe(), sim.kernel().name,
               scene.dem.threads > 1 ? fmt::format(", {} OpenMP threads", scene.dem.threads) : std::string(", serial"));
    fmt::print("time step: {}\n", sim.timeStepChoice().describe());
    fmt::print("broad phase: {} (skin {:.4g}, rebuilt when a particle moved skin/2)\n",
               sim.neighbours().backend().describe(), sim.neighbours().skin());
    if (resumed) {
      fmt::print("resumed at step {}: {} contacts, max overlap / r {:.4g}, total energy {:.6g} J (step 0: {:.6g} J)\n",
                 sim.step(), s0.contacts, s0.maxOverlapRatio, sim.energies().total(), sim.initialEnergy());
    } else {
      fmt::print("start: {} contacts, max overlap / r {:.4g}, total energy {:.6g} J\n", s0.contacts,
                 s0.maxOverlapRatio, sim.initialEnergy());
    }
  }
  std::map<std::string, std::string> attributes = run.attributes;
  if (targetNotReached) attributes["target_not_reached"] = *targetNotReached;

  std::ofstream csv;
  io::PeriodicFlush flushCsv;
  if (!scene.timeseries.empty()) {
    const bool append = resumed && std::filesystem::exists(scene.timeseries);
    if (append) truncateTimeSeries(scene.timeseries, sim.step());
    csv.open(scene.timeseries, append ? std::ios::app : std::ios::trunc);
    if (!csv) throw InputError(fmt::format("{}: cannot write the time series", scene.timeseries));
    if (!append) {
      csv << "step,time,kinetic,rotational,elastic,potential,total,contacts,wall_contacts,contacts_per_particle,"
             "max_overlap_ratio,rebuilds\n";
    }
  }
  auto writeRow = [&] {
    const integrators::Energies e = sim.energies();
    const contact::ContactStats c = sim.contactStats();
    csv << fmt::format("{},{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},{:.12g},{},{},{:.6g},{:.6g},{}\n", sim.step(),
                       sim.time(), e.kinetic, e.rotational, e.elastic, e.potential, e.total(), c.contacts,
                       c.wallContacts, 2.0 * static_cast<double>(c.contacts) / n, c.maxOverlapRatio, sim.rebuilds());
    flushCsv(csv);
  };
  const bool snapshots = !scene.snapshot.empty() && scene.snapshotInterval > 0;
  auto writeSnapshot = [&] { io::writeParticles(withStep(scene.snapshot, sim.step()), snapshotOf(sim, attributes)); };
  Stopwatch clock;
  double lastCheckpoint = 0.0;
  auto writeCheckpoint = [&] {
    io::writeCheckpoint(scene.checkpoint, makeCheckpoint(sim, run));
    lastCheckpoint = clock.seconds();
  };
  if (!resumed) {
    if (csv.is_open()) writeRow();
    if (snapshots) writeSnapshot();
  }

  double loopSeconds = 0.0, lastProgress = 0.0;
  const std::int64_t total = scene.steps;
  const std::int64_t firstStep = sim.step();
  bool interrupted = interruptRequested();
  auto boundary = [&](std::int64_t interval) { return (sim.step() / interval + 1) * interval; };
  while (sim.step() < total && !interrupted) {
    std::int64_t next = std::min(total, sim.step() + 200);
    if (csv.is_open()) next = std::min(next, boundary(scene.timeseriesInterval));
    if (snapshots) next = std::min(next, boundary(scene.snapshotInterval));
    if (!scene.checkpoint.empty() && scene.checkpointInterval > 0) {
      next = std::min(next, boundary(scene.checkpointInterval));
    }
    const double before = clock.seconds();
    sim.advance(next - sim.step(), true);
    loopSeconds += clock.seconds() - before;
    interrupted = interruptRequested();
    if (csv.is_open() && sim.step() % scene.timeseriesInterval == 0) writeRow();
    if (interrupted) break;
    if (snapshots && sim.step() % scene.snapshotInterval == 0) writeSnapshot();
    if (!scene.checkpoint.empty() && sim.step() < total) {
      // Timed checkpoints read the state; they never change it, so wall time cannot reach the trajectory.
      const bool byStep = scene.checkpointInterval > 0 && sim.step() % scene.checkpointInterval == 0;
      const bool byTime = scene.checkpointSeconds > 0.0 && clock.seconds() - lastCheckpoint >= scene.checkpointSeconds;
      if (byStep || byTime) writeCheckpoint();
    }
    const double now = clock.seconds();
    if (!quiet && scene.progressInterval > 0.0 && now - lastProgress >= scene.progressInterval && sim.step() < total) {
      lastProgress = now;
      const double done = static_cast<double>(sim.step() - firstStep);
      const double rate = done / std::max(loopSeconds, 1e-9);
      fmt::print(stderr, "  step {:>10} / {} ({:4.1f}%)  {:.0f} steps/s  {:.3f} us/particle/step  ETA {:.0f} s\n",
                 sim.step(), total, 100.0 * static_cast<double>(sim.step()) / static_cast<double>(total), rate,
                 1e6 * loopSeconds / (std::max(done, 1.0) * n), static_cast<double>(total - sim.step()) / rate);
    }
  }
  if (csv.is_open()) csv.flush();
  // The checks run once at the end whatever run.check_interval says (0 included): no state is written
  // as a result without having passed them.
  if (!interrupted) sim.checkStability();
  if (!scene.checkpoint.empty()) writeCheckpoint();
  if (!scene.finalState.empty()) io::writeParticles(scene.finalState, snapshotOf(sim, attributes));
  if (!interrupted && !scene.snapshot.empty() &&
      (scene.snapshotInterval == 0 || sim.step() % scene.snapshotInterval != 0)) {
    writeSnapshot();
  }

  const integrators::Energies e = sim.energies();
  RunSummary summary{loopSeconds, e.total(), sim.initialEnergy(), {}, interrupted};
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
  const std::int64_t stepsRun = sim.step() - firstStep;
  const double perParticleStep = 1e6 / (static_cast<double>(std::max<std::int64_t>(1, stepsRun)) * n);
  fmt::print("\n--- relax report ---\n");
  if (interrupted) {
    fmt::print("INTERRUPTED           by signal {} at step {} of {}\n", interruptSignal(), sim.step(), total);
  }
  fmt::print("steps                 {} (dt = {:.6g} s, simulated time {:.6g} s)\n", sim.step(), sim.dt(), sim.time());
  fmt::print("contacts              {} particle pairs, {} with walls: {:.3f} contacts per particle (z = 2 C / N)\n",
             c.contacts, c.wallContacts, 2.0 * static_cast<double>(c.contacts) / n);
  fmt::print("max overlap / radius  {:.4g}\n", c.maxOverlapRatio);
  fmt::print("energy (J)            kinetic {:.6g}, rotational {:.6g}, elastic {:.6g}, potential {:.6g}\n", e.kinetic,
             e.rotational, e.elastic, e.potential);
  const std::string relative = sim.initialEnergy() != 0.0
                                   ? fmt::format("relative change {:+.3e}", (e.total() - sim.initialEnergy()) /
                                                                                std::abs(sim.initialEnergy()))
                                   : std::string("relative change undefined: the start energy is 0");
  fmt::print("                      total {:.8g} (start {:.8g}, {})\n", e.total(), sim.initialEnergy(), relative);
  fmt::print("time                  {:.4f} us/particle/step in the loop ({:.3f} s): broad phase {:.4f}, force {:.4f}, "
             "integration {:.4f}, checks {:.4f}\n",
             loopSeconds * perParticleStep, loopSeconds, t.broadPhase * perParticleStep, t.force * perParticleStep,
             t.integration * perParticleStep, t.check * perParticleStep);
  fmt::print("neighbour list        {} rebuilds, {} candidate pairs ({:.2f} per particle)\n", sim.rebuilds(),
             sim.neighbours().list().pairCount(), static_cast<double>(sim.neighbours().list().pairCount()) / n);
  fmt::print("memory                {:.1f} MiB held by the run ({:.0f} bytes/particle), peak RSS {:.1f} MiB\n",
             static_cast<double>(sim.memoryBytes()) / (1024.0 * 1024.0),
             static_cast<double>(sim.memoryBytes()) / n, peakMemoryMiB());
  if (targetNotReached) fmt::print("TARGET NOT REACHED    {}\n", *targetNotReached);
  if (!scene.finalState.empty()) fmt::print("final state           {}\n", scene.finalState);
  if (!scene.timeseries.empty()) fmt::print("time series           {}\n", scene.timeseries);
  if (!run.checkpointNote.empty()) {
    fmt::print("checkpoint            {}\n", run.checkpointNote);
  } else if (!scene.checkpoint.empty()) {
    fmt::print("checkpoint            {} (step {}): continue with polydem relax --resume {}{}\n", scene.checkpoint,
               sim.step(), scene.checkpoint, interrupted ? "" : " --steps N");
  } else if (interrupted) {
    fmt::print("checkpoint            none (set output.checkpoint to make a run resumable)\n");
  }
  return summary;
}

/// Run the soft compression of `scene` chunk by chunk; between chunks poll interrupts and write
/// checkpoints (phase "compression") as the scene asks. On return `start` holds the compressed particles
/// at rest, marked if the target was not reached or the run was interrupted.
void compressStart(const RelaxScene& scene, integrators::SoftCompression& c, Start& start, const RunContext& run,
                   bool quiet, bool checkpoints) {
  Stopwatch clock;
  double lastCheckpoint = 0.0;
  std::int64_t reported = c.progress().steps / 1000;
  auto writeCheckpoint = [&] {
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
                 c.growing() ? "growing " : "relaxing", c.simulation().packingFraction(),
                 c.simulation().contactStats().maxOverlapRatio);
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
  const integrators::CompressionResult r = c.result();
  fmt::print("soft compression: packing fraction {:.4f} after {} growth + {} relaxation steps, max overlap / r "
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

/// "--sweep NAME=v1,v2,...": strict numbers (no trailing characters, finite), dt-factor >= 5, skin >= 0.
std::vector<double> sweepValues(const std::string& what, const std::string& list) {
  std::vector<double> values;
  std::stringstream in(list);
  for (std::string item; std::getline(in, item, ',');) {
    const auto v = io::parseFiniteDouble(item);
    if (!v) {
      // Name the item; a NaN or infinity is described rather than echoed (reports never print nan).
      const double parsed = std::strtod(item.c_str(), nullptr);
      const bool nonFinite = !item.empty() && !std::isfinite(parsed);
      throw ConfigError(fmt::format("--sweep {}: {} is not a finite number", what,
                                    nonFinite ? fmt::format("value {} (not-a-number or infinite)", values.size() + 1)
                                              : fmt::format("'{}'", item)));
    }
    const double lo = what == "dt-factor" ? integrators::kMinStepsPerContact : 0.0;
    if (*v < lo)
      throw ConfigError(fmt::format("--sweep {}: {} is below the smallest allowed value {:g}", what, item, lo));
    values.push_back(*v);
  }
  if (values.empty() || list.empty() || list.back() == ',') {
    throw ConfigError(fmt::format("--sweep {}: give a comma-separated list of values, e.g. {}=10,20,50", what, what));
  }
  return values;
}

/// --sweep dt-factor=10,20,50 | skin=0.05,0.1: same scene (same start) per setting, same simulated time.
int runSweep(RelaxScene scene, const std::string& spec, bool quiet, const std::vector<std::filesystem::path>& inputs) {
  const std::size_t eq = spec.find('=');
  if (eq == std::string::npos) throw ConfigError(fmt::format("--sweep '{}': expected dt-factor=... or skin=...", spec));
  const std::string what = spec.substr(0, eq);
  if (what != "dt-factor" && what != "skin") {
    throw ConfigError(fmt::format("--sweep {}: only dt-factor and skin can be swept", what));
  }
  std::vector<double> values = sweepValues(what, spec.substr(eq + 1));
  if (what == "dt-factor" && scene.dem.timeStep > 0.0) throw ConfigError("--sweep dt-factor conflicts with run.dt");
  std::sort(values.begin(), values.end());
  const std::string stem = scene.source.stem().string();
  const std::string csvPath = fmt::format("{}_sweep_{}.csv", stem, what);
  const std::string png = fmt::format("{}_sweep_{}.png", stem, what);
  const std::string script = fmt::format("{}_sweep_{}.gp", stem, what);
  scene.timeseries.clear();
  scene.snapshot.clear();
  scene.finalState.clear();
  scene.checkpoint.clear();
  checkOutputs(scene, inputs, {{csvPath, "--sweep table"}, {png, "--sweep plot"}, {script, "--sweep plot script"}});

  Start start = prepare(scene);
  RunContext context;
  context.attributes = start.attributes;
  context.origin = start.origin;
  if (scene.compression) {
    integrators::SoftCompression c(std::move(start.particles), start.box, scene.dem, *scene.compression);
    compressStart(scene, c, start, context, quiet, false);
    if (start.interrupted) return kExitInterrupted;
    if (start.targetNotReached) {
      fmt::print("TARGET NOT REACHED: {}; no sweep run\n", *start.targetNotReached);
      return kExitTargetNotReached;
    }
  }
  setVelocities(scene, start);
  const double baseFactor = scene.dem.stepsPerContact;
  const std::int64_t baseSteps = scene.steps;
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
    Start copy = start;
    rows.push_back({v, s.steps,
                    runScene(s, integrators::DemSimulation(std::move(copy.particles), copy.box, s.dem), context, true,
                             true, false)});
    if (rows.back().run.interrupted) {
      fmt::print("sweep interrupted at {} = {:g}: no table written\n", what, v);
      return kExitInterrupted;
    }
  }
  // Error: energy drift for elastic scenes, else distance to the finest setting (largest dt factor).
  const bool elastic = scene.dem.contact.elastic() && scene.dem.viscousDamping == 0.0;
  const Row& finest = what == "dt-factor" ? rows.back() : rows.front();
  const double rmin = start.particles.radius().minCoeff();
  std::string table = what + ",steps,wall_seconds,us_per_particle_step,energy_error,position_error\n";
  fmt::print("\n{:>10} {:>10} {:>12} {:>18} {:>16} {:>16}\n", what, "steps", "wall s", "us/particle/step",
             elastic ? "energy drift" : "energy vs finest", "max |dx| / r_min");
  const double n = static_cast<double>(start.particles.count());
  for (const Row& r : rows) {
    const double scale = std::abs(elastic ? r.run.initialEnergy : finest.run.initialEnergy);
    const double diff = elastic ? std::abs(r.run.finalEnergy - r.run.initialEnergy)
                                : std::abs(r.run.finalEnergy - finest.run.finalEnergy);
    const std::optional<double> energyError =
        scale > 0.0 ? std::optional<double>(diff / scale) : (diff == 0.0 ? std::optional<double>(0.0) : std::nullopt);
    double positionError = 0.0;
    for (Index i = 0; i < r.run.positions.cols(); ++i) {
      positionError = std::max(positionError,
                               start.box.minimumImageAny(r.run.positions.col(i) - finest.run.positions.col(i)).norm());
    }
    positionError /= rmin;
    const double us = 1e6 * r.run.wallSeconds / (static_cast<double>(std::max<std::int64_t>(1, r.steps)) * n);
    const std::string energyText = energyError ? fmt::format("{:.4e}", *energyError) : std::string("undefined");
    fmt::print("{:>10g} {:>10} {:>12.3f} {:>18.4f} {:>16} {:>16.4e}\n", r.value, r.steps, r.run.wallSeconds, us,
               energyText, positionError);
    table += fmt::format("{},{},{:.6g},{:.6g},{},{:.6e}\n", r.value, r.steps, r.run.wallSeconds, us,
                         energyError ? fmt::format("{:.6e}", *energyError) : std::string(""), positionError);
  }
  io::writeFileAtomically(csvPath, table);
  fmt::print("table: {}\n", csvPath);
  if (what == "dt-factor" && std::system("command -v gnuplot > /dev/null 2>&1") == 0) {
    io::AtomicFile plot(png);
    std::string gp;
    gp += "set terminal pngcairo size 800,560\n";
    gp += "set output '" + plot.temporary().string() + "'\n";
    gp += "set datafile separator ','\n";
    gp += "set logscale xy\n";
    gp += "set xlabel 'wall time (s)'\n";
    gp += std::string("set ylabel '") + (elastic ? "relative energy drift" : "energy error vs finest dt") + "'\n";
    gp += "set title 'polydem relax: error against run time, labels = steps per contact'\n";
    gp += "set key off\n";
    gp += "plot '" + csvPath + "' every ::1 using 3:($5 > 0 ? $5 : 1/0) with linespoints pt 7, " +
          "'' every ::1 using 3:($5 > 0 ? $5 : 1/0):1 with labels offset 1.5,0.8\n";
    io::writeFileAtomically(script, gp);
    if (std::system(("gnuplot " + script).c_str()) == 0 && std::filesystem::exists(plot.temporary())) {
      plot.commit();
      fmt::print("plot: {}\n", png);
    }
  }
  return kExitOk;
}

std::string readText(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw InputError(fmt::format("{}: cannot open scene file", file.string()));
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

Runner addRelax(CLI::App& app) {
  auto opt = std::make_shared<RelaxOptions>();
  CLI::App* cmd = app.add_subcommand("relax", "soft-sphere DEM relaxation of a scene file (TOML)");
  cmd->add_option("scene", opt->scene, "scene file, e.g. examples/relax_uv10.toml");
  cmd->add_option("--resume", opt->resume,
                  "continue the run saved in this checkpoint (output.checkpoint); no scene file: the checkpoint "
                  "holds it. Allowed with it: --steps, --threads, -q, --set run.steps|run.threads|"
                  "run.progress_interval|output.*");
  cmd->add_flag("--print-defaults", opt->printDefaults, "print every scene key with its default (a TOML scene)");
  cmd->add_option("--set", opt->sets, "override a scene key, section.key=value (repeatable), e.g. --set contact.restitution=0.5")
      ->allow_extra_args(false);  // one value per --set, so the scene file is never swallowed
  cmd->add_option("--steps", opt->steps, "run.steps (total, counted from step 0)")->check(finiteIn(0, 9e18));
  cmd->add_option("--dt-factor", opt->dtFactor, "run.dt_factor: steps per shortest contact (>= 5)")
      ->check(finiteIn(integrators::kMinStepsPerContact, std::numeric_limits<double>::infinity()));
  cmd->add_option("--broadphase", opt->broadPhase, "run.broadphase: brute, linked-cell, hgrid-td, ..., auto");
  cmd->add_option("--skin", opt->skin, "run.skin: Verlet skin (m)")->check(finiteNonNegative());
  cmd->add_option("--kernel", opt->kernel, "run.kernel: specialised or general (for comparisons)");
  cmd->add_option("--threads", opt->threads, "run.threads: OpenMP threads for forces and kicks (1 = serial)")
      ->check(finiteIn(1, 1024));
  cmd->add_option("--sweep", opt->sweep, "dt-factor=10,20,50,100,200 or skin=...: error against wall time");
  cmd->add_flag("-q,--quiet", opt->quiet, "no progress lines");
  return [opt]() {
    if (opt->printDefaults) {
      fmt::print("{}", defaultSceneToml());
      return static_cast<int>(kExitOk);
    }
    std::vector<std::string> overrides = opt->sets;
    if (opt->steps) overrides.push_back(fmt::format("run.steps={}", *opt->steps));
    if (opt->dtFactor) overrides.push_back(fmt::format("run.dt_factor={:.17g}", *opt->dtFactor));
    if (opt->broadPhase) overrides.push_back(fmt::format("run.broadphase=\"{}\"", *opt->broadPhase));
    if (opt->skin) overrides.push_back(fmt::format("run.skin={:.17g}", *opt->skin));
    if (opt->kernel) overrides.push_back(fmt::format("run.kernel=\"{}\"", *opt->kernel));
    if (opt->threads) overrides.push_back(fmt::format("run.threads={}", *opt->threads));
    for (const std::string& o : overrides) {
      if (o.find('\n') != std::string::npos) throw ConfigError(fmt::format("--set '{}': no line breaks", o));
    }

    RunContext context;
    std::vector<std::filesystem::path> inputs;
    std::optional<io::Checkpoint> checkpoint;
    if (!opt->resume.empty()) {
      if (!opt->scene.empty()) {
        throw ConfigError(fmt::format("relax --resume {} takes no scene file ({}): the checkpoint holds the scene",
                                      opt->resume, opt->scene));
      }
      if (!opt->sweep.empty()) throw ConfigError("relax --resume cannot be combined with --sweep");
      for (const std::string& o : overrides) {
        if (!resumableKey(o)) {
          throw ConfigError(fmt::format(
              "relax --resume: '{}' would change the trajectory of the saved run; only run.steps (--steps), "
              "run.threads (--threads), run.progress_interval and output.* may be given",
              o));
        }
      }
      checkpoint = io::readCheckpoint(opt->resume, kCheckpointKind);
      context.sceneText = checkpoint->string("scene");
      context.sceneSource = checkpoint->string("scene_source");
      context.overrides = lines(checkpoint->string("overrides"));
      context.origin = checkpoint->string("origin");
      for (const std::string& line : lines(checkpoint->string("attributes"))) {
        const std::size_t tab = line.find('\t');
        if (tab != std::string::npos) context.attributes[line.substr(0, tab)] = line.substr(tab + 1);
      }
      // Later overrides win: the saved ones first, then this command line's.
      context.overrides.insert(context.overrides.end(), overrides.begin(), overrides.end());
      inputs.push_back(context.sceneSource);
    } else {
      if (opt->scene.empty()) throw ConfigError("relax: give a scene file (or --resume FILE.h5, --print-defaults)");
      context.sceneText = readText(opt->scene);
      context.sceneSource = opt->scene;
      context.overrides = overrides;
      inputs.push_back(opt->scene);
    }
    const RelaxScene scene = parseRelaxScene(context.sceneText, context.overrides, context.sceneSource);
    if (!scene.particleFile.empty()) inputs.push_back(scene.resolve(scene.particleFile));
    fmt::print("polydem relax {}\n", opt->resume.empty() ? opt->scene : "--resume " + opt->resume);
    installInterruptHandlers();
    if (!opt->sweep.empty()) return runSweep(scene, opt->sweep, opt->quiet, inputs);
    checkOutputs(scene, inputs);

    Start start;
    std::optional<integrators::SoftCompression> compression;
    if (checkpoint) {
      const integrators::DemState state = stateFrom(*checkpoint);
      if (checkpoint->string("phase") == "run") {
        if (scene.steps < state.step) {
          throw ConfigError(fmt::format("run.steps = {} is below the checkpoint's step {}: run.steps counts from "
                                        "step 0, give a larger total with --steps",
                                        scene.steps, state.step));
        }
        integrators::DemSettings settings = scene.dem;
        if (scene.initialVelocities == "impact") settings.impactOverlap = scene.impactOverlap;
        const RunSummary r = runScene(scene, integrators::DemSimulation::restore(state, settings), context,
                                      opt->quiet, false, true, std::nullopt);
        return static_cast<int>(r.interrupted ? kExitInterrupted : kExitOk);
      }
      if (checkpoint->string("phase") != "compression" || !scene.compression) {
        throw InputError(fmt::format("{}: checkpoint phase '{}' does not match its scene", opt->resume,
                                     checkpoint->string("phase")));
      }
      const integrators::CompressionProgress progress = compressionFrom(*checkpoint);
      compression.emplace(state, scene.dem, *scene.compression, progress);
      start.origin = context.origin;
      start.attributes = context.attributes;
      fmt::print("resumed the soft compression at step {}\n", progress.steps);
    } else {
      start = prepare(scene);
      context.attributes = start.attributes;
      context.origin = start.origin;
      if (scene.initialVelocities == "file" && scene.compression) {
        throw ConfigError("velocities.initial = \"file\" cannot follow [compression]");
      }
      if (scene.compression) compression.emplace(std::move(start.particles), start.box, scene.dem, *scene.compression);
    }
    if (compression) compressStart(scene, *compression, start, context, opt->quiet, true);
    if (start.targetNotReached) {
      // Not the state that was asked for: write what there is, marked, and do not run on it.
      fmt::print("TARGET NOT REACHED: {}\n", *start.targetNotReached);
      RelaxScene stop = scene;
      stop.steps = 0;
      stop.checkpoint.clear();  // an interrupted compression wrote its own; a finished one has nothing to resume
      if (start.interrupted && !scene.checkpoint.empty()) {
        context.checkpointNote = fmt::format("{} (soft compression, step {}): continue with polydem relax --resume {}",
                                             scene.checkpoint, compression->progress().steps, scene.checkpoint);
      } else if (!scene.checkpoint.empty()) {
        context.checkpointNote = "none written (a soft compression that ended short of its target is not resumed)";
      }
      runScene(stop, integrators::DemSimulation(std::move(start.particles), start.box, scene.dem), context,
               opt->quiet, false, false, start.targetNotReached);
      return static_cast<int>(start.interrupted ? kExitInterrupted : kExitTargetNotReached);
    }
    setVelocities(scene, start);
    integrators::DemSettings settings = scene.dem;
    if (scene.initialVelocities == "impact") settings.impactOverlap = scene.impactOverlap;
    RelaxScene running = scene;
    running.dem = settings;
    const RunSummary r = runScene(running, integrators::DemSimulation(std::move(start.particles), start.box, settings),
                                  context, opt->quiet, false, false);
    return static_cast<int>(r.interrupted ? kExitInterrupted : kExitOk);
  };
}

}  // namespace polydem::app
