// The DEM Simulation: a `polydem relax` scene (a dict with the scene file's keys, or the file itself) up to
// step 0 exactly as the CLI prepares it (apps/polydem/relax_start.cpp: read or generate, soft compression,
// initial velocities), then an integrators::DemSimulation advanced by step(n). Files are written through
// the CLI's own snapshotOf(), so a Simulation run for run.steps steps writes the bytes `polydem relax`
// writes to output.final.
//
// Views: positions, velocities, forces (N, 3), radii, inverse_masses (N,), ids (N,) int32 and, with rotation,
// angular_velocities are read-only numpy views of the engine's arrays (slot order, which a spatial sort may
// have permuted; `ids` maps slots to stored ids). They stay valid for the Simulation's lifetime: the engine
// never reallocates them after construction.
#include <fmt/format.h>
#include <pybind11/functional.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>

#include "apps/polydem/relax.hpp"
#include "apps/polydem/relax_scene.hpp"
#include "apps/polydem/summary.hpp"
#include "core/errors.hpp"
#include "core/io/checkpoint.hpp"
#include "core/io/safe_output.hpp"
#include "python/convert.hpp"
#include "python/io.hpp"

namespace polydem::python {

namespace {

/// One TOML value from a Python scalar or list; `key` names it in errors.
std::string tomlValue(const py::handle& v, const std::string& key) {
  if (py::isinstance<py::bool_>(v)) return v.cast<bool>() ? "true" : "false";
  if (py::isinstance<py::int_>(v)) return py::str(v);
  // Python's repr is the shortest text that reads back as the same double, and valid TOML (1e-05, inf, nan).
  if (py::isinstance<py::float_>(v)) return py::repr(py::float_(v.cast<double>()));
  if (py::isinstance<py::str>(v)) return app::quotedString(v.cast<std::string>());
  if (py::isinstance<py::sequence>(v) || py::hasattr(v, "tolist")) {
    py::object list = py::hasattr(v, "tolist") ? v.attr("tolist")() : py::reinterpret_borrow<py::object>(v);
    if (!py::isinstance<py::list>(list) && !py::isinstance<py::tuple>(list)) return tomlValue(list, key);
    std::string out = "[";
    bool first = true;
    for (const py::handle& item : list) {
      out += (first ? "" : ", ") + tomlValue(item, key);
      first = false;
    }
    return out + "]";
  }
  throw ConfigError(fmt::format("{}: a {} cannot be a scene value (give a number, string, bool or list)", key,
                                py::str(py::type::of(v).attr("__name__")).cast<std::string>()));
}

}  // namespace

/// A scene dict {section: {key: value}} as TOML text, so that the scene reader sees what it sees in a file
/// (the same keys, checks and messages).
std::string sceneToml(const py::dict& scene) {
  std::string root, sections;
  for (const auto& item : scene) {
    const std::string section = py::str(item.first);
    if (!py::isinstance<py::dict>(item.second)) {
      root += section + " = " + tomlValue(item.second, section) + "\n";  // the reader names it as unknown
      continue;
    }
    sections += "[" + section + "]\n";
    for (const auto& entry : item.second.cast<py::dict>()) {
      const std::string key = section + "." + py::str(entry.first).cast<std::string>();
      if (py::isinstance<py::dict>(entry.second)) {
        throw ConfigError(fmt::format("{}: scene sections hold values, not tables", key));
      }
      sections += py::str(entry.first).cast<std::string>() + " = " + tomlValue(entry.second, key) + "\n";
    }
  }
  return root + sections;
}

namespace {

std::string readSceneText(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw InputError(fmt::format("{}: cannot open scene file", file.string()));
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

py::dict energyDict(const integrators::Energies& e) {
  py::dict d;
  d["kinetic"] = e.kinetic;
  d["rotational"] = e.rotational;
  d["elastic"] = e.elastic;
  d["potential"] = e.potential;
  d["total"] = e.total();
  return d;
}

class PySimulation {
 public:
  /// From TOML text (a file's, or a dict's), as `polydem relax` starts a new run (runNew in relax.cpp).
  PySimulation(const std::string& text, const std::vector<std::string>& overrides, const std::filesystem::path& source,
               bool fromFile) {
    context_.sceneText = text;
    context_.sceneSource = source.string();
    context_.overrides = overrides;
    scene_ = app::parseRelaxScene(text, overrides, source);
    if (fromFile) inputs_.push_back(source);
    if (!scene_.particleFile.empty()) inputs_.push_back(scene_.resolve(scene_.particleFile));
    if (scene_.initialVelocities == "file" && scene_.compression) {
      throw ConfigError("velocities.initial = \"file\" cannot follow [compression]");
    }
    py::gil_scoped_release release;
    app::Start start = app::prepare(scene_);
    context_.attributes = start.attributes;
    context_.origin = start.origin;
    std::optional<integrators::SoftCompression> compression;
    if (scene_.compression) compression.emplace(std::move(start.particles), start.box, scene_.dem, *scene_.compression);
    finishStart(std::move(start), std::move(compression));
  }

  /// From a checkpoint of `polydem relax` or of save_checkpoint(), as `polydem relax --resume` continues it
  /// (resume in relax.cpp): the scene, overrides, attributes and origin it holds, then `overrides`, which may
  /// only be the keys a resumed run may change (relax_checkpoint.cpp's resumableKey).
  PySimulation(const std::filesystem::path& file, const std::vector<std::string>& overrides) {
    for (const std::string& o : overrides) {
      if (!app::resumableKey(o)) {
        throw ConfigError(
            fmt::format("resume: '{}' would change the trajectory of the saved run; only run.steps, run.threads, "
                        "run.progress_interval and output.* may be given",
                        o));
      }
    }
    io::Checkpoint checkpoint;
    {
      py::gil_scoped_release release;
      checkpoint = io::readCheckpoint(file, app::kCheckpointKind);
    }
    context_ = app::contextFrom(checkpoint, overrides);
    scene_ = app::parseRelaxScene(context_.sceneText, context_.overrides, context_.sceneSource);
    // As `relax --resume`: the scene file and the particle file are inputs; the checkpoint may be checkpointed
    // over again, but never written over by a particle file.
    inputs_.push_back(context_.sceneSource);
    if (!scene_.particleFile.empty()) inputs_.push_back(scene_.resolve(scene_.particleFile));
    resumedFrom_ = file;
    py::gil_scoped_release release;
    const integrators::DemState state = app::stateFrom(checkpoint);
    const std::string phase = checkpoint.string("phase");
    if (phase == "run") {
      sim_ = std::make_unique<integrators::DemSimulation>(integrators::DemSimulation::restore(state, runSettings()));
      return;
    }
    if (phase != "compression" || !scene_.compression) {
      throw InputError(fmt::format("{}: checkpoint phase '{}' does not match its scene", file.string(), phase));
    }
    std::optional<integrators::SoftCompression> compression;
    compression.emplace(state, scene_.dem, *scene_.compression, app::compressionFrom(checkpoint));
    app::Start start;
    start.origin = context_.origin;
    start.attributes = context_.attributes;
    finishStart(std::move(start), std::move(compression));
  }

  /// Advance n steps in chunks; between chunks the GIL is taken back, signals are polled (Ctrl-C raises
  /// KeyboardInterrupt at a complete step) and progress(step, target) is called.
  std::int64_t step(std::int64_t n, const std::function<void(std::int64_t, std::int64_t)>& progress,
                    std::int64_t chunk) {
    if (n < 0) throw ConfigError(fmt::format("step: n must be >= 0, got {}", n));
    if (chunk < 1) throw ConfigError(fmt::format("chunk must be >= 1, got {}", chunk));
    const std::int64_t target = sim_->step() + n;
    std::int64_t done = 0;
    while (done < n) {
      const std::int64_t k = std::min(chunk, n - done);
      {
        py::gil_scoped_release release;
        done += sim_->advance(k, false);
      }
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
      if (progress) progress(sim_->step(), target);
    }
    return done;
  }

  const integrators::DemSimulation& sim() const { return *sim_; }
  integrators::DemSimulation& sim() { return *sim_; }
  const app::RelaxScene& scene() const { return scene_; }
  const std::map<std::string, std::string>& attributes() const { return context_.attributes; }
  const std::string& origin() const { return context_.origin; }
  const std::optional<std::string>& targetNotReached() const { return targetNotReached_; }
  io::ParticleData snapshot() const { return app::snapshotOf(*sim_, context_.attributes); }

  /// The complete state, as `polydem relax` checkpoints it (phase "run"): `Simulation.resume(file)` and
  /// `polydem relax --resume file` continue it bit-identically. Never over one of the run's inputs.
  void saveCheckpoint(const std::filesystem::path& file) const {
    if (targetNotReached_) {
      throw ConfigError(fmt::format(
          "save_checkpoint: the scene's soft compression stopped short of its target ({}); such a run is not "
          "resumed (as `polydem relax`, which writes no checkpoint for it)",
          *targetNotReached_));
    }
    io::checkOutputPath(file, "checkpoint", inputs_);
    const io::Checkpoint c = app::makeCheckpoint(*sim_, context_);
    py::gil_scoped_release release;
    io::writeCheckpoint(file, c);
  }

  /// Write the current state as output.final is written; never over one of the run's inputs.
  void write(const std::filesystem::path& file) const {
    std::vector<std::filesystem::path> against = inputs_;
    if (!resumedFrom_.empty()) against.push_back(resumedFrom_);
    io::checkOutputPath(file, "file", against);
    const io::ParticleData data = snapshot();
    py::gil_scoped_release release;
    io::writeParticles(file, data);
  }

 private:
  /// runSettings() of relax.cpp: with the impact rule, overlap errors name velocities.overlap as the fix.
  integrators::DemSettings runSettings() const {
    integrators::DemSettings settings = scene_.dem;
    if (scene_.initialVelocities == "impact") settings.impactOverlap = scene_.impactOverlap;
    return settings;
  }

  /// runFromStart() of relax.cpp up to the time loop: the soft compression (if any), the velocities.
  void finishStart(app::Start start, std::optional<integrators::SoftCompression> compression) {
    if (compression) app::compressStart(scene_, *compression, start, context_, true, false);
    if (start.targetNotReached) {
      // As the CLI: the compressed state at rest, marked, with the scene's settings; no velocities given.
      targetNotReached_ = start.targetNotReached;
      context_.attributes["target_not_reached"] = *targetNotReached_;
      sim_ = std::make_unique<integrators::DemSimulation>(std::move(start.particles), start.box, scene_.dem);
      return;
    }
    app::setVelocities(scene_, start);
    sim_ = std::make_unique<integrators::DemSimulation>(std::move(start.particles), start.box, runSettings());
    if (scene_.initialVelocities == "file") sim_->setTimeOrigin(start.fileTime);
  }

  app::RelaxScene scene_;
  app::RunContext context_;
  std::vector<std::filesystem::path> inputs_;
  std::filesystem::path resumedFrom_;  ///< the checkpoint this run continues, if any
  std::optional<std::string> targetNotReached_;
  std::unique_ptr<integrators::DemSimulation> sim_;
};

PySimulation& self(const py::object& o) { return o.cast<PySimulation&>(); }

/// `polydem relax SCENE --sweep KEY=VALUES` without its files: the start prepared once (soft compression
/// included), one run per value over the same simulated time, and the table of its summary's sweep.* keys.
py::dict relaxSweep(const py::dict& sceneDict, const std::string& key, const std::vector<double>& values,
                    const std::vector<std::string>& overrides, const std::filesystem::path& baseDir) {
  std::string spec = key + "=";
  for (std::size_t k = 0; k < values.size(); ++k) spec += fmt::format("{}{}", k ? "," : "", values[k]);
  app::RelaxScene scene = app::parseRelaxScene(sceneToml(sceneDict), overrides, baseDir / "<scene dict>");
  const app::SweepSpec sweep = app::parseSweep(scene, spec);
  std::vector<app::SweepRow> rows;
  std::vector<app::SweepError> errors;
  {
    py::gil_scoped_release release;
    app::Start start = app::prepare(scene);
    app::RunContext context;
    context.attributes = start.attributes;
    context.origin = start.origin;
    if (scene.compression) {
      integrators::SoftCompression c(std::move(start.particles), start.box, scene.dem, *scene.compression);
      app::compressStart(scene, c, start, context, true, false);
      if (start.targetNotReached) {
        throw SimulationError(fmt::format("TARGET NOT REACHED: {}; no sweep run", *start.targetNotReached));
      }
    }
    app::setVelocities(scene, start);
    rows = app::sweepRows(scene, sweep, start, context, true);
    errors = app::sweepErrors(scene, sweep, start, rows);
  }
  py::dict out;
  out["key"] = sweep.what;
  out["error_reference"] = scene.dem.dissipationFree() ? "energy drift" : "energy vs finest";
  std::vector<double> wall, perStep, position;
  std::vector<std::int64_t> steps;
  py::list energy;
  for (std::size_t k = 0; k < rows.size(); ++k) {
    steps.push_back(rows[k].steps);
    wall.push_back(rows[k].run.wallSeconds);
    perStep.push_back(errors[k].usPerParticleStep);
    position.push_back(errors[k].position);
    energy.append(errors[k].energy ? py::object(py::float_(*errors[k].energy)) : py::object(py::none()));
  }
  auto array = [](const auto& v) {
    using T = typename std::decay_t<decltype(v)>::value_type;
    return py::array_t<T>(static_cast<py::ssize_t>(v.size()), v.data());
  };
  out["values"] = array(sweep.values);
  out["steps"] = array(steps);
  out["wall_seconds"] = array(wall);
  out["us_per_particle_step"] = array(perStep);
  out["energy_error"] = energy;
  out["position_error"] = array(position);
  return out;
}

}  // namespace

void bindSimulation(py::module_& m) {
  m.def("scene_toml", &sceneToml, py::arg("scene"), "the TOML text a scene dict is read as");
  m.def("relax_sweep", &relaxSweep, py::arg("scene"), py::arg("key"), py::arg("values"),
        py::arg("overrides") = std::vector<std::string>{}, py::arg("base_dir") = ".",
        "`polydem relax --sweep KEY=VALUES` (key 'dt-factor' or 'skin'): the scene's start once, one run per value "
        "(ascending) over the same simulated time; returns values, steps, wall_seconds, us_per_particle_step, "
        "energy_error (None where undefined) and position_error (max |dx| / r_min against the finest setting), the "
        "CLI summary's sweep.* keys. Writes no file; not interruptible");
  m.def("default_scene", &app::defaultSceneToml, "every scene key with its default (`polydem relax --print-defaults`)");
  py::class_<PySimulation>(m, "Simulation",
                           "A soft-sphere DEM run of a `polydem relax` scene (dict with the scene file's keys).")
      .def(py::init([](const py::dict& scene, const std::vector<std::string>& overrides,
                       const std::filesystem::path& baseDir) {
             return std::make_unique<PySimulation>(sceneToml(scene), overrides, baseDir / "<scene dict>", false);
           }),
           py::arg("scene"), py::arg("overrides") = std::vector<std::string>{}, py::arg("base_dir") = ".",
           "scene: {section: {key: value}} as in a scene file; overrides: 'section.key=value' as relax --set; "
           "relative paths resolve against base_dir")
      .def_static(
          "from_file",
          [](const std::filesystem::path& file, const std::vector<std::string>& overrides) {
            return std::make_unique<PySimulation>(readSceneText(file), overrides, file, true);
          },
          py::arg("file"), py::arg("overrides") = std::vector<std::string>{}, "a scene file, as `polydem relax FILE`")
      .def_static(
          "resume",
          [](const std::filesystem::path& file, const std::vector<std::string>& overrides) {
            return std::make_unique<PySimulation>(file, overrides);
          },
          py::arg("file"), py::arg("overrides") = std::vector<std::string>{},
          "continue a checkpoint of save_checkpoint() or of `polydem relax` (output.checkpoint) as `polydem relax "
          "--resume FILE` does; overrides only run.steps, run.threads, run.progress_interval, output.*")
      .def("save_checkpoint", &PySimulation::saveCheckpoint, py::arg("file"),
           "write the complete state (HDF5, the checkpoint of `polydem relax`); resume() or `polydem relax "
           "--resume FILE` continue it bit-identically")
      .def("step", &PySimulation::step, py::arg("n") = 1, py::arg("progress") = nullptr, py::arg("chunk") = 200,
           "advance n steps (GIL released; Ctrl-C raises KeyboardInterrupt after a complete step); progress(step, "
           "target) after each chunk")
      .def(
          "run",
          [](PySimulation& s, const std::function<void(std::int64_t, std::int64_t)>& progress, std::int64_t chunk) {
            return s.step(std::max<std::int64_t>(0, s.scene().steps - s.sim().step()), progress, chunk);
          },
          py::arg("progress") = nullptr, py::arg("chunk") = 200, "advance to the scene's run.steps")
      .def(
          "check_stability", [](const PySimulation& s) { s.sim().checkStability(); },
          "the stability checks (raises SimulationError); the CLI runs them before writing the final state")
      .def(
          "grow_radii", [](PySimulation& s, double f) { s.sim().growRadii(f); }, py::arg("factor"))
      .def_property_readonly("positions",
                             [](const py::object& o) { return viewOf(self(o).sim().particles().position(), o); })
      .def_property_readonly("velocities",
                             [](const py::object& o) { return viewOf(self(o).sim().particles().velocity(), o); })
      .def_property_readonly("forces", [](const py::object& o) { return viewOf(self(o).sim().particles().force(), o); })
      .def_property_readonly("radii", [](const py::object& o) { return viewOf(self(o).sim().particles().radius(), o); })
      .def_property_readonly("inverse_masses",
                             [](const py::object& o) { return viewOf(self(o).sim().particles().inverseMass(), o); })
      .def_property_readonly("ids", [](const py::object& o) { return viewOf(self(o).sim().particles().id(), o); })
      .def_property_readonly("angular_velocities",
                             [](const py::object& o) -> py::object {
                               const ParticleStore& p = self(o).sim().particles();
                               if (!p.features().rotation) return py::none();
                               return viewOf(p.angularVelocity(), o);
                             })
      .def_property_readonly("count", [](const PySimulation& s) { return s.sim().particles().count(); })
      .def_property_readonly("step_count", [](const PySimulation& s) { return s.sim().step(); })
      .def_property_readonly(
          "steps", [](const PySimulation& s) { return s.scene().steps; }, "the scene's run.steps")
      .def_property_readonly("time", [](const PySimulation& s) { return s.sim().time(); })
      .def_property_readonly("dt", [](const PySimulation& s) { return s.sim().dt(); })
      .def_property_readonly("time_step", [](const PySimulation& s) { return s.sim().timeStepChoice().describe(); })
      .def_property_readonly("box", [](const PySimulation& s) { return s.sim().box(); })
      .def_property_readonly("packing_fraction", [](const PySimulation& s) { return s.sim().packingFraction(); })
      .def_property_readonly("rebuilds", [](const PySimulation& s) { return s.sim().rebuilds(); })
      .def_property_readonly("memory_bytes", [](const PySimulation& s) { return s.sim().memoryBytes(); })
      .def_property_readonly("conservative", [](const PySimulation& s) { return s.sim().conservative(); })
      .def_property_readonly("contact_law",
                             [](const PySimulation& s) { return s.sim().model().parameters().describe(); })
      .def_property_readonly("broad_phase", [](const PySimulation& s) { return s.sim().settings().broadPhase; })
      .def_property_readonly("origin", &PySimulation::origin)
      .def_property_readonly("attributes", &PySimulation::attributes)
      .def_property_readonly("target_not_reached", &PySimulation::targetNotReached,
                             "None, or why the scene's soft compression stopped short (the run then starts at rest)")
      .def_property_readonly("momentum",
                             [](const PySimulation& s) {
                               const Eigen::Vector3d p = s.sim().momentum();
                               return py::make_tuple(p[0], p[1], p[2]);
                             })
      .def(
          "energies", [](const PySimulation& s) { return energyDict(s.sim().energies()); },
          "kinetic, rotational, elastic, potential, total (J)")
      .def_property_readonly("initial_energy", [](const PySimulation& s) { return s.sim().initialEnergy(); })
      .def(
          "contacts",
          [](const PySimulation& s) {
            const contact::ContactStats c = s.sim().contactStats();
            py::dict d;
            d["contacts"] = c.contacts;
            d["wall_contacts"] = c.wallContacts;
            d["contacts_per_particle"] = 2.0 * static_cast<double>(c.contacts) / s.sim().particles().count();
            d["max_overlap_ratio"] = c.maxOverlapRatio;
            d["elastic_energy"] = c.elasticEnergy;
            return d;
          },
          "contacts (overlap > 0), wall contacts, largest overlap / smaller radius, elastic energy")
      .def("phase_times",
           [](const PySimulation& s) {
             const integrators::PhaseTimes& t = s.sim().times();
             py::dict d;
             d["broad_phase"] = t.broadPhase;
             d["force"] = t.force;
             d["integration"] = t.integration;
             d["check"] = t.check;
             return d;
           })
      .def(
          "snapshot", [](const PySimulation& s) { return particleDict(s.snapshot()); },
          "the state in id order as the CLI writes it (a particle dict, copies)")
      .def("write", &PySimulation::write, py::arg("file"),
           "write the state as `polydem relax` writes output.final (format by extension)");
}

}  // namespace polydem::python
