// polydem relax: the time loop and its outputs (time series, snapshots, checkpoints, final state).
// Outputs are written atomically (io::AtomicFile) except the time series, whose rows are flushed every
// few seconds; a resumed run keeps the rows up to its checkpoint and appends.
//
// Contact files (output.contacts) and the arrays rattler and size_class: contactsOf() and the functions
// after it. Contact forces are evaluated from the snapshot's state with the run's contact law: positions,
// the synchronised velocities v(t) and angular velocities, and the tangential spring histories as the last
// step left them. The spring part of every force is therefore the one the integrator used; the dashpot
// part uses v(t), whereas the step used the predicted velocity v(t + dt/2) + dt/2 F(t)/m (or v(t + dt/2)
// with run.dashpot_velocity = "half-step"), a difference of order c dt F/m per contact. Without dashpots
// (restitution 1, no tangential damping) the contact forces on a particle sum to its force array to
// round-off (minus gravity, viscous damping and walls). Candidates are the Verlet list's pairs (every
// touching pair is in it); a pair is in contact when |d|^2 < (r_i + r_j)^2, the kernel's own test.
#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
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
#include "jamming/contact_network.hpp"
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

using Vec3 = Eigen::Vector3d;

/// The run's normal law at one contact (the kernel's choice, contact/force_kernel_select.cpp).
contact::NormalForce normalForce(const contact::ContactModel& model, double overlap, double rate, double meff,
                                 double reff) {
  const contact::ContactParameters& p = model.parameters();
  if (p.normal == contact::NormalModel::Hertz) {
    return contact::HertzNormal::force(model.hertzParams(), overlap, rate, meff, reff);
  }
  if (p.damping == contact::DampingModel::MassVelocity) {
    return contact::LinearMassVelocityNormal::force(model.massVelocityParams(), overlap, rate, meff, reff);
  }
  return contact::LinearNormal::force(model.linearParams(), overlap, rate, meff, reff);
}

}  // namespace

