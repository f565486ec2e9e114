// `jam` (event-driven compression, edmd/compression.hpp, started as `polydem jam` starts it) and `analyze`
// (the contact network of a hard-sphere packing, through the CLI's own computeContacts of
// apps/polydem/analyze_contacts.cpp: same pressure rule, validity check and messages).
#include <fmt/format.h>
#include <pybind11/functional.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <chrono>
#include <cmath>
#include <optional>

#include "apps/polydem/analyze.hpp"
#include "apps/polydem/jam.hpp"
#include "core/errors.hpp"
#include "core/initial_configuration.hpp"
#include "core/io/checkpoint.hpp"
#include "core/io/particle_file.hpp"
#include "core/io/safe_output.hpp"
#include "edmd/compression.hpp"
#include "edmd/hard_sphere_system.hpp"
#include "jamming/contact_network.hpp"
#include "python/convert.hpp"
#include "python/distributions.hpp"
#include "python/io.hpp"

namespace polydem::python {

namespace {

py::object finiteOrNone(double x) { return std::isfinite(x) ? py::object(py::float_(x)) : py::object(py::none()); }

py::dict networkDict(const jamming::ContactNetwork& net, const jamming::ContactOptions& options) {
  py::dict d;
  const auto n = static_cast<py::ssize_t>(net.contacts.size());
  py::array_t<Index> i(n), j(n);
  for (py::ssize_t k = 0; k < n; ++k) {
    i.mutable_data()[k] = net.contacts[static_cast<std::size_t>(k)].i;
    j.mutable_data()[k] = net.contacts[static_cast<std::size_t>(k)].j;
  }
  d["contacts"] = py::make_tuple(i, j);
  py::array_t<Index> wi(static_cast<py::ssize_t>(net.wallContacts.size()));
  py::array_t<int> wall(static_cast<py::ssize_t>(net.wallContacts.size()));
  for (std::size_t k = 0; k < net.wallContacts.size(); ++k) {
    wi.mutable_data()[k] = net.wallContacts[k].i;
    wall.mutable_data()[k] = net.wallContacts[k].wall;
  }
  d["wall_contacts"] = py::make_tuple(wi, wall);
  py::array_t<int> z(static_cast<py::ssize_t>(net.coordination.size()));
  std::copy(net.coordination.begin(), net.coordination.end(), z.mutable_data());
  d["coordination"] = z;
  py::array_t<bool> rattler(static_cast<py::ssize_t>(net.rattler.size()));
  for (std::size_t k = 0; k < net.rattler.size(); ++k) rattler.mutable_data()[k] = net.rattler[k] != 0;
  d["rattler"] = rattler;
  d["contact_gap"] = options.relativeGap;
  d["min_contacts"] = options.minContacts;
  d["z"] = net.particles > 0 ? py::object(py::float_(net.meanCoordination())) : py::object(py::none());
  // An empty backbone (every sphere a rattler) has no coordination and no isostaticity: None, not nan.
  d["backbone"] = net.backbone;
  d["backbone_contacts"] = net.backboneContacts;
  d["z_backbone"] = net.backbone > 0 ? py::object(py::float_(net.backboneCoordination())) : py::object(py::none());
  d["isostatic_excess"] = net.backbone > 0 ? py::object(py::int_(net.isostaticExcess())) : py::object(py::none());
  d["rattler_fraction"] = net.particles > 0 ? py::object(py::float_(net.rattlerFraction())) : py::object(py::none());
  d["max_overlap"] = net.maxOverlap;
  d["min_gap"] = net.minGap;
  return d;
}

py::dict progressDict(const edmd::Progress& p) {
  py::dict d;
  d["packing_fraction"] = p.packingFraction;
  d["pressure"] = p.pressure;
  d["phi_j_estimate"] = finiteOrNone(p.jammingEstimate);
  d["rate"] = p.rate;
  d["stage"] = p.stage;
  d["collisions_per_particle"] = p.collisionsPerParticle;
  d["blocks"] = p.blocks;
  d["wall_seconds"] = p.wallSeconds;
  d["time"] = p.time;
  return d;
}

/// A jam run as jam.cpp's runJam makes it, without its printing: the settings, the start, the system, the
/// compression state.
struct PyJam {
  app::JamOptions opt;
  edmd::CompressionOptions copt;
  io::ParticleData start;
  std::string origin;  ///< saved into checkpoints (a resumed run keeps the first run's)
  std::vector<std::filesystem::path> inputs;
  std::unique_ptr<edmd::HardSphereSystem> system;
  edmd::CompressionState cstate;
};

py::dict fixedDensityDict(const edmd::EquilibriumRun& eq, double collisions, double compressionEnd) {
  py::dict d;
  d["collisions_per_particle"] = collisions;
  d["reduced_pressure"] = eq.pressure;
  d["compression_end_pressure"] = compressionEnd;
  d["collisions_per_second"] = eq.collisionsPerSecond;
  d["wall_seconds"] = eq.wallSeconds;
  return d;
}

/// The compression (checkpoints at block boundaries as the CLI writes them), the fixed-density run, the
/// contact network and the output; then the dict, or the exception that stopped the run (Ctrl-C, a callback's).
py::dict runJam(PyJam& run, const std::function<void(py::dict)>& progress) {
  const app::JamOptions& opt = run.opt;
  // Python callbacks and signals are handled with the GIL taken back, at block boundaries; an error there
  // stops the compression at the boundary and is raised after the checkpoint and the output are written.
  std::optional<py::error_already_set> failure;
  std::vector<double> eosPhi, eosZ, eosRate, eosCollisions, eosTime;
  const std::function<void(const edmd::Progress&)> onBlock = [&](const edmd::Progress& p) {
    eosPhi.push_back(p.packingFraction);
    eosZ.push_back(p.pressure);
    eosRate.push_back(p.rate);
    eosCollisions.push_back(p.collisionsPerParticle);
    eosTime.push_back(p.time);
    if (!progress || failure) return;
    py::gil_scoped_acquire acquire;
    try {
      progress(progressDict(p));
    } catch (py::error_already_set& e) {
      failure.emplace(std::move(e));
    }
  };
  auto signalled = [&] {
    if (failure) return true;
    py::gil_scoped_acquire acquire;
    if (PyErr_CheckSignals() != 0) failure.emplace();
    return failure.has_value();
  };
  auto sinceCheckpoint = std::chrono::steady_clock::now();
  const edmd::BoundaryHook atBoundary = [&](edmd::HardSphereSystem& sys, const edmd::CompressionState& cs) {
    const bool testStop = opt.stopAfterBlocks > 0 && cs.blocks >= opt.stopAfterBlocks;
    const bool stop = signalled() || testStop;
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - sinceCheckpoint).count();
    if (!opt.checkpoint.empty() && (stop || elapsed >= opt.checkpointInterval)) {
      io::writeCheckpoint(opt.checkpoint, app::jamCheckpoint(opt, run.origin, run.start, sys, cs, 0));
      sinceCheckpoint = std::chrono::steady_clock::now();
    }
    return stop;
  };
  app::JamSummary summary;
  edmd::CompressionResult result;
  std::optional<edmd::EquilibriumRun> fixed;
  double compressionEnd = 0.0;
  {
    py::gil_scoped_release release;
    result = edmd::compress(*run.system, run.copt, onBlock, atBoundary, &run.cstate);
    summary.stopReason = result.stopReason;
    summary.interrupted = summary.stopReason == "interrupted";
    summary.pressure = result.last.pressure;
    compressionEnd = summary.pressure;
    if (opt.runCollisions > 0.0 && !summary.interrupted) {
      fixed = edmd::runAtFixedDensity(*run.system, opt.runCollisions, 100.0, signalled);
      if (failure) {
        summary.interrupted = true;
        summary.stopReason = "interrupted (during --run-collisions)";
      }
      summary.pressure = fixed->pressure;
    }
    app::analysePacking(opt, *run.system, summary);
    summary.targetReached = result.targetReached && !summary.interrupted;
    if (!opt.output.empty()) {
      io::writeParticles(opt.output,
                         app::packingRecord(opt, run.copt, run.start, *run.system, summary, result.counts.collisions));
    }
  }
  if (failure) throw std::move(*failure);
  const edmd::HardSphereSystem& system = *run.system;
  py::dict out;
  out["positions"] = copyOut(summary.x);
  out["radii"] = copyOut(summary.r);
  out["id"] = copyOut(run.start.id);
  out["box"] = py::cast(system.box());
  out["packing_fraction"] = summary.phi;
  out["pressure"] = summary.pressure;
  out["phi_j_estimate"] = finiteOrNone(summary.phiJ);
  out["target_reached"] = summary.targetReached;
  out["interrupted"] = summary.interrupted;
  out["stop_reason"] = summary.stopReason;
  out["collisions"] = result.counts.collisions;
  out["blocks"] = result.last.blocks;
  out["wall_seconds"] = result.wallSeconds;
  out["schedule"] = edmd::formatSchedule(run.copt.schedule);
  out["origin"] = run.origin;
  out["attributes"] = py::cast(run.start.attributes);
  out["network"] = networkDict(summary.net, summary.contactOptions);
  out["fixed_density"] =
      fixed ? py::object(fixedDensityDict(*fixed, opt.runCollisions, compressionEnd)) : py::object(py::none());
  // The --eos-csv columns of the blocks this call ran (a resumed run: those after the checkpoint).
  py::dict eos;
  eos["phi"] = py::array_t<double>(static_cast<py::ssize_t>(eosPhi.size()), eosPhi.data());
  eos["Z"] = py::array_t<double>(static_cast<py::ssize_t>(eosZ.size()), eosZ.data());
  eos["rate"] = py::array_t<double>(static_cast<py::ssize_t>(eosRate.size()), eosRate.data());
  eos["collisions_per_particle"] =
      py::array_t<double>(static_cast<py::ssize_t>(eosCollisions.size()), eosCollisions.data());
  eos["time"] = py::array_t<double>(static_cast<py::ssize_t>(eosTime.size()), eosTime.data());
  out["eos"] = eos;
  out["output"] = opt.output.empty() ? py::object(py::none()) : py::object(py::str(opt.output));
  out["checkpoint"] = opt.checkpoint.empty() ? py::object(py::none()) : py::object(py::str(opt.checkpoint));
  return out;
}

std::string boundaryText(const std::array<Boundary, 3>& b) {
  std::string text;
  for (std::size_t k = 0; k < 3; ++k)
    text += std::string(k ? "," : "") + (b[k] == Boundary::Periodic ? "periodic" : "wall");
  return text;
}

/// Outputs checked before any work, as the CLI checks them: never an input, never each other.
void checkJamOutputs(const PyJam& run, const std::filesystem::path& resumed) {
  std::vector<std::filesystem::path> against = run.inputs;
  if (!resumed.empty()) against.push_back(resumed);
  if (!run.opt.output.empty()) io::checkOutputPath(run.opt.output, "output", against);
  if (!run.opt.checkpoint.empty()) {
    io::checkOutputPath(run.opt.checkpoint, "checkpoint", run.inputs);
    if (!run.opt.output.empty() && io::samePath(run.opt.output, run.opt.checkpoint)) {
      throw ConfigError(fmt::format("checkpoint '{}': the same file as the output", run.opt.checkpoint));
    }
  }
}

py::dict jam(const std::shared_ptr<Distribution>& distribution, Index count, double initialPhi,
             const py::object& boundaries, const std::string& sampling, std::uint64_t seed, const py::object& packing,
             double reopen, const std::string& equivalent, const std::optional<std::string>& schedule,
             double targetPressure, double targetPhi, double maxCollisions, double block, const std::string& broadPhase,
             double neighbourhoodScale, double skinCap, double contactGap, double runCollisions,
             const std::optional<std::filesystem::path>& output, bool velocities,
             const std::optional<std::filesystem::path>& checkpoint, double checkpointInterval,
             std::int64_t stopAfterBlocks, const std::function<void(py::dict)>& progress) {
  PyJam run;
  app::JamOptions& opt = run.opt;
  opt.count = count;
  opt.initialPhi = initialPhi;
  opt.boundaries = boundaryText(boundariesFrom(boundaries));
  opt.sampling = sampling;
  opt.seed = seed;
  opt.reopen = reopen;
  opt.equivalent = equivalent;
  if (schedule) opt.schedule = *schedule;
  opt.targetPressure = targetPressure;
  opt.targetPhi = targetPhi;
  opt.maxCollisions = maxCollisions;
  opt.block = block;
  opt.broadPhase = broadPhase;
  opt.neighbourhoodScale = neighbourhoodScale;
  opt.skinCap = skinCap;
  opt.contactGap = contactGap;
  opt.runCollisions = runCollisions;
  opt.output = output ? output->string() : std::string();
  opt.writeVelocities = velocities;
  opt.checkpoint = checkpoint ? checkpoint->string() : std::string();
  opt.checkpointInterval = checkpointInterval;
  opt.stopAfterBlocks = stopAfterBlocks;
  // The CLI's option checks, named by the Python arguments.
  if (sampling != "systematic" && sampling != "random") {
    throw ConfigError(fmt::format("sampling '{}': expected systematic or random", sampling));
  }
  if (equivalent != "none" && equivalent != "bi" && equivalent != "tri") {
    throw ConfigError(fmt::format("equivalent '{}': expected none, bi or tri", equivalent));
  }
  if (!(initialPhi > 0.0 && initialPhi < 1.0))
    throw ConfigError(fmt::format("initial_phi {}: outside (0, 1)", initialPhi));
  if (reopen != 0.0 && !(std::isfinite(reopen) && reopen >= 10.0)) {
    throw ConfigError(fmt::format("reopen {}: a reduced pressure >= 10 (or 0: no reopening)", reopen));
  }
  if (block != 0.0 && !(block >= 1.0 && block <= 1e6)) {
    throw ConfigError(
        fmt::format("block {}: must be 0 (automatic) or 1 to 1e6 collisions per particle (smaller blocks spend the run "
                    "synchronising)",
                    block));
  }
  if (!(std::isfinite(runCollisions) && runCollisions >= 0.0 && runCollisions <= 1e9)) {
    throw ConfigError(fmt::format("run_collisions {}: outside [0, 1e9]", runCollisions));
  }
  if (!(std::isfinite(checkpointInterval) && checkpointInterval > 0.0)) {
    throw ConfigError(fmt::format("checkpoint_interval {}: must be > 0 seconds", checkpointInterval));
  }
  if (stopAfterBlocks < 0) throw ConfigError(fmt::format("stop_after_blocks {}: must be >= 0", stopAfterBlocks));
  run.copt = app::compressionOptions(opt);
  std::string name = "packing";
  if (!packing.is_none()) {
    if (distribution) throw ConfigError("jam: give either a distribution or a start packing, not both");
    if (equivalent != "none") {
      throw ConfigError("equivalent applies to the random start (a distribution); it cannot be combined with packing");
    }
    run.start = particlesFrom(packing, name);
    if (!py::isinstance<py::dict>(packing)) {
      opt.input = name;
      run.inputs.emplace_back(name);
    }
    run.origin = name;
    if (reopen > 0.0) run.origin += app::reopenStart(run.start, reopen, name);
  } else {
    if (!distribution) throw ConfigError("jam: give a distribution (with count) or a start packing");
    if (reopen > 0.0) throw ConfigError("reopen needs packing (a jammed packing)");
  }
  checkJamOutputs(run, {});
  {
    py::gil_scoped_release release;
    if (packing.is_none()) run.start = app::sampledStart(distribution->get(), opt, run.origin);
    run.system = app::startedSystem(opt, run.copt, run.start, name);
  }
  return runJam(run, progress);
}

py::dict resumeJam(const std::filesystem::path& file, const std::optional<double>& checkpointInterval,
                   std::int64_t stopAfterBlocks, const std::function<void(py::dict)>& progress) {
  PyJam run;
  io::Checkpoint saved;
  {
    py::gil_scoped_release release;
    saved = io::readCheckpoint(file, "jam");
  }
  if (saved.integerScalar("format") != app::kJamCheckpointFormat) {
    throw InputError(fmt::format("{}: jam checkpoint format {} (this polydem reads format {})", file.string(),
                                 saved.integerScalar("format"), app::kJamCheckpointFormat));
  }
  app::JamOptions& opt = run.opt;
  app::getSettings(saved, opt);
  opt.checkpoint = file.string();  // a resumed run keeps checkpointing into the file it resumed from
  opt.eosCsv.clear();              // the EOS rows come back in the result, no table is kept
  if (checkpointInterval) {
    if (!(std::isfinite(*checkpointInterval) && *checkpointInterval > 0.0)) {
      throw ConfigError(fmt::format("checkpoint_interval {}: must be > 0 seconds", *checkpointInterval));
    }
    opt.checkpointInterval = *checkpointInterval;
  }
  if (stopAfterBlocks < 0) throw ConfigError(fmt::format("stop_after_blocks {}: must be >= 0", stopAfterBlocks));
  opt.stopAfterBlocks = stopAfterBlocks;
  run.copt = app::compressionOptions(opt);
  if (!opt.input.empty()) run.inputs.emplace_back(opt.input);
  checkJamOutputs(run, file);
  run.start = app::getStartRecord(saved);
  run.origin = saved.string("origin");
  {
    py::gil_scoped_release release;
    run.system = app::restoreSystem(saved, file.string(), opt, run.start);
  }
  run.cstate = app::getCompressionState(saved);
  return runJam(run, progress);
}

}  // namespace

