// The jamming tests and structure analyses of `polydem analyze` as functions returning dicts and arrays:
// certify (--certify: the ideal-contact LP test and the load test), leak_test (--leak-test) and structure
// (--order, --channels-csv, --sk-csv, --velocity-rattlers). They call the libraries the CLI calls
// (jamming/, structure/) on the contact network of the CLI's own computeContacts, and their dicts use the
// keys of the CLI's --summary-json groups (certify.*, leak_test.*, delaunay.*, bond_order.*, channels.*,
// structure_factor.*, velocity_rattlers.*), so the numbers can be compared key by key. What the CLI writes
// as CSV (the load test's motion, the channel histogram, S(k)) is returned as numpy arrays.
#include <fmt/format.h>
#include <pybind11/functional.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <chrono>
#include <cmath>
#include <optional>

#include "apps/polydem/analyze.hpp"
#include "core/errors.hpp"
#include "jamming/ideal_contacts.hpp"
#include "jamming/load_protocols.hpp"
#include "jamming/pressure_leak.hpp"
#include "python/convert.hpp"
#include "python/io.hpp"
#include "structure/bond_order.hpp"
#include "structure/channel_size.hpp"
#include "structure/delaunay_neighbours.hpp"
#include "structure/rattlers.hpp"
#include "structure/structure_factor.hpp"

namespace polydem::python {

namespace {

using ProgressLine = std::function<void(const std::string&)>;

void requirePositive(const char* name, double value) {
  if (!(std::isfinite(value) && value > 0.0)) {
    throw ConfigError(fmt::format("{}: {} must be a finite number > 0", name, value));
  }
}

void requireRange(const char* name, std::int64_t value, std::int64_t lo, std::int64_t hi) {
  if (value < lo || value > hi) throw ConfigError(fmt::format("{}: {} is outside [{}, {}]", name, value, lo, hi));
}

/// The sphere to take out (None: -1), checked against the packing's size as the CLI checks --remove.
Index removedSphere(const std::optional<Index>& remove, Index n) {
  if (!remove) return -1;
  if (*remove < 0) throw ConfigError(fmt::format("remove {}: a sphere index is >= 0", *remove));
  if (*remove >= n) {
    throw ConfigError(n == 0 ? fmt::format("remove {}: the packing has no spheres", *remove)
                             : fmt::format("remove {}: the packing has {} spheres (indices 0..{})", *remove, n, n - 1));
  }
  return *remove;
}

/// The contact network a jamming test rests on, found as `polydem analyze` finds it (GIL released).
app::analyze::ContactAnalysis contactsOf(const io::ParticleData& data, const std::string& name, double pressure,
                                         double contactGap, const std::string& broadPhase) {
  app::analyze::AnalyzeOptions opt;
  opt.input = name;
  opt.pressure = pressure;
  opt.contactGap = contactGap;
  opt.broadPhase = broadPhase;
  py::gil_scoped_release release;
  return app::analyze::computeContacts(opt, data);
}

/// A progress callback for library code running without the GIL: the first exception it raises is kept
/// (later lines are dropped) and rethrown by rethrow() once the call has returned.
class Relay {
 public:
  explicit Relay(ProgressLine callback) : callback_(std::move(callback)) {}
  ProgressLine line() {
    if (!callback_) return {};
    return [this](const std::string& text) {
      if (failure_) return;
      py::gil_scoped_acquire acquire;
      try {
        callback_(text);
      } catch (py::error_already_set& e) {
        failure_.emplace(std::move(e));
      }
    };
  }
  void rethrow() {
    if (failure_) throw std::move(*failure_);
  }

