// Particle files (core/io/particle_file.hpp): text, and HDF5 snapshots with XDMF sidecars when built with
// HDF5. A file is a dict: positions (N, 3), radii (N,), id (N,) int32, box, time, attributes, and
// velocities / angular_velocities (N, 3) or None.
#include "python/io.hpp"

#include <fmt/format.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "apps/polydem/convert.hpp"
#include "core/errors.hpp"
#include "core/io/hdf5_snapshot.hpp"
#include "core/io/lammps_data.hpp"
#include "core/io/lammps_dump.hpp"
#include "core/io/particle_file.hpp"
#include "core/io/xdmf.hpp"
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
  // Optional per-particle arrays (LAMMPS type / density / image, output arrays such as force), in file order:
  // (N,) for one component, (N, 3) for three.
  py::dict arrays;
  for (const io::ParticleArray& a : data.arrays) {
    if (a.values.rows() == 3) {
      arrays[py::str(a.name)] = copyOut(Eigen::Matrix3Xd(a.values));
    } else {
      arrays[py::str(a.name)] = copyOut(Eigen::VectorXd(a.values.row(0).transpose()));
    }
  }
  d["arrays"] = arrays;
  return d;
}

io::ParticleData particleData(const py::dict& d) {
  static const std::vector<std::string> known = {"positions", "radii",      "id",   "velocities", "angular_velocities",
                                                 "box",       "boundaries", "time", "attributes", "arrays"};
  for (const auto& item : d) {
    const std::string key = py::str(item.first);
    if (std::find(known.begin(), known.end(), key) == known.end()) {
      throw ConfigError(
          fmt::format("particle data: unknown key '{}' (expected one of positions, radii, id, "
                      "velocities, angular_velocities, box, boundaries, time, attributes, arrays)",
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
  if (d.contains("arrays") && !d["arrays"].is_none()) {
    for (const auto& item : d["arrays"].cast<py::dict>()) {
      const std::string name = py::str(item.first);
      const std::string what = "arrays['" + name + "']";
      auto a = DoubleArray::ensure(item.second);
      if (!a) throw ConfigError(fmt::format("{}: expected an array of shape (N,) or (N, 3)", what));
      io::ParticleArray array;
      array.name = name;
      if (a.ndim() == 1) {
        array.values = toVector(a, what).transpose();
      } else {
        array.values = toMatrix3X(a, what);
      }
      data.arrays.push_back(std::move(array));
    }
  }
  io::requireConsistentSizes(data);
  return data;
}

namespace {

/// Frames of a dump: one particle dict or a sequence of them.
std::vector<io::ParticleData> framesOf(const py::object& frames) {
  std::vector<io::ParticleData> out;
  if (py::isinstance<py::dict>(frames)) {
    out.push_back(particleData(frames.cast<py::dict>()));
    return out;
  }
  for (const py::handle& f : frames) {
    if (!py::isinstance<py::dict>(f)) throw ConfigError("frames: expected a particle dict or a list of them");
    out.push_back(particleData(f.cast<py::dict>()));
  }
  if (out.empty()) throw ConfigError("frames: a dump needs at least one frame");
  return out;
}

}  // namespace

io::ParticleData particlesFrom(const py::object& packing, std::string& name) {
  if (py::isinstance<py::dict>(packing)) {
    name = "packing";
    return particleData(packing.cast<py::dict>());
  }
  const auto file = packing.cast<std::filesystem::path>();
  name = file.string();
  py::gil_scoped_release release;
  return io::readParticles(file);
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
      "Read a particle file by extension (.h5/.hdf5: HDF5 snapshot; .data/.lmp/data.*: LAMMPS data; "
      ".dump/.lammpstrj/dump.*: a one-frame LAMMPS dump; else text); boundaries apply to text files without a "
      "'# boundaries:' line and to LAMMPS data files");
  m.def(
      "write_particles",
      [](const std::filesystem::path& file, const py::dict& d) {
        const io::ParticleData data = particleData(d);
        py::gil_scoped_release release;
        io::writeParticles(file, data);
      },
      py::arg("file"), py::arg("data"),
      "Write a particle dict by extension, as read_particles reads it (HDF5 also writes the .xmf sidecar)");
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
  m.def(
      "read_lammps_data",
      [](const std::filesystem::path& file, const py::object& boundaries) {
        const auto b = boundariesFrom(boundaries);
        io::ParticleData data;
        {
          py::gil_scoped_release release;
          data = io::readLammpsData(file, b);
        }
        return particleDict(data);
      },
      py::arg("file"), py::arg("boundaries") = "periodic",
      "Read a LAMMPS data file (atom_style sphere) whatever the extension; data files carry no boundaries: "
      "`boundaries` decides. Atom types, densities and image flags come back in `arrays`");
  m.def(
      "write_lammps_data",
      [](const std::filesystem::path& file, const py::dict& d) {
        const io::ParticleData data = particleData(d);
        py::gil_scoped_release release;
        io::writeLammpsData(file, data);
      },
      py::arg("file"), py::arg("data"),
      "Write a LAMMPS data file (atom_style sphere, Velocities section with velocities) whatever the extension");
  m.def(
      "read_lammps_dump",
      [](const std::filesystem::path& file) {
        std::vector<io::ParticleData> frames;
        {
          py::gil_scoped_release release;
          frames = io::readLammpsDump(file);
        }
        py::list out;
        for (const io::ParticleData& f : frames) out.append(particleDict(f));
        return out;
      },
      py::arg("file"),
      "Every frame of a LAMMPS dump (a list of particle dicts); read_particles takes a one-frame dump");
  m.def(
      "write_lammps_dump",
      [](const std::filesystem::path& file, const py::object& frames) {
        const std::vector<io::ParticleData> data = framesOf(frames);
        py::gil_scoped_release release;
        io::writeLammpsDump(file, data);
      },
      py::arg("file"), py::arg("frames"),
      "Write one particle dict or a list of them as a multi-frame LAMMPS dump (arrays become extra columns)");
  m.def(
      "write_xdmf_series",
      [](const std::filesystem::path& file, const std::vector<std::filesystem::path>& snapshots) {
        py::gil_scoped_release release;
        return app::writeSeries(file, snapshots).size();
      },
      py::arg("file"), py::arg("snapshots"),
      "`polydem convert --series FILE.xmf SNAPSHOTS...`: an XDMF temporal series over HDF5 snapshots (ParaView, "
      "meshio's TimeSeriesReader); returns the number of frames");
  m.def("series_path_for", &io::seriesPathFor, py::arg("pattern"),
        "the series file that accompanies a snapshot pattern such as 'out/snap_{step}.h5'");
  m.def("xdmf_path", &io::xdmfPath, py::arg("file"), "the XDMF sidecar written beside an HDF5 snapshot");
  m.def("is_hdf5_path", &io::isHdf5Path, py::arg("file"));
  m.def("formats", []() {
    std::vector<std::string> f = {"text"};
    if (POLYDEM_WITH_HDF5) f.emplace_back("hdf5");
    f.emplace_back("lammps-data");
    f.emplace_back("lammps-dump");
    if (POLYDEM_WITH_HDF5) f.emplace_back("xdmf-series");
    return f;
  });
}

}  // namespace polydem::python