io::ContactData contactsOf(const integrators::DemSimulation& sim, const std::map<std::string, std::string>& attrs) {
  const ParticleStore& p = sim.particles();
  const Box& box = sim.box();
  const contact::ContactModel& model = sim.model();
  const contact::ContactParameters& law = model.parameters();
  const contact::ContactList& list = sim.neighbours().list();
  const contact::ContactHistory& history = sim.pairHistory();
  const bool friction = law.usesFriction() && history.width() >= 3 && p.features().rotation;
  const bool lammps = law.tangential == contact::TangentialModel::LammpsHistory;
  const bool mindlin = law.tangential == contact::TangentialModel::HertzMindlin;

  struct Row {
    Index idI, idJ;
    Vec3 centre, branch, ft;
    double overlap, fn;
  };
  std::vector<Row> rows;
  const Index n = p.count();
  for (Index i = 0; i < n && i + 1 < static_cast<Index>(list.offset.size()); ++i) {
    for (Index c = list.offset[std::size_t(i)]; c < list.offset[std::size_t(i) + 1]; ++c) {
      const Index j = list.neighbour[std::size_t(c)];
      const Vec3 d = box.minimumImage(p.position().col(i) - p.position().col(j));  // from j to i
      const double sumR = p.radius()[i] + p.radius()[j];
      if (d.squaredNorm() >= sumR * sumR) continue;
      const double dist = d.norm();
      const Vec3 nrm = d / dist;
      const double overlap = sumR - dist;
      const double meff = 1.0 / (p.inverseMass()[i] + p.inverseMass()[j]);
      const double reff = p.radius()[i] * p.radius()[j] / sumR;
      const Vec3 vrel = p.velocity().col(i) - p.velocity().col(j);
      const contact::NormalForce nf = normalForce(model, overlap, -vrel.dot(nrm), meff, reff);
      Vec3 ft = Vec3::Zero();
      if (friction) {
        const double ai = lammps ? p.radius()[i] : p.radius()[i] - 0.5 * overlap;
        const double aj = lammps ? p.radius()[j] : p.radius()[j] - 0.5 * overlap;
        const Vec3 vc = vrel - (ai * p.angularVelocity().col(i) + aj * p.angularVelocity().col(j)).cross(nrm);
        const Vec3 vt = vc - vc.dot(nrm) * nrm;
        const double* xi = history.values(static_cast<std::size_t>(c));
        const Vec3 spring(xi[0], xi[1], xi[2]);
        const double ct = law.tangentialDampingRatio * nf.damping;
        // Hertz-Mindlin stores the spring force itself; Cundall-Strack and LAMMPS's variant the displacement
        // xi, whose force is -k_t xi (also after a Coulomb cap, which resets xi to match the capped force).
        ft = mindlin ? Vec3(spring - ct * vt) : Vec3(-law.tangentialStiffnessRatio * nf.stiffness * spring - ct * vt);
      }
      Row row{p.id()[std::size_t(i)], p.id()[std::size_t(j)], box.wrap(p.position().col(i)), -d, ft, overlap, nf.force};
      if (row.idI > row.idJ) {  // rows name the smaller id first: the forces and the branch turn round
        std::swap(row.idI, row.idJ);
        row.centre = box.wrap(p.position().col(j));
        row.branch = d;
        row.ft = -ft;
      }
      rows.push_back(row);
    }
  }
  std::sort(rows.begin(), rows.end(),
            [](const Row& a, const Row& b) { return a.idI != b.idI ? a.idI < b.idI : a.idJ < b.idJ; });

  io::ContactData out;
  out.box = box;
  out.time = sim.time();
  out.attributes = attrs;
  out.attributes["step"] = std::to_string(sim.step());
  out.attributes["time"] = fmt::format("{:.17g}", sim.time());
  out.attributes["contact"] = law.describe();
  const auto m = static_cast<Index>(rows.size());
  out.idI.resize(rows.size());
  out.idJ.resize(rows.size());
  out.centre.resize(3, m);
  out.branch.resize(3, m);
  out.overlap.resize(m);
  out.normalForce.resize(m);
  if (friction) out.tangentialForce = Eigen::Matrix3Xd(3, m);
  for (Index k = 0; k < m; ++k) {
    const Row& r = rows[std::size_t(k)];
    out.idI[std::size_t(k)] = r.idI;
    out.idJ[std::size_t(k)] = r.idJ;
    out.centre.col(k) = r.centre;
    out.branch.col(k) = r.branch;
    out.overlap[k] = r.overlap;
    out.normalForce[k] = r.fn;
    if (friction) out.tangentialForce->col(k) = r.ft;
  }
  return out;
}

Eigen::VectorXd rattlerFlags(const io::ParticleData& d) {
  jamming::ContactOptions options;
  options.relativeGap = 0.0;  // in contact: touching or overlapping
  options.minContacts = 4;    // d + 1
  const SphereView spheres{d.position, d.radius};
  jamming::ContactNetwork net;
  try {
    options.broadPhase = "linked-cell";
    net = jamming::analyseContacts(spheres, d.box, options);
  } catch (const ConfigError&) {  // a box too small for cells
    options.broadPhase = "brute";
    net = jamming::analyseContacts(spheres, d.box, options);
  }
  Eigen::VectorXd flags(d.count());
  for (Index k = 0; k < d.count(); ++k) flags[k] = net.rattler[std::size_t(k)] ? 1.0 : 0.0;
  return flags;
}

