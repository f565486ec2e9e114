// Particle files (core/io/particle_file.hpp): text, and HDF5 snapshots with XDMF sidecars when built with
// HDF5. A file is a dict: positions (N, 3), radii (N,), id (N,) int32, box, time, attributes, and
// velocities / angular_velocities (N, 3) or None.
#include "python/io.hpp"

#include <fmt/format.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "core/errors.hpp"
#include "core/io/hdf5_snapshot.hpp"
#include "core/io/particle_file.hpp"
#include "polydem/config.hpp"
#include "python/convert.hpp"

namespace polydem::python {

py::dict particleDict(const io::ParticleData& data) {
  py::dict d;
  d["positions"] = copyOut(data.position);
  d["radii"] = copyOut(data.radius);
  d["id"] = copyOut(data.id);
  d["velocities"] = data.velocity ? py::object(copyOut(*data.velocity)) : py::object(py::none());
  d["angular_velocities"] = data.angularVelocity ? py::object(copyOut(*data.angularVelocity)) : py::object(py::none());
  d["box"] = py::cast(data.box);
  d["time"] = data.time;
  d["attributes"] = py::cast(data.attributes);
  return d;
}

io::ParticleData particleData(const py::dict& d) {
  static const std::vector<std::string> known = {"positions", "radii",      "id",   "velocities", "angular_velocities",
                                                 "box",       "boundaries", "time", "attributes"};
  for (const auto& item : d) {
    const std::string key = py::str(item.first);
    if (std::find(known.begin(), known.end(), key) == known.end()) {
      throw ConfigError(
          fmt::format("particle data: unknown key '{}' (expected one of positions, radii, id, "
                      "velocities, angular_velocities, box, boundaries, time, attributes)",
                      key));
    }
  }
  for (const char* key : {"positions", "radii", "box"}) {
    if (!d.contains(key)) throw ConfigError(fmt::format("particle data: '{}' is required", key));
  }
  io::ParticleData data;
  data.position = toMatrix3X(d["positions"], "positions");
  data.radius = toVector(d["radii"], "radii");
  data.box = boxFrom(d["box"], d.contains("boundaries") ? py::object(d["boundaries"]) : py::object(py::none()));
  auto optionalMatrix = [&](const char* key) -> std::optional<Eigen::Matrix3Xd> {
    if (!d.contains(key) || d[key].is_none()) return std::nullopt;
    return toMatrix3X(d[key], key);
  };
  data.velocity = optionalMatrix("velocities");
  data.angularVelocity = optionalMatrix("angular_velocities");
  if (d.contains("id") && !d["id"].is_none()) {
    data.id = toIndices(d["id"], "id");
  } else {
    data.id.resize(static_cast<std::size_t>(data.count()));
    for (Index i = 0; i < data.count(); ++i) data.id[static_cast<std::size_t>(i)] = i;
  }
  if (d.contains("time")) data.time = d["time"].cast<double>();
  if (d.contains("attributes")) {
    for (const auto& item : d["attributes"].cast<py::dict>()) {
      data.attributes[py::str(item.first)] = py::str(item.second);
    }
  }
  io::requireConsistentSizes(data);
  return data;
}

void bindIo(py::module_& m) {
  m.def(
      "read_particles",
      [](const std::filesystem::path& file, const py::object& boundaries) {
        const auto b = boundariesFrom(boundaries);
        io::ParticleData data;
        {
          py::gil_scoped_release release;
          data = io::readParticles(file, b);
        }
        return particleDict(data);
      },
      py::arg("file"), py::arg("boundaries") = "periodic",
      "Read a particle file by extension (.h5/.hdf5: HDF5 snapshot, else text); boundaries apply to text files "
      "without a '# boundaries:' line");
  m.def(
      "write_particles",
      [](const std::filesystem::path& file, const py::dict& d) {
        const io::ParticleData data = particleData(d);
        py::gil_scoped_release release;
        io::writeParticles(file, data);
      },
      py::arg("file"), py::arg("data"), "Write a particle dict by extension (HDF5 also writes the .xmf sidecar)");
  m.def(
      "read_text",
      [](const std::filesystem::path& file, const py::object& boundaries) {
        return particleDict(io::readText(file, boundariesFrom(boundaries)));
      },
      py::arg("file"), py::arg("boundaries") = "periodic", "Read the text format whatever the extension");
  m.def(
      "write_text", [](const std::filesystem::path& file, const py::dict& d) { io::writeText(file, particleData(d)); },
      py::arg("file"), py::arg("data"), "Write the text format whatever the extension");
  m.def(
      "read_snapshot", [](const std::filesystem::path& file) { return particleDict(io::readSnapshot(file)); },
      py::arg("file"), "Read an HDF5 snapshot (needs a build with HDF5)");
  m.def(
      "write_snapshot",
      [](const std::filesystem::path& file, const py::dict& d) { io::writeSnapshot(file, particleData(d)); },
      py::arg("file"), py::arg("data"), "Write an HDF5 snapshot and its XDMF sidecar (needs a build with HDF5)");
  m.def("xdmf_path", &io::xdmfPath, py::arg("file"), "the XDMF sidecar written beside an HDF5 snapshot");
  m.def("is_hdf5_path", &io::isHdf5Path, py::arg("file"));
  m.def("formats", []() {
    std::vector<std::string> f = {"text"};
    if (POLYDEM_WITH_HDF5) f.emplace_back("hdf5");
    return f;
  });
}

}  // namespace polydem::python
