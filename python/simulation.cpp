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
    scene_ = app::parseRelaxScene(text, overrides, source);
    if (fromFile) inputs_.push_back(source);
    if (!scene_.particleFile.empty()) inputs_.push_back(scene_.resolve(scene_.particleFile));
    if (scene_.initialVelocities == "file" && scene_.compression) {
      throw ConfigError("velocities.initial = \"file\" cannot follow [compression]");
    }
    py::gil_scoped_release release;
    app::Start start = app::prepare(scene_);
    attributes_ = start.attributes;
    origin_ = start.origin;
    if (scene_.compression) {
      integrators::SoftCompression compression(std::move(start.particles), start.box, scene_.dem, *scene_.compression);
      app::RunContext context;
      context.attributes = attributes_;
      context.origin = origin_;
      app::compressStart(scene_, compression, start, context, true, false);
    }
    if (start.targetNotReached) {
      // As the CLI: the compressed state at rest, marked, with the scene's settings; no velocities given.
      targetNotReached_ = start.targetNotReached;
      attributes_["target_not_reached"] = *targetNotReached_;
      sim_ = std::make_unique<integrators::DemSimulation>(std::move(start.particles), start.box, scene_.dem);
      return;
    }
    app::setVelocities(scene_, start);
    integrators::DemSettings settings = scene_.dem;
    // runSettings() of relax.cpp: with the impact rule, overlap errors name velocities.overlap as the fix.
    if (scene_.initialVelocities == "impact") settings.impactOverlap = scene_.impactOverlap;
    sim_ = std::make_unique<integrators::DemSimulation>(std::move(start.particles), start.box, settings);
    if (scene_.initialVelocities == "file") sim_->setTimeOrigin(start.fileTime);
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
  const std::map<std::string, std::string>& attributes() const { return attributes_; }
  const std::string& origin() const { return origin_; }
  const std::optional<std::string>& targetNotReached() const { return targetNotReached_; }
  io::ParticleData snapshot() const { return app::snapshotOf(*sim_, attributes_); }

  /// Write the current state as output.final is written; never over one of the run's inputs.
  void write(const std::filesystem::path& file) const {
    io::checkOutputPath(file, "file", inputs_);
    const io::ParticleData data = snapshot();
    py::gil_scoped_release release;
    io::writeParticles(file, data);
  }

 private:
  app::RelaxScene scene_;
  std::vector<std::filesystem::path> inputs_;
  std::map<std::string, std::string> attributes_;
  std::string origin_;
  std::optional<std::string> targetNotReached_;
  std::unique_ptr<integrators::DemSimulation> sim_;
};

PySimulation& self(const py::object& o) { return o.cast<PySimulation&>(); }

}  // namespace

void bindSimulation(py::module_& m) {
  m.def("scene_toml", &sceneToml, py::arg("scene"), "the TOML text a scene dict is read as");
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