SizeClasses sizeClasses(const Eigen::VectorXd& radius) {
  SizeClasses out;
  const Index n = static_cast<Index>(radius.size());
  out.values = Eigen::VectorXd::Zero(n);
  if (n == 0) {
    out.rule = "component index (no particles)";
    return out;
  }
  std::vector<double> sorted(radius.data(), radius.data() + n);
  std::sort(sorted.begin(), sorted.end());
  // Components: runs of sorted radii that agree to 1e-12 relative (a uniform growth keeps equal radii equal).
  std::vector<double> components{sorted.front()};
  for (std::size_t k = 1; k < sorted.size(); ++k) {
    if (sorted[k] > sorted[k - 1] * (1.0 + 1e-12)) components.push_back(sorted[k]);
  }
  const double rmin = sorted.front();
  if (static_cast<int>(components.size()) <= kMaxSizeComponents) {
    out.discrete = true;
    out.rule = fmt::format("component index among {} distinct radii, ascending from 0", components.size());
    for (Index i = 0; i < n; ++i) {
      const auto it = std::upper_bound(components.begin(), components.end(), radius[i] * (1.0 + 1e-12));
      out.values[i] = static_cast<double>(std::distance(components.begin(), it) - 1);
    }
    return out;
  }
  out.rule = fmt::format("floor(log2(r / r_min)), r_min = {:.17g} m", rmin);
  for (Index i = 0; i < n; ++i) {
    // Guard against log2 of an exact power of two rounding down (r = 2 r_min must be class 1).
    double k = std::floor(std::log2(radius[i] / rmin));
    if (rmin * std::exp2(k + 1.0) <= radius[i]) k += 1.0;
    if (k > 0.0 && rmin * std::exp2(k) > radius[i]) k -= 1.0;
    out.values[i] = std::max(k, 0.0);
  }
  return out;
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
    } else if (name == "rattler") {
      a.values = rattlerFlags(d).transpose();
    } else if (name == "size_class") {
      const SizeClasses classes = sizeClasses(d.radius);
      a.values = classes.values.transpose();
      d.attributes["size_class"] = classes.rule;
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
  /// A resumed run's series starts with the snapshots (and contact files) the first run left on disk up
  /// to `step`.
  void resumeSeries(std::int64_t step) {
    if (!hdf5Snapshots()) return;
    const std::int64_t interval = std::max<std::int64_t>(scene_.snapshotInterval, 1);
    for (std::int64_t s = 0; s <= step; s += interval) {
      const std::filesystem::path file = withStep(scene_.snapshot, s);
      if (std::filesystem::exists(file)) frames_.push_back(io::xdmfFrameOf(file, io::readSnapshot(file)));
      const std::filesystem::path contacts = io::contactPathFor(file);
      if (scene_.contacts && std::filesystem::exists(contacts)) {
        contactFrames_.push_back(io::xdmfContactFrameOf(contacts, io::readContacts(contacts)));
      }
      if (scene_.snapshot.find("{step}") == std::string::npos) break;
    }
  }
  /// The snapshot of this step and its contact file (output.contacts), and for HDF5 snapshots the
  /// temporal series files rewritten with them.
  void writeSnapshot(const integrators::DemSimulation& sim) {
    const std::string file = withStep(scene_.snapshot, sim.step());
    io::ParticleData data = snapshotOf(sim, attributes_);
    addSnapshotArrays(data, sim, scene_.snapshotArrays);
    io::writeParticles(file, data);
    // One pattern without {step} rewrites one file: its series holds one frame.
    const bool oneFile = scene_.snapshot.find("{step}") == std::string::npos;
    if (hdf5Snapshots()) {
      if (oneFile) frames_.clear();
      frames_.push_back(io::xdmfFrameOf(file, data));
      io::writeXdmfSeries(io::seriesPathFor(scene_.snapshot), frames_);
    }
    if (!scene_.contacts) return;
    const std::filesystem::path contactFile = io::contactPathFor(file);
    io::ContactData contacts = contactsOf(sim, attributes_);
    contacts.attributes["snapshot"] = std::filesystem::path(file).filename().string();
    io::writeContacts(contactFile, contacts);
    if (hdf5Snapshots()) {
      if (oneFile) contactFrames_.clear();
      contactFrames_.push_back(io::xdmfContactFrameOf(contactFile, contacts));
      io::writeXdmfContactSeries(io::contactSeriesPathFor(scene_.snapshot), contactFrames_);
    }
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
  std::vector<io::XdmfFrame> frames_;                ///< the snapshots of the series file, in step order
  std::vector<io::XdmfContactFrame> contactFrames_;  ///< the contact files of the contact series
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
  if (scene.contacts && !scene.snapshot.empty()) {
    outputs.emplace_back(io::contactPathFor(withStep(scene.snapshot, 0)), "output.contacts (the contact file)");
    if (io::isHdf5Path(scene.snapshot)) {
      outputs.emplace_back(io::contactSeriesPathFor(scene.snapshot), "output.contacts (its series file)");
    }
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
  const std::int64_t resortsBefore = sim.resorts();
  LoopTiming timing = timeLoop(scene, sim, series, out, mode.quiet, driver);
  if (driver) driver->finish();
  timing.resorts = driver ? driver->resorts() : sim.resorts() - resortsBefore;
  if (driver) timing.rankPhases = driver->phaseTimes();
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
