#include "core/io/checkpoint.hpp"

#include <fmt/format.h>

#include "core/errors.hpp"
#include "core/io/hdf5_handle.hpp"
#include "core/io/safe_output.hpp"

namespace polydem::io {

namespace {
constexpr std::int64_t kFormat = 1;

[[noreturn]] void missing(const Checkpoint& c, const std::string& name, const std::string& problem) {
  throw InputError(fmt::format("{}: checkpoint entry {}: {}", c.source.string(), name, problem));
}
}  // namespace

void Checkpoint::putVector(const std::string& name, const Eigen::VectorXd& v) {
  real[name].assign(v.data(), v.data() + v.size());
}

void Checkpoint::putMatrix(const std::string& name, const Eigen::Matrix3Xd& m) {
  real[name].assign(m.data(), m.data() + m.size());
}

const std::vector<double>& Checkpoint::reals(const std::string& name) const {
  const auto it = real.find(name);
  if (it == real.end()) missing(*this, name, "missing");
  return it->second;
}

const std::vector<std::int64_t>& Checkpoint::integers(const std::string& name) const {
  const auto it = integer.find(name);
  if (it == integer.end()) missing(*this, name, "missing");
  return it->second;
}

const std::string& Checkpoint::string(const std::string& name) const {
  const auto it = text.find(name);
  if (it == text.end()) missing(*this, name, "missing");
  return it->second;
}

double Checkpoint::scalar(const std::string& name) const {
  const auto& v = reals(name);
  if (v.size() != 1) missing(*this, name, fmt::format("expected one value, got {}", v.size()));
  return v[0];
}

std::int64_t Checkpoint::integerScalar(const std::string& name) const {
  const auto& v = integers(name);
  if (v.size() != 1) missing(*this, name, fmt::format("expected one value, got {}", v.size()));
  return v[0];
}

Eigen::VectorXd Checkpoint::vector(const std::string& name) const {
  const auto& v = reals(name);
  return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

Eigen::Matrix3Xd Checkpoint::matrix(const std::string& name, std::int64_t columns) const {
  const auto& v = reals(name);
  if (static_cast<std::int64_t>(v.size()) != 3 * columns) {
    missing(*this, name, fmt::format("expected 3 x {} values, got {}", columns, v.size()));
  }
  return Eigen::Map<const Eigen::Matrix3Xd>(v.data(), 3, static_cast<Eigen::Index>(columns));
}

#if !POLYDEM_WITH_HDF5

void writeCheckpoint(const std::filesystem::path& file, const Checkpoint&) {
  throw ConfigError(
      fmt::format("{}: checkpoints need HDF5; polydem was built with POLYDEM_WITH_HDF5=OFF", file.string()));
}
Checkpoint readCheckpoint(const std::filesystem::path& file, const std::string&) {
  throw ConfigError(
      fmt::format("{}: checkpoints need HDF5; polydem was built with POLYDEM_WITH_HDF5=OFF", file.string()));
}

#else

namespace {

using hdf5::Handle;
using hdf5::QuietErrors;

/// A creation property list of `propertyClass` with object time stamps off: HDF5 otherwise stamps every
/// group and dataset with the wall clock, and the same checkpoint written twice would differ in bytes.
Handle untimedCreation(hid_t propertyClass, const std::string& file) {
  Handle plist(H5Pcreate(propertyClass), H5Pclose);
  if (!plist.valid() || H5Pset_obj_track_times(plist.get(), 0) < 0) {
    throw InputError(fmt::format("{}: cannot create an HDF5 property list", file));
  }
  return plist;
}

Handle createGroup(hid_t parent, const char* path, const std::string& file) {
  const Handle gcpl = untimedCreation(H5P_GROUP_CREATE, file);
  Handle group(H5Gcreate2(parent, path, H5P_DEFAULT, gcpl.get(), H5P_DEFAULT), H5Gclose);
  if (!group.valid()) throw InputError(fmt::format("{}: cannot create checkpoint group {}", file, path));
  return group;
}

void writeStringAttribute(hid_t object, const std::string& name, const std::string& value, const std::string& file) {
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type.get(), value.empty() ? 1 : value.size());
  H5Tset_strpad(type.get(), H5T_STR_NULLPAD);
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle attr(H5Acreate2(object, name.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!attr.valid() || H5Awrite(attr.get(), type.get(), value.empty() ? "" : value.data()) < 0) {
    throw InputError(fmt::format("{}: cannot write checkpoint attribute {}", file, name));
  }
}

std::string readStringAttribute(hid_t object, const char* name, const std::string& file) {
  Handle attr(H5Aopen(object, name, H5P_DEFAULT), H5Aclose);
  if (!attr.valid()) throw InputError(fmt::format("{}: checkpoint attribute {} is missing", file, name));
  Handle type(H5Aget_type(attr.get()), H5Tclose);
  if (H5Tget_class(type.get()) != H5T_STRING || H5Tis_variable_str(type.get()) > 0) {
    throw InputError(fmt::format("{}: checkpoint attribute {}: expected a fixed-length string", file, name));
  }
  const std::size_t size = H5Tget_size(type.get());
  std::string value(size, '\0');
  Handle memType(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(memType.get(), size);
  H5Tset_strpad(memType.get(), H5T_STR_NULLPAD);
  if (H5Aread(attr.get(), memType.get(), value.data()) < 0) {
    throw InputError(fmt::format("{}: cannot read checkpoint attribute {}", file, name));
  }
  value.resize(value.find('\0') == std::string::npos ? size : value.find('\0'));
  return value;
}

template <class T>
void writeDataset(hid_t group, const std::string& name, const std::vector<T>& values, hid_t type,
                  const std::string& file) {
  if (name.empty() || name.find('/') != std::string::npos) {
    throw ConfigError(fmt::format("{}: checkpoint entry name '{}' must be non-empty without '/'", file, name));
  }
  const hsize_t n = values.size();
  Handle space(H5Screate_simple(1, &n, nullptr), H5Sclose);
  const Handle dcpl = untimedCreation(H5P_DATASET_CREATE, file);
  Handle set(H5Dcreate2(group, name.c_str(), type, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT), H5Dclose);
  if (!set.valid() || (n > 0 && H5Dwrite(set.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) < 0)) {
    throw InputError(fmt::format("{}: cannot write checkpoint entry {}", file, name));
  }
}

struct Listing {
  std::vector<std::string> names;
};

herr_t collectName(hid_t, const char* name, const H5L_info_t*, void* out) {
  static_cast<Listing*>(out)->names.emplace_back(name);
  return 0;
}

herr_t collectAttribute(hid_t, const char* name, const H5A_info_t*, void* out) {
  static_cast<Listing*>(out)->names.emplace_back(name);
  return 0;
}

template <class T>
std::vector<T> readDataset(hid_t group, const std::string& name, hid_t memType, H5T_class_t cls,
                           const std::string& file) {
  Handle set(H5Dopen2(group, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!set.valid()) throw InputError(fmt::format("{}: cannot open checkpoint entry {}", file, name));
  Handle type(H5Dget_type(set.get()), H5Tclose);
  if (H5Tget_class(type.get()) != cls) {
    throw InputError(fmt::format("{}: checkpoint entry {}: wrong type", file, name));
  }
  Handle space(H5Dget_space(set.get()), H5Sclose);
  if (H5Sget_simple_extent_ndims(space.get()) != 1) {
    throw InputError(fmt::format("{}: checkpoint entry {}: expected a 1-D dataset", file, name));
  }
  hsize_t n = 0;
  H5Sget_simple_extent_dims(space.get(), &n, nullptr);
  std::vector<T> values(n);
  if (n > 0 && H5Dread(set.get(), memType, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) < 0) {
    throw InputError(fmt::format("{}: cannot read checkpoint entry {}", file, name));
  }
  return values;
}

Handle openGroup(hid_t parent, const char* name, const std::string& file) {
  Handle g(H5Gopen2(parent, name, H5P_DEFAULT), H5Gclose);
  if (!g.valid()) throw InputError(fmt::format("{}: not a polydem checkpoint (no group {})", file, name));
  return g;
}

}  // namespace

void writeCheckpoint(const std::filesystem::path& file, const Checkpoint& checkpoint) {
  const std::string name = file.string();
  if (checkpoint.kind.empty()) throw ConfigError(fmt::format("{}: checkpoint without a kind", name));
  QuietErrors quiet;
  AtomicFile atomic(file);
  {
    const Handle fcpl = untimedCreation(H5P_FILE_CREATE, name);
    Handle h = hdf5::createInMemoryFile(atomic.temporary().string(), fcpl.get());
    if (!h.valid()) throw InputError(fmt::format("{}: cannot create the checkpoint file", name));
    Handle root = createGroup(h.get(), "checkpoint", name);
    writeStringAttribute(root.get(), "kind", checkpoint.kind, name);
    writeStringAttribute(root.get(), "format", std::to_string(kFormat), name);
    {
      const Handle g = createGroup(root.get(), "real", name);
      for (const auto& [key, values] : checkpoint.real) writeDataset(g.get(), key, values, H5T_NATIVE_DOUBLE, name);
    }
    {
      const Handle g = createGroup(root.get(), "integer", name);
      for (const auto& [key, values] : checkpoint.integer) writeDataset(g.get(), key, values, H5T_NATIVE_INT64, name);
    }
    {
      const Handle g = createGroup(root.get(), "text", name);
      for (const auto& [key, value] : checkpoint.text) {
        if (key.empty()) throw ConfigError(fmt::format("{}: checkpoint text entry with an empty name", name));
        writeStringAttribute(g.get(), key, value, name);
      }
    }
    root.reset();
    if (!hdf5::writeImage(h, atomic.temporary().string())) {
      throw InputError(fmt::format("{}: cannot write the checkpoint (disk full or not writable?)", name));
    }
  }
  atomic.commit();
}

Checkpoint readCheckpoint(const std::filesystem::path& file, const std::string& expectedKind) {
  const std::string name = file.string();
  QuietErrors quiet;
  Checkpoint c;
  c.source = file;
  Handle h(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!h.valid()) throw InputError(fmt::format("{}: cannot open as an HDF5 checkpoint", name));
  Handle root = openGroup(h.get(), "checkpoint", name);
  c.kind = readStringAttribute(root.get(), "kind", name);
  const std::string format = readStringAttribute(root.get(), "format", name);
  if (format != std::to_string(kFormat)) {
    throw InputError(fmt::format("{}: checkpoint format {} (this polydem reads {})", name, format, kFormat));
  }
  if (!expectedKind.empty() && c.kind != expectedKind) {
    throw InputError(fmt::format("{}: a '{}' checkpoint, expected '{}'", name, c.kind, expectedKind));
  }
  {
    Handle g = openGroup(root.get(), "real", name);
    Listing list;
    H5Literate(g.get(), H5_INDEX_NAME, H5_ITER_INC, nullptr, &collectName, &list);
    for (const auto& key : list.names) {
      c.real[key] = readDataset<double>(g.get(), key, H5T_NATIVE_DOUBLE, H5T_FLOAT, name);
    }
  }
  {
    Handle g = openGroup(root.get(), "integer", name);
    Listing list;
    H5Literate(g.get(), H5_INDEX_NAME, H5_ITER_INC, nullptr, &collectName, &list);
    for (const auto& key : list.names) {
      c.integer[key] = readDataset<std::int64_t>(g.get(), key, H5T_NATIVE_INT64, H5T_INTEGER, name);
    }
  }
  {
    Handle g = openGroup(root.get(), "text", name);
    Listing list;
    H5Aiterate2(g.get(), H5_INDEX_NAME, H5_ITER_INC, nullptr, &collectAttribute, &list);
    for (const auto& key : list.names) c.text[key] = readStringAttribute(g.get(), key.c_str(), name);
  }
  return c;
}

#endif

}  // namespace polydem::io