void bindJamming(py::module_& m) {
  m.def("jam", &jam, py::arg("distribution") = nullptr, py::arg("count") = 1000, py::arg("initial_phi") = 0.3,
        py::arg("boundaries") = "periodic", py::arg("sampling") = "systematic", py::arg("seed") = 1,
        py::arg("packing") = py::none(), py::arg("reopen") = 0.0, py::arg("equivalent") = "none",
        py::arg("schedule") = py::none(), py::arg("target_pressure") = 1e12, py::arg("target_phi") = 0.0,
        py::arg("max_collisions") = 1e7, py::arg("block") = 0.0, py::arg("broadphase") = "hgrid-td",
        py::arg("neighbourhood_scale") = 1.4, py::arg("skin_cap") = 4.0, py::arg("contact_gap") = 0.0,
        py::arg("run_collisions") = 0.0, py::arg("output") = py::none(), py::arg("velocities") = false,
        py::arg("checkpoint") = py::none(), py::arg("checkpoint_interval") = 600.0, py::arg("stop_after_blocks") = 0,
        py::arg("progress") = nullptr,
        "Event-driven compression (`polydem jam`) of a start packing made from a distribution (or its equivalent "
        "mixture), or of `packing` (a particle dict or file, perhaps reopened to a pressure); run_collisions at fixed "
        "density afterwards; output writes the CLI's file, checkpoint its checkpoint (every checkpoint_interval s "
        "and when stopped). progress(dict) after every block; Ctrl-C stops at a block boundary (checkpoint and "
        "output written) with KeyboardInterrupt. Returns positions, radii, box, packing_fraction, pressure, "
        "phi_j_estimate, stop_reason, network, eos, ...");
  m.def("resume_jam", &resumeJam, py::arg("checkpoint"), py::arg("checkpoint_interval") = py::none(),
        py::arg("stop_after_blocks") = 0, py::arg("progress") = nullptr,
        "continue a jam checkpoint (of jam(checkpoint=...) or `polydem jam --checkpoint`) as `polydem jam --resume` "
        "does: every setting, the output file and the checkpoint file come from it; the run is the interrupted one");

  m.def(
      "analyze",
      [](const py::object& packing, double pressure, double contactGap, const std::string& broadPhase,
         const std::vector<double>& taus) {
        std::string name;
        const io::ParticleData data = particlesFrom(packing, name);
        app::analyze::AnalyzeOptions opt;
        opt.input = name;
        opt.pressure = pressure;
        opt.contactGap = contactGap;
        opt.broadPhase = broadPhase;
        app::analyze::ContactAnalysis a;
        std::vector<double> z;
        {
          py::gil_scoped_release release;
          a = app::analyze::computeContacts(opt, data);
          if (!taus.empty()) {
            z = jamming::cumulativeCoordination(SphereView{data.position, data.radius}, data.box, taus, broadPhase);
          }
        }
        py::dict out = networkDict(a.net, a.contact);
        out["spheres"] = data.count();
        out["packing_fraction"] = app::analyze::solidVolume(data) / data.box.volume();
        out["pressure"] = a.pressure ? py::object(py::float_(*a.pressure)) : py::object(py::none());
        out["density_bound"] = a.validity.densityBound;
        out["valid"] = a.validity.valid();
        if (!taus.empty()) {
          out["taus"] = taus;
          out["z_of_tau"] = z;
        }
        return out;
      },
      py::arg("packing"), py::arg("pressure") = 0.0, py::arg("contact_gap") = 0.0, py::arg("broadphase") = "hgrid-td",
      py::arg("taus") = std::vector<double>{},
      "`polydem analyze` (contact network): packing a particle dict or a file; the contact gap from pressure "
      "(or the file's reduced_pressure) or contact_gap. Raises InputError for an invalid hard-sphere packing");

  m.def(
      "check_packing",
      [](const py::object& packing, double tolerance, const std::string& broadPhase) {
        std::string name;
        const io::ParticleData data = particlesFrom(packing, name);
        const jamming::PackingValidity v =
            jamming::checkHardSpherePacking(SphereView{data.position, data.radius}, data.box,
                                            {.overlapTolerance = tolerance, .broadPhase = broadPhase});
        py::dict d;
        d["valid"] = v.valid();
        d["packing_fraction"] = v.packingFraction;
        d["density_bound"] = v.densityBound;
        d["worst_overlap"] = v.worstOverlap;
        d["overlaps"] = v.overlaps;
        d["problem"] = jamming::describeInvalidPacking(v, data.id);
        return d;
      },
      py::arg("packing"), py::arg("tolerance") = 1e-8, py::arg("broadphase") = "hgrid-td",
      "overlaps and density bound of a hard-sphere packing (jamming::checkHardSpherePacking)");
}

}  // namespace polydem::python
