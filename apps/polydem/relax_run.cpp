// polydem relax: the time loop and its outputs (time series, snapshots, checkpoints, final state).
// Outputs are written atomically (io::AtomicFile) except the time series, whose rows are flushed every
// few seconds; a resumed run keeps the rows up to its checkpoint and appends.
#include <fmt/format.h>

#include <algorithm>
#include <fstream>
#include <numeric>
#include <sstream>

#include "apps/polydem/common.hpp"
#include "apps/polydem/relax.hpp"
#include "broadphase/registry.hpp"
#include "core/errors.hpp"
#include "core/interrupt.hpp"
#include "core/io/attributes.hpp"
#include "core/io/hdf5_snapshot.hpp"
#include "core/io/safe_output.hpp"
#include "core/io/xdmf.hpp"
#include "polydem/config.hpp"

namespace polydem::app {

namespace {

/// Slots in ascending stored id: the order of every written particle file.
std::vector<Index> idOrder(const ParticleStore& p) {
  std::vector<Index> order(static_cast<std::size_t>(p.count()));
  std::iota(order.begin(), order.end(), Index{0});
  std::sort(order.begin(), order.end(), [&](Index a, Index b) { return p.id()[a] < p.id()[b]; });
  return order;
}

}  // namespace

io::ParticleData snapshotOf(const integrators::DemSimulation& sim, const std::map<std::string, std::string>& attrs) {
  const ParticleStore& p = sim.particles();
  const Index n = p.count();
  const std::vector<Index> order = idOrder(p);
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

namespace {

/// The optional arrays `names` (output.arrays) of the snapshot `d` (id order, as snapshotOf()).
/// Computed here, at snapshot time only: contact_count and max_overlap (m) count particle pairs that
/// overlap (walls not included), found with a linked-cell pass over the snapshot (brute force where the
/// box is too small for cells); kinetic_energy is translational + rotational (J).
void addSnapshotArrays(io::ParticleData& d, const integrators::DemSimulation& sim,
                       const std::vector<std::string>& names) {
  if (names.empty()) return;
  const ParticleStore& p = sim.particles();
  const Index n = p.count();
  const std::vector<Index> order = idOrder(p);
  const bool rotation = p.features().rotation;
  for (const std::string& name : names) {
    io::ParticleArray a{name, Eigen::MatrixXd()};
    if (name == "force" || name == "torque") {
      a.values = Eigen::MatrixXd::Zero(3, n);
      if (name == "force" || rotation) {
        for (Index k = 0; k < n; ++k) {
          const Index i = order[std::size_t(k)];
          a.values.col(k) = name == "force" ? p.force().col(i) : p.torque().col(i);
        }
      }
    } else if (name == "angular_velocity") {
      // Stored as the built-in dataset; zeros when the run has no rotation.
      if (!d.angularVelocity) d.angularVelocity = Eigen::Matrix3Xd::Zero(3, n);
      continue;
    } else if (name == "kinetic_energy") {
      a.values = Eigen::MatrixXd::Zero(1, n);
      for (Index k = 0; k < n; ++k) {
        const Index i = order[std::size_t(k)];
        double e = 0.5 * p.velocity().col(i).squaredNorm() / p.inverseMass()[i];
        if (rotation) e += 0.5 * p.angularVelocity().col(i).squaredNorm() / p.inverseInertia()[i];
        a.values(0, k) = e;
      }
    } else {  // contact_count, max_overlap
      a.values = Eigen::MatrixXd::Zero(1, n);
      const SphereView spheres{d.position, d.radius};
      std::vector<broadphase::Pair> pairs;
      std::unique_ptr<broadphase::BroadPhase> bp = broadphase::makeBroadPhase("linked-cell");
      try {
        bp->build(spheres, d.box, 0.0);
      } catch (const ConfigError&) {
        bp = broadphase::makeBroadPhase("brute");
        bp->build(spheres, d.box, 0.0);
      }
      bp->findPairs(spheres, pairs);
      for (const broadphase::Pair& pair : pairs) {
        const double gap = d.box.minimumImage(d.position.col(pair.i) - d.position.col(pair.j)).norm() -
                           (d.radius[pair.i] + d.radius[pair.j]);
        if (gap >= 0.0) continue;
        if (name == "contact_count") {
          a.values(0, pair.i) += 1.0;
          a.values(0, pair.j) += 1.0;
        } else {
          a.values(0, pair.i) = std::max(a.values(0, pair.i), -gap);
          a.values(0, pair.j) = std::max(a.values(0, pair.j), -gap);
        }
      }
    }
    d.arrays.push_back(std::move(a));
  }
}

std::string withStep(const std::string& pattern, std::int64_t step) {
  std::string out = pattern;
  const std::size_t at = out.find("{step}");
  if (at != std::string::npos) out.replace(at, 6, fmt::format("{:09d}", step));
  return out;
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

/// output.timeseries: energies and contacts every output.timeseries_interval steps (CSV).
class TimeSeries {
 public:
  TimeSeries(const RelaxScene& scene, const integrators::DemSimulation& sim, bool resumed) {
    if (scene.timeseries.empty()) return;
    const bool append = resumed && std::filesystem::exists(scene.timeseries);
    if (append) truncateTimeSeries(scene.timeseries, sim.step());
    csv_.open(scene.timeseries, append ? std::ios::app : std::ios::trunc);
    if (!csv_) throw InputError(fmt::format("{}: cannot write the time series", scene.timeseries));
    if (!append) {
      csv_ << "step,time,kinetic,rotational,elastic,potential,total,contacts,wall_contacts,contacts_per_particle,"
              "max_overlap_ratio,rebuilds\n";
    }
  }
  bool enabled() const { return csv_.is_open(); }
  void write(const integrators::DemSimulation& sim) {
    const integrators::Energies e = sim.energies();
    const contact::ContactStats c = sim.contactStats();
    const Index n = sim.particles().count();
    csv_ << fmt::format("{},{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},{:.12g},{},{},{:.6g},{:.6g},{}\n", sim.step(),
                        sim.time(), e.kinetic, e.rotational, e.elastic, e.potential, e.total(), c.contacts,
                        c.wallContacts, 2.0 * static_cast<double>(c.contacts) / n, c.maxOverlapRatio, sim.rebuilds());
    flush_(csv_);
  }
  void flush() {
    if (csv_.is_open()) csv_.flush();
  }

 private:
  std::ofstream csv_;
  io::PeriodicFlush flush_;
};

/// Snapshots and checkpoints of the time loop, and the wall clock that times the loop and the
/// timed checkpoints.
class LoopOutputs {
 public:
  LoopOutputs(const RelaxScene& scene, const RunContext& run, std::map<std::string, std::string> attributes)
      : scene_(scene), run_(run), attributes_(std::move(attributes)) {}
  bool snapshots() const { return !scene_.snapshot.empty() && scene_.snapshotInterval > 0; }
  bool checkpoints() const { return !scene_.checkpoint.empty(); }
  /// A resumed run's series starts with the snapshots the first run left on disk up to `step`.
  void resumeSeries(std::int64_t step) {
    if (!hdf5Snapshots()) return;
    const std::int64_t interval = std::max<std::int64_t>(scene_.snapshotInterval, 1);
    for (std::int64_t s = 0; s <= step; s += interval) {
      const std::filesystem::path file = withStep(scene_.snapshot, s);
      if (std::filesystem::exists(file)) frames_.push_back(io::xdmfFrameOf(file, io::readSnapshot(file)));
      if (scene_.snapshot.find("{step}") == std::string::npos) break;
    }
  }
  /// The snapshot of this step, and for HDF5 snapshots the temporal series file rewritten with it.
  void writeSnapshot(const integrators::DemSimulation& sim) {
    const std::string file = withStep(scene_.snapshot, sim.step());
    io::ParticleData data = snapshotOf(sim, attributes_);
    addSnapshotArrays(data, sim, scene_.snapshotArrays);
    io::writeParticles(file, data);
    if (!hdf5Snapshots()) return;
    // One pattern without {step} rewrites one file: its series holds one frame.
    if (scene_.snapshot.find("{step}") == std::string::npos) frames_.clear();
    frames_.push_back(io::xdmfFrameOf(file, data));
    io::writeXdmfSeries(io::seriesPathFor(scene_.snapshot), frames_);
  }
  void writeCheckpoint(const integrators::DemSimulation& sim) {
    io::writeCheckpoint(scene_.checkpoint, makeCheckpoint(sim, run_));
    lastCheckpoint_ = clock_.seconds();
  }
  /// Timed checkpoints read the state; they never change it, so wall time cannot reach the trajectory.
  bool checkpointDue(std::int64_t step) const {
    const bool byStep = scene_.checkpointInterval > 0 && step % scene_.checkpointInterval == 0;
    const bool byTime =
        scene_.checkpointSeconds > 0.0 && clock_.seconds() - lastCheckpoint_ >= scene_.checkpointSeconds;
    return byStep || byTime;
  }
  void writeFinal(const integrators::DemSimulation& sim) const {
    io::writeParticles(scene_.finalState, snapshotOf(sim, attributes_));
  }
  double seconds() const { return clock_.seconds(); }

 private:
  const RelaxScene& scene_;
  const RunContext& run_;
  std::map<std::string, std::string> attributes_;
  bool hdf5Snapshots() const { return !scene_.snapshot.empty() && io::isHdf5Path(scene_.snapshot); }

  Stopwatch clock_;
  double lastCheckpoint_ = 0.0;
  std::vector<io::XdmfFrame> frames_;  ///< the snapshots of the series file, in step order
};

void printProgress(const integrators::DemSimulation& sim, std::int64_t step, std::int64_t total, std::int64_t firstStep,
                   double loopSeconds) {
  const double n = static_cast<double>(sim.particles().count());
  const double done = static_cast<double>(step - firstStep);
  const double rate = done / std::max(loopSeconds, 1e-9);
  fmt::print(stderr, "  step {:>10} / {} ({:4.1f}%)  {:.0f} steps/s  {:.3f} us/particle/step  ETA {:.0f} s\n", step,
             total, 100.0 * static_cast<double>(step) / static_cast<double>(total), rate,
             1e6 * loopSeconds / (std::max(done, 1.0) * n), static_cast<double>(total - step) / rate);
}

/// Advance to scene.steps in chunks that end on every output interval, writing the outputs due at each
/// chunk's end; stops early at an interrupt (after a complete step). With a driver (several MPI ranks) the
/// steps run there and `sim` is brought up to date only when something reads it.
LoopTiming timeLoop(const RelaxScene& scene, integrators::DemSimulation& sim, TimeSeries& series, LoopOutputs& out,
                    bool quiet, StepDriver* driver) {
  LoopTiming timing;
  double lastProgress = 0.0;
  const std::int64_t total = scene.steps;
  const std::int64_t firstStep = sim.step();
  std::int64_t step = firstStep;
  bool interrupted = interruptRequested();
  auto boundary = [&](std::int64_t interval) { return (step / interval + 1) * interval; };
  while (step < total && !interrupted) {
    std::int64_t next = std::min(total, step + 200);
    if (series.enabled()) next = std::min(next, boundary(scene.timeseriesInterval));
    if (out.snapshots()) next = std::min(next, boundary(scene.snapshotInterval));
    if (out.checkpoints() && scene.checkpointInterval > 0) next = std::min(next, boundary(scene.checkpointInterval));
    const double before = out.seconds();
    if (driver) {
      step = driver->advance(next - step);
      interrupted = driver->interrupted();
    } else {
      sim.advance(next - step, true);
      step = sim.step();
      interrupted = interruptRequested();
    }
    timing.loopSeconds += out.seconds() - before;
    const bool seriesDue = series.enabled() && step % scene.timeseriesInterval == 0;
    const bool snapshotDue = !interrupted && out.snapshots() && step % scene.snapshotInterval == 0;
    const bool checkpointDue = !interrupted && out.checkpoints() && step < total && out.checkpointDue(step);
    if (driver && (seriesDue || snapshotDue || checkpointDue || interrupted || step >= total)) driver->sync(sim);
    if (seriesDue) series.write(sim);
    if (interrupted) break;
    if (snapshotDue) out.writeSnapshot(sim);
    if (checkpointDue) out.writeCheckpoint(sim);
    const double now = out.seconds();
    if (!quiet && scene.progressInterval > 0.0 && now - lastProgress >= scene.progressInterval && step < total) {
      lastProgress = now;
      printProgress(sim, step, total, firstStep, timing.loopSeconds);
    }
  }
  timing.stepsRun = step - firstStep;
  timing.totalSteps = total;
  timing.interrupted = interrupted;
  return timing;
}

}  // namespace

void checkOutputs(const RelaxScene& scene, const std::vector<std::filesystem::path>& inputs,
                  const std::vector<std::pair<std::filesystem::path, std::string>>& extra) {
  if (!scene.checkpoint.empty() && !POLYDEM_WITH_HDF5) {
    throw ConfigError(
        fmt::format("output.checkpoint = \"{}\": checkpoints are HDF5 files, and this polydem was "
                    "built with POLYDEM_WITH_HDF5=OFF",
                    scene.checkpoint));
  }
  std::vector<std::pair<std::filesystem::path, std::string>> outputs = extra;
  if (!scene.finalState.empty()) outputs.emplace_back(scene.finalState, "output.final");
  if (!scene.timeseries.empty()) outputs.emplace_back(scene.timeseries, "output.timeseries");
  if (!scene.snapshot.empty()) outputs.emplace_back(withStep(scene.snapshot, 0), "output.snapshot");
  if (!scene.snapshot.empty() && io::isHdf5Path(scene.snapshot)) {
    outputs.emplace_back(io::seriesPathFor(scene.snapshot), "output.snapshot (its series file)");
  }
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

RunSummary runScene(const RelaxScene& scene, integrators::DemSimulation sim, const RunContext& run,
                    const RunMode& mode) {
  StepDriver* driver = mode.driver;
  if (driver && !driver->root()) return driver->serve();
  if (!mode.brief) printStart(scene, sim, run, mode.resumed);
  if (driver && !mode.brief) driver->printStart();
  std::map<std::string, std::string> attributes = run.attributes;
  if (mode.targetNotReached) attributes["target_not_reached"] = *mode.targetNotReached;

  TimeSeries series(scene, sim, mode.resumed);
  LoopOutputs out(scene, run, std::move(attributes));
  if (mode.resumed) out.resumeSeries(sim.step());
  if (!mode.resumed) {
    if (series.enabled()) series.write(sim);
    if (out.snapshots()) out.writeSnapshot(sim);
  }
  const LoopTiming timing = timeLoop(scene, sim, series, out, mode.quiet, driver);
  if (driver) driver->finish();
  series.flush();
  // The checks run once at the end whatever run.check_interval says (0 included): no state is written
  // as a result without having passed them.
  if (!timing.interrupted) sim.checkStability();
  if (out.checkpoints()) out.writeCheckpoint(sim);
  if (!scene.finalState.empty()) out.writeFinal(sim);
  if (!timing.interrupted && !scene.snapshot.empty() &&
      (scene.snapshotInterval == 0 || sim.step() % scene.snapshotInterval != 0)) {
    out.writeSnapshot(sim);
  }

  const integrators::Energies e = sim.energies();
  RunSummary summary{timing.loopSeconds, e.total(), sim.initialEnergy(), {}, timing.interrupted};
  const ParticleStore& p = sim.particles();
  const std::vector<Index> order = idOrder(p);
  summary.positions.resize(3, p.count());
  for (Index k = 0; k < p.count(); ++k) summary.positions.col(k) = p.position().col(order[static_cast<std::size_t>(k)]);
  if (!mode.brief) printReport(scene, sim, run, timing, mode.targetNotReached);
  if (driver && !mode.brief) driver->printReport();
  return summary;
}

}  // namespace polydem::app