 private:
  ProgressLine callback_;
  std::optional<py::error_already_set> failure_;
};

py::object noneIfEmpty(const Eigen::Matrix3Xd& m, Index n) {
  return m.cols() == n && n > 0 ? py::object(copyOut(m)) : py::object(py::none());
}

py::dict certify(const py::object& packing, double pressure, double contactGap, const std::string& broadPhase,
                 const std::optional<Index>& remove, bool ideal, const std::string& loadTest, double loadGap, int loads,
                 double displacementLimit, double beta, double maxLimit, double meanLimit, int maxSteps,
                 const std::string& lpSolver, int subpackingRounds, bool strict, bool localRattlers,
                 const ProgressLine& progress) {
  // The option checks of `analyze --certify`, before any work.
  if (loadTest != "sequential" && loadTest != "single") {
    throw ConfigError(fmt::format("load_test '{}': expected sequential or single", loadTest));
  }
  if (lpSolver != "auto" && lpSolver != "simplex" && lpSolver != "interior") {
    throw ConfigError(fmt::format("lp_solver '{}': expected auto, simplex or interior", lpSolver));
  }
  requirePositive("load_gap", loadGap);
  requirePositive("displacement_limit", displacementLimit);
  requirePositive("beta", beta);
  requirePositive("max_limit", maxLimit);
  requirePositive("mean_limit", meanLimit);
  requireRange("loads", loads, 1, 1000000);
  requireRange("max_steps", maxSteps, 1, 1000);
  requireRange("subpacking_rounds", subpackingRounds, 1, 100);
  if (strict && loadTest != "single") {
    throw ConfigError("strict needs load_test='single' (the sequential test keeps the cell fixed)");
  }
  if (ideal && !jamming::jammingTestAvailable()) {
    throw ConfigError(
        "certify: the ideal-contact LP test needs GLPK (libglpk-dev), which this build did not find; give "
        "ideal=False to run the load test alone");
  }
  std::string name;
  const io::ParticleData data = particlesFrom(packing, name);
  const Index n = data.count();
  const Index removed = removedSphere(remove, n);
  const app::analyze::ContactAnalysis contacts = contactsOf(data, name, pressure, contactGap, broadPhase);

  jamming::LoadTestOptions lo;
  lo.gapTolerance = loadGap;
  lo.displacementLimit = displacementLimit;
  lo.loads = loads;
  lo.subpackingRounds = subpackingRounds;
  lo.protocol = loadTest == "sequential" ? jamming::LoadProtocol::Sequential : jamming::LoadProtocol::SingleLp;
  lo.beta = beta;
  lo.maxLimit = maxLimit;
  lo.meanLimit = meanLimit;
  lo.maxSteps = maxSteps;
  lo.localRattlers = localRattlers;
  lo.strict = strict;
  lo.solver = lpSolver == "simplex"    ? jamming::LpSolver::Simplex
              : lpSolver == "interior" ? jamming::LpSolver::InteriorPoint
                                       : jamming::LpSolver::Automatic;
  if (removed >= 0) lo.removed.push_back(removed);
  Relay relay(progress);
  lo.progress = relay.line();

  // As certifyJamming: the removed sphere leaves the test, the rattlers stay those of the intact packing.
  jamming::ContactNetwork tested = contacts.net;
  if (removed >= 0) tested.rattler[static_cast<std::size_t>(removed)] = 1;
  const SphereView spheres{data.position, data.radius};
  std::optional<jamming::JammingTestResult> idealResult;
  jamming::LoadTestResult load;
  {
    py::gil_scoped_release release;
    if (ideal) idealResult = jamming::testCollectiveJamming(spheres, data.box, tested);
    load = jamming::testJammingUnderLoad(spheres, data.box, tested, lo);
  }
  relay.rethrow();

  py::dict out;
  out["removed_sphere"] = removed >= 0 ? py::object(py::int_(removed)) : py::object(py::none());
  if (idealResult) {
    const jamming::JammingTestResult& r = *idealResult;
    py::dict d;
    d["outcome"] = std::string(jamming::verdictName(r.outcome));
    d["verdict"] = r.verdict;
    d["lps_solved"] = r.lps;
    d["opening_objective"] = r.lps > 0 ? py::object(py::float_(r.openingObjective)) : py::object(py::none());
    d["floppy_objective"] = r.lps > 0 ? py::object(py::float_(r.floppyObjective)) : py::object(py::none());
    d["seconds"] = r.seconds;
    d["jammed"] = r.jammed;
    d["contacts_opened"] = r.contactsOpened;
    d["motion"] = noneIfEmpty(r.motion, n);
    out["ideal_contacts"] = d;
  } else {
    out["ideal_contacts"] = py::none();
  }
  const jamming::LoadTestSummary& s = jamming::summaryOf(load);
  py::dict d;
  d["protocol"] = loadTest;
  d["outcome"] = std::string(jamming::verdictName(s.outcome));
  d["verdict"] = s.verdict;
  d["largest_displacement"] = s.largestDisplacement;
  d["displaced_spheres"] = s.displaced;
  d["constraints"] = s.constraints;
  d["gap_tolerance"] = loadGap;
  d["solver"] = s.solver;
  d["local_rattlers"] = s.localRattlers;
  d["seconds"] = s.seconds;
  d["jammed"] = s.jammed;
  // The --motion-csv columns: displacement per sphere, in own diameters too, and the spheres tested as rattlers.
  d["motion"] = s.motion.cols() == n ? copyOut(s.motion) : copyOut(Eigen::Matrix3Xd(Eigen::Matrix3Xd::Zero(3, n)));
  Eigen::VectorXd moved = Eigen::VectorXd::Zero(n);
  for (Index i = 0; i < n && s.motion.cols() == n; ++i) moved[i] = s.motion.col(i).norm() / (2.0 * data.radius[i]);
  d["moved_over_diameter"] = copyOut(moved);
  py::array_t<bool> rattler(static_cast<py::ssize_t>(n));
  for (Index i = 0; i < n; ++i) rattler.mutable_data()[i] = tested.rattler[static_cast<std::size_t>(i)] != 0;
  d["rattler"] = rattler;
  out["loads"] = d;
  return out;
}

py::dict leakTest(const py::object& packing, double collisions, int blocks, double tolerance, double drift,
                  const std::optional<Index>& remove, double pressure, double contactGap, const std::string& broadPhase,
                  const ProgressLine& progress) {
  requirePositive("collisions", collisions);
  requireRange("blocks", blocks, 4, 100000);
  requirePositive("tolerance", tolerance);
  if (!(std::isfinite(drift) && drift > 1.0)) {
    throw ConfigError(fmt::format("drift: {} must be > 1 (a ratio of displacements)", drift));
  }
  std::string name;
  const io::ParticleData data = particlesFrom(packing, name);
  const Index removed = removedSphere(remove, data.count());
  const app::analyze::ContactAnalysis contacts = contactsOf(data, name, pressure, contactGap, broadPhase);
  jamming::LeakTestOptions leak;
  leak.collisionsPerParticle = collisions;
  leak.blocks = blocks;
  leak.pressureTolerance = tolerance;
  leak.driftFactor = drift;
  Relay relay(progress);
  leak.progress = relay.line();
  jamming::LeakTestResult result;
  {
    py::gil_scoped_release release;
    result =
        jamming::testPressureLeakWithout(data.position, data.radius, data.box, contacts.net.rattler, removed, leak);
  }
  relay.rethrow();
  py::dict out;
  out["removed_sphere"] = removed >= 0 ? py::object(py::int_(removed)) : py::object(py::none());
  out["outcome"] = std::string(jamming::verdictName(result.outcome));
  out["verdict"] = result.verdict;
  out["leaks"] = result.leaks;
  out["pressure_change"] = result.pressureChange;
  out["drift_ratio"] = result.driftRatio;
  out["collisions"] = result.counts.collisions;
  out["seconds"] = result.seconds;
  const auto m = static_cast<py::ssize_t>(result.blocks.size());
  py::array_t<double> cpp(m), p(m), mean(m), largest(m);
  py::array_t<Index> sphere(m);
  for (py::ssize_t k = 0; k < m; ++k) {
    const jamming::LeakBlock& b = result.blocks[static_cast<std::size_t>(k)];
    cpp.mutable_data()[k] = b.collisionsPerParticle;
    p.mutable_data()[k] = b.pressure;
    mean.mutable_data()[k] = b.meanDisplacement;
    largest.mutable_data()[k] = b.maxDisplacement;
    sphere.mutable_data()[k] = b.maxSphere;
  }
  py::dict b;
  b["collisions_per_particle"] = cpp;
  b["reduced_pressure"] = p;
  b["mean_displacement"] = mean;
  b["max_displacement"] = largest;
  b["max_sphere"] = sphere;
  out["blocks"] = b;
  return out;
}

double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

py::dict structureOf(const py::object& packing, bool order, bool channels, bool structureFactor, double kMax,
                     double maxVectors, const std::optional<double>& velocityThreshold) {
  std::string name;
  const io::ParticleData data = particlesFrom(packing, name);
  const Index n = data.count();
  // The input checks of analyze's loadInput, with the same messages.
  if (velocityThreshold) {
    requirePositive("velocity_threshold", *velocityThreshold);
    if (n > 0 && !data.velocity) {
      throw ConfigError(
          fmt::format("velocity_threshold: {} has no velocities; write it with `polydem jam --velocities`", name));
    }
  }
  if (structureFactor) {
    requirePositive("k_max", kMax);
    if (!(std::isfinite(maxVectors) && maxVectors >= 0.0 && maxVectors <= 1e15)) {
      throw ConfigError(fmt::format("max_vectors: {} is outside [0, 1e15]", maxVectors));
    }
    if (n == 0) throw InputError(fmt::format("structure factor: {} has no spheres, so S(k) is undefined (0/0)", name));
    if (!data.box.fullyPeriodic()) {
      throw InputError(fmt::format("structure factor: S(k) needs a box periodic on every axis; {} has {}", name,
                                   data.box.describe()));
    }
  }
  if (channels && n == 0) {
    throw InputError(fmt::format("channels: {} has no spheres, so there are no channels (f is 0/0)", name));
  }
  const SphereView spheres{data.position, data.radius};
  py::dict out;
  if (velocityThreshold) {
    py::dict d;
    d["threshold"] = *velocityThreshold;
    if (n == 0) {
      d["count"] = py::none();  // undefined: no spheres (the CLI prints "undefined" and records nothing)
    } else {
      const structure::VelocityRattlers r =
          structure::velocityRattlers(*data.velocity, data.radius, data.box, *velocityThreshold);
      d["count"] = r.count;
      d["number_fraction"] = r.numberFraction;
      d["volume_fraction"] = r.volumeFraction;
      d["volume_share"] = r.volumeShare;
      d["rms_speed"] = r.rmsSpeed;
      py::array_t<bool> flags(static_cast<py::ssize_t>(n));
      for (Index i = 0; i < n; ++i) flags.mutable_data()[i] = r.rattler[static_cast<std::size_t>(i)] != 0;
      d["rattler"] = flags;
    }
    out["velocity_rattlers"] = d;
  }
  if (order || channels) {
    structure::NeighbourList nb;
    double seconds = 0.0;
    {
      py::gil_scoped_release release;
      const auto t0 = std::chrono::steady_clock::now();
      nb = structure::delaunayNeighbours(spheres, data.box);
      seconds = secondsSince(t0);
    }
    py::dict d;
    d["image_shell"] = nb.imageShell;
    d["triangulations"] = nb.attempts;
    d["unverified_cells"] = nb.unverifiedCells;
    d["hidden_spheres"] = nb.hidden;
    d["mean_neighbours"] = n ? py::object(py::float_(nb.meanDegree())) : py::object(py::none());
    d["seconds"] = seconds;
    py::array_t<Index> degree(static_cast<py::ssize_t>(n));
    for (Index i = 0; i < n; ++i) degree.mutable_data()[i] = nb.degree(i);
    d["neighbours"] = degree;
    out["delaunay"] = d;
    if (order) {
      if (nb.entries() == 0) {
        out["bond_order"] = py::none();  // undefined: no Delaunay neighbours
      } else {
        const structure::BondOrder bo = structure::bondOrder(nb);
        py::dict o;
        o["crystalline_fraction"] = bo.crystallineFraction;
        o["solid_like"] = bo.solidCount;
        o["mean_q6"] = bo.meanQ;
        o["global_q6"] = bo.globalQ;
        py::array_t<double> q(static_cast<py::ssize_t>(n));
        py::array_t<int> connections(static_cast<py::ssize_t>(n));
        py::array_t<bool> solid(static_cast<py::ssize_t>(n));
        for (Index i = 0; i < n; ++i) {
          q.mutable_data()[i] = bo.q[static_cast<std::size_t>(i)];
          connections.mutable_data()[i] = bo.connections[static_cast<std::size_t>(i)];
          solid.mutable_data()[i] = bo.solid[static_cast<std::size_t>(i)] != 0;
        }
        o["q6"] = q;
        o["connections"] = connections;
        o["solid"] = solid;
        out["bond_order"] = o;
      }
    }
    if (channels) {
      structure::ChannelHistogram h;
      {
        py::gil_scoped_release release;
        h = structure::channelSizes(spheres, nb);
      }
      py::dict c;
      c["acute_triangles"] = h.acute;
      c["triangles"] = h.triangles;
      c["with_gap_circle"] = h.channels;
      c["mean"] = h.channels > 0 ? py::object(py::float_(h.mean)) : py::object(py::none());
      c["sd"] = h.channels > 0 ? py::object(py::float_(h.stddev)) : py::object(py::none());
      c["overflow"] = h.overflow;
      c["bin_width"] = h.binWidth;
      // The --channels-csv columns; f is a density over the channels, 0 where it does not exist (no channel).
      const auto bins = static_cast<py::ssize_t>(h.counts.size());
      py::array_t<double> low(bins), mid(bins), f(bins);
      py::array_t<std::int64_t> count(bins);
      for (py::ssize_t k = 0; k < bins; ++k) {
        const auto uk = static_cast<std::size_t>(k);
        low.mutable_data()[k] = static_cast<double>(k) * h.binWidth;
        mid.mutable_data()[k] = (static_cast<double>(k) + 0.5) * h.binWidth;
        f.mutable_data()[k] = h.channels > 0 && std::isfinite(h.density[uk]) ? h.density[uk] : 0.0;
        count.mutable_data()[k] = h.counts[uk];
      }
      c["x_low"] = low;
      c["x_mid"] = mid;
      c["f"] = f;
      c["count"] = count;
      out["channels"] = c;
    }
  }
  if (structureFactor) {
    structure::StructureFactor sk;
    {
      py::gil_scoped_release release;
      sk = structure::structureFactor(spheres, data.box,
                                      {.kMax = kMax, .maxVectors = static_cast<std::int64_t>(maxVectors)});
    }
    py::dict d;
    d["wave_vectors"] = sk.totalVectors;
    d["stride"] = sk.stride;
    d["diameter"] = sk.diameter;
    if (sk.k.empty()) {
      for (const char* key : {"k_min", "s_at_k_min", "peak_s", "peak_k"}) d[key] = py::none();
    } else {
      std::size_t peak = 0;
      for (std::size_t s = 1; s < sk.s.size(); ++s) {
        if (sk.s[s] > sk.s[peak]) peak = s;
      }
      d["k_min"] = sk.k[0];
      d["s_at_k_min"] = sk.s[0];
      d["peak_s"] = sk.s[peak];
      d["peak_k"] = sk.k[peak];
    }
    d["K"] = py::array_t<double>(static_cast<py::ssize_t>(sk.k.size()), sk.k.data());
    d["S"] = py::array_t<double>(static_cast<py::ssize_t>(sk.s.size()), sk.s.data());
    d["chi"] = py::array_t<double>(static_cast<py::ssize_t>(sk.chi.size()), sk.chi.data());
    d["vectors"] = py::array_t<std::int64_t>(static_cast<py::ssize_t>(sk.vectors.size()), sk.vectors.data());
    out["structure_factor"] = d;
  }
  return out;
}

}  // namespace

void bindAnalysis(py::module_& m) {
  m.attr("with_glpk") = jamming::jammingTestAvailable();
  m.def("certify", &certify, py::arg("packing"), py::arg("pressure") = 0.0, py::arg("contact_gap") = 0.0,
        py::arg("broadphase") = "hgrid-td", py::arg("remove") = py::none(), py::arg("ideal") = true,
        py::arg("load_test") = "sequential", py::arg("load_gap") = 0.05, py::arg("loads") = 2,
        py::arg("displacement_limit") = 1e-3, py::arg("beta") = 0.01, py::arg("max_limit") = 0.05,
        py::arg("mean_limit") = 1e-3, py::arg("max_steps") = 10, py::arg("lp_solver") = "auto",
        py::arg("subpacking_rounds") = 1, py::arg("strict") = false, py::arg("local_rattlers") = true,
        py::arg("progress") = nullptr,
        "`polydem analyze --certify`: the ideal-contact LP test (ideal=True, needs GLPK) and the load test on the "
        "contact network of `packing` (a particle dict or a file; contact gap as in analyze()). Returns "
        "{removed_sphere, ideal_contacts: {...} or None, loads: {..., motion (N, 3)}}, the keys of the CLI's "
        "certify.* summary; progress(line) after each LP. The GIL is released while the LPs run");
  m.def("leak_test", &leakTest, py::arg("packing"), py::arg("collisions") = 1e4, py::arg("blocks") = 20,
        py::arg("tolerance") = 1e-3, py::arg("drift") = 1.5, py::arg("remove") = py::none(), py::arg("pressure") = 0.0,
        py::arg("contact_gap") = 0.0, py::arg("broadphase") = "hgrid-td", py::arg("progress") = nullptr,
        "`polydem analyze --leak-test COLLISIONS`: event-driven dynamics at fixed density; a jammed packing keeps "
        "its pressure and its backbone does not drift. Returns the keys of the CLI's leak_test.* summary, blocks "
        "as arrays; progress(line) after each block");
  m.def("structure", &structureOf, py::arg("packing"), py::arg("order") = true, py::arg("channels") = false,
        py::arg("structure_factor") = false, py::arg("k_max") = 20.0, py::arg("max_vectors") = 2e6,
        py::arg("velocity_threshold") = py::none(),
        "`polydem analyze --structure-only` analyses of any configuration: Delaunay neighbours and bond order "
        "(order), channel sizes (channels: the --channels-csv histogram as arrays), S(k) and chi(k) "
        "(structure_factor: the --sk-csv columns K, S, chi, vectors; periodic boxes), rattlers by speed "
        "(velocity_threshold, e.g. 1e-4). Keys as the CLI's delaunay.*, bond_order.*, channels.*, "
        "structure_factor.*, velocity_rattlers.* summary");
}

}  // namespace polydem::python
