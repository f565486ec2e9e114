// HDF5 snapshots and their XDMF sidecars, see hdf5_snapshot.hpp for the layout.
//
// Uses the HDF5 C API (1.10+) behind small RAII handles rather than the C++ API: the C++ API reports
// errors by exceptions whose messages name neither file nor dataset, and it is not always packaged.
// Every failure becomes an InputError "FILE: dataset PATH: problem", with HDF5's innermost error
// description appended when HDF5 itself failed.
#include "core/io/hdf5_snapshot.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>  // fmt::join

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "core/errors.hpp"
#include "core/io/contacts.hpp"
#include "core/io/hdf5_handle.hpp"
#include "core/io/safe_output.hpp"
#include "core/io/xdmf.hpp"
#include "polydem/config.hpp"

namespace polydem::io {

std::filesystem::path xdmfPath(const std::filesystem::path& file) {
  std::filesystem::path sidecar = file;
  sidecar.replace_extension(".xmf");
  return sidecar;
}

#if !POLYDEM_WITH_HDF5

void writeSnapshot(const std::filesystem::path& file, const ParticleData&) {
  throw ConfigError(
      fmt::format("{}: cannot write an HDF5 snapshot: polydem was built with POLYDEM_WITH_HDF5=OFF; "
                  "write a text file instead",
                  file.string()));
}

ParticleData readSnapshot(const std::filesystem::path& file) {
  throw ConfigError(
      fmt::format("{}: cannot read an HDF5 snapshot: polydem was built with POLYDEM_WITH_HDF5=OFF", file.string()));
}

void writeContactsHdf5(const std::filesystem::path& file, const ContactData&) {
  throw ConfigError(
      fmt::format("{}: cannot write an HDF5 contact file: polydem was built with POLYDEM_WITH_HDF5=OFF; "
                  "use text snapshots (their contact files are CSV)",
                  file.string()));
}

ContactData readContacts(const std::filesystem::path& file) {
  throw ConfigError(
      fmt::format("{}: cannot read an HDF5 contact file: polydem was built with POLYDEM_WITH_HDF5=OFF", file.string()));
}

#else

namespace {

using hdf5::Handle;
using hdf5::QuietErrors;

constexpr char kAxis[] = "xyz";

/// The innermost description on HDF5's error stack, as " (HDF5: ...)", or "" if the stack is empty.
/// Clears the stack.
std::string hdf5Detail() {
  std::string detail;
  H5Ewalk2(
      H5E_DEFAULT, H5E_WALK_UPWARD,
      [](unsigned n, const H5E_error2_t* error, void* out) -> herr_t {
        if (n == 0 && error->desc != nullptr) *static_cast<std::string*>(out) = error->desc;
        return 0;
      },
      &detail);
  H5Eclear2(H5E_DEFAULT);
  return detail.empty() ? std::string() : fmt::format(" (HDF5: {})", detail);
}

/// Error context: the file and, once known, the dataset or attribute being handled.
class Context {
 public:
  explicit Context(const std::filesystem::path& file) : name_(file.string()) {}

  [[noreturn]] void fail(std::string_view problem) const { throw InputError(fmt::format("{}: {}", name_, problem)); }
  [[noreturn]] void fail(std::string_view object, std::string_view problem) const {
    throw InputError(fmt::format("{}: {}: {}", name_, object, problem));
  }
  /// fail() with HDF5's error description appended, for failed HDF5 calls.
  [[noreturn]] void failHdf5(std::string_view object, std::string_view problem) const {
    fail(object, fmt::format("{}{}", problem, hdf5Detail()));
  }
  const std::string& name() const { return name_; }

 private:
  std::string name_;
};

std::string datasetLabel(std::string_view path) { return fmt::format("dataset {}", path); }

// ---------------------------------------------------------------------------------------------------
// Writing

/// An object creation property list with modification times off: HDF5 otherwise stamps every group and
/// dataset with the wall clock, and the same data written twice would differ in its bytes.
Handle untimedCreation(const Context& ctx, hid_t propertyClass, std::string_view object) {
  Handle plist(H5Pcreate(propertyClass), H5Pclose);
  if (!plist.valid() || H5Pset_obj_track_times(plist.get(), 0) < 0) {
    ctx.failHdf5(object, "cannot create a property list");
  }
  return plist;
}

Handle createGroup(const Context& ctx, hid_t file, const char* path) {
  const std::string label = fmt::format("group {}", path);
  const Handle gcpl = untimedCreation(ctx, H5P_GROUP_CREATE, label);
  Handle group(H5Gcreate2(file, path, H5P_DEFAULT, gcpl.get(), H5P_DEFAULT), H5Gclose);
  if (!group.valid()) ctx.failHdf5(fmt::format("group {}", path), "cannot create");
  return group;
}

void writeDataset(const Context& ctx, hid_t file, const char* path, hid_t fileType, hid_t memoryType,
                  std::initializer_list<hsize_t> dims, const void* values) {
  const std::string label = datasetLabel(path);
  std::vector<hsize_t> shape(dims);
  Handle space(H5Screate_simple(static_cast<int>(shape.size()), shape.data(), nullptr), H5Sclose);
  if (!space.valid()) ctx.failHdf5(label, "cannot create dataspace");
  const Handle dcpl = untimedCreation(ctx, H5P_DATASET_CREATE, label);
  Handle dataset(H5Dcreate2(file, path, fileType, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT), H5Dclose);
  if (!dataset.valid()) ctx.failHdf5(label, "cannot create");
  hsize_t total = 1;
  for (hsize_t d : shape) total *= d;
  // An empty Eigen array has no buffer, and HDF5 refuses a null buffer even for zero elements.
  if (total == 0) return;
  if (H5Dwrite(dataset.get(), memoryType, H5S_ALL, H5S_ALL, H5P_DEFAULT, values) < 0) {
    ctx.failHdf5(label, "cannot write");
  }
}

void writeStringAttribute(const Context& ctx, hid_t location, const std::string& locationName, const std::string& key,
                          const std::string& value) {
  const std::string label = fmt::format("attribute {}/{}", locationName, key);
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  if (!type.valid() || H5Tset_size(type.get(), H5T_VARIABLE) < 0 || H5Tset_cset(type.get(), H5T_CSET_UTF8) < 0) {
    ctx.failHdf5(label, "cannot create string type");
  }
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle attribute(H5Acreate2(location, key.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!attribute.valid()) ctx.failHdf5(label, "cannot create");
  const char* text = value.c_str();
  if (H5Awrite(attribute.get(), type.get(), &text) < 0) ctx.failHdf5(label, "cannot write");
}

void writeDoubleAttribute(const Context& ctx, hid_t location, const char* key, double value) {
  const std::string label = fmt::format("attribute /{}", key);
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle attribute(H5Acreate2(location, key, H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!attribute.valid()) ctx.failHdf5(label, "cannot create");
  if (H5Awrite(attribute.get(), H5T_NATIVE_DOUBLE, &value) < 0) ctx.failHdf5(label, "cannot write");
}

/// The XDMF text `xml` of the sidecar `sidecarName`, written to `sidecar` (a temporary that is renamed afterwards).
void writeXdmf(const std::string& sidecarName, const std::filesystem::path& sidecar, const std::string& xml) {
  std::ofstream out(sidecar, std::ios::binary | std::ios::trunc);
  if (!out) throw InputError(fmt::format("{}: cannot open for writing: {}", sidecarName, std::strerror(errno)));
  out.write(xml.data(), static_cast<std::streamsize>(xml.size()));
  out.close();
  if (!out) throw InputError(fmt::format("{}: write failed: {}", sidecarName, std::strerror(errno)));
}

/// ConfigError for attribute keys or values HDF5 cannot store (empty keys, NUL characters).
void requireStorableAttributes(const std::map<std::string, std::string>& attributes) {
  for (const auto& [key, value] : attributes) {
    if (key.empty()) throw ConfigError("particle data: attribute keys must not be empty");
    if (key.find('\0') != std::string::npos || value.find('\0') != std::string::npos) {
      throw ConfigError(
          fmt::format("particle data: attribute '{}' contains a NUL character, which HDF5 strings cannot hold",
                      key.substr(0, key.find('\0'))));
    }
  }
}

/// An empty in-memory HDF5 file for the temporary of `atomic` (written out by hdf5::writeImage()).
Handle createFile(const Context& ctx, const AtomicFile& atomic) {
  const Handle fcpl = untimedCreation(ctx, H5P_FILE_CREATE, "the root group");
  if (!std::ofstream(atomic.temporary(), std::ios::binary)) {
    ctx.fail(fmt::format("cannot create HDF5 file (is the directory there and writable?)"));
  }
  Handle h5 = hdf5::createInMemoryFile(atomic.temporary().string(), fcpl.get());
  if (!h5.valid()) ctx.fail(fmt::format("cannot create HDF5 file{}", hdf5Detail()));
  return h5;
}

/// /box/lengths and /box/periodic.
void writeBox(const Context& ctx, hid_t f, const Box& box) {
  const Handle group = createGroup(ctx, f, "/box");
  writeDataset(ctx, f, "/box/lengths", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {3}, box.lengths().data());
  const std::int8_t periodic[3] = {std::int8_t(box.periodic(0)), std::int8_t(box.periodic(1)),
                                   std::int8_t(box.periodic(2))};
  writeDataset(ctx, f, "/box/periodic", H5T_STD_I8LE, H5T_NATIVE_INT8, {3}, periodic);
}

/// /parameters with one string attribute per entry, and the root attribute time.
void writeParametersAndTime(const Context& ctx, hid_t f, const std::map<std::string, std::string>& attributes,
                            double time) {
  {
    const Handle parameters = createGroup(ctx, f, "/parameters");
    for (const auto& [key, value] : attributes) writeStringAttribute(ctx, parameters.get(), "/parameters", key, value);
  }
  writeDoubleAttribute(ctx, f, "time", time);
}

// ---------------------------------------------------------------------------------------------------
// Reading

/// True if every component of `path` ("/a/b") exists; H5Lexists alone fails on a missing parent.
bool linkExists(hid_t file, std::string_view path) {
  std::size_t pos = 0;
  while ((pos = path.find('/', pos + 1)) != std::string_view::npos) {
    if (H5Lexists(file, std::string(path.substr(0, pos)).c_str(), H5P_DEFAULT) <= 0) return false;
  }
  return H5Lexists(file, std::string(path).c_str(), H5P_DEFAULT) > 0;
}

/// An open dataset with its shape, for checking before reading.
struct Dataset {
  Handle handle;
  std::string label;
  std::vector<hsize_t> shape;
  H5T_class_t typeClass = H5T_NO_CLASS;
};

std::string shapeText(const std::vector<hsize_t>& shape) {
  if (shape.empty()) return "a scalar";
  return fmt::format("shape {}", fmt::join(shape, " x "));
}

std::string_view className(H5T_class_t c) {
  switch (c) {
    case H5T_INTEGER:
      return "integers";
    case H5T_FLOAT:
      return "floating-point numbers";
    case H5T_STRING:
      return "strings";
    case H5T_COMPOUND:
      return "a compound type";
    default:
      return "a non-numeric type";
  }
}

Dataset openDataset(const Context& ctx, hid_t file, std::string_view path) {
  Dataset d;
  d.label = datasetLabel(path);
  if (!linkExists(file, path)) ctx.fail(d.label, "missing");
  d.handle = Handle(H5Dopen2(file, std::string(path).c_str(), H5P_DEFAULT), H5Dclose);
  if (!d.handle.valid()) ctx.failHdf5(d.label, "cannot open (is it a dataset?)");
  Handle space(H5Dget_space(d.handle.get()), H5Sclose);
  const int rank = space.valid() ? H5Sget_simple_extent_ndims(space.get()) : -1;
  if (rank < 0) ctx.failHdf5(d.label, "cannot read its shape");
  d.shape.resize(static_cast<std::size_t>(rank));
  if (rank > 0 && H5Sget_simple_extent_dims(space.get(), d.shape.data(), nullptr) < 0) {
    ctx.failHdf5(d.label, "cannot read its shape");
  }
  Handle type(H5Dget_type(d.handle.get()), H5Tclose);
  if (!type.valid()) ctx.failHdf5(d.label, "cannot read its type");
  d.typeClass = H5Tget_class(type.get());
  return d;
}

void requireNumeric(const Context& ctx, const Dataset& d, bool integer) {
  const bool ok = integer ? d.typeClass == H5T_INTEGER : (d.typeClass == H5T_FLOAT || d.typeClass == H5T_INTEGER);
  if (!ok) {
    ctx.fail(d.label, fmt::format("expected {}, got {}", integer ? "integers" : "numbers", className(d.typeClass)));
  }
}

/// Require a 1-d dataset of `count` entries.
void requireEntries(const Context& ctx, const Dataset& d, hsize_t count) {
  if (d.shape.size() != 1) {
    ctx.fail(d.label, fmt::format("expected a 1-d array of {} entries, got {}", count, shapeText(d.shape)));
  }
  if (d.shape[0] != count) ctx.fail(d.label, fmt::format("expected {} entries, got {}", count, d.shape[0]));
}

/// Require an N x 3 dataset.
void requireRows(const Context& ctx, const Dataset& d, hsize_t count) {
  if (d.shape.size() != 2 || d.shape[1] != 3) {
    ctx.fail(d.label, fmt::format("expected shape {} x 3, got {}", count, shapeText(d.shape)));
  }
  if (d.shape[0] != count) ctx.fail(d.label, fmt::format("expected {} rows of 3, got {}", count, d.shape[0]));
}

void readInto(const Context& ctx, const Dataset& d, hid_t memoryType, void* out) {
  hsize_t total = 1;
  for (hsize_t s : d.shape) total *= s;
  if (total == 0) return;
  if (H5Dread(d.handle.get(), memoryType, H5S_ALL, H5S_ALL, H5P_DEFAULT, out) < 0) {
    ctx.failHdf5(d.label, "cannot read");
  }
}

Eigen::Matrix3Xd readRows(const Context& ctx, hid_t file, std::string_view path, hsize_t count) {
  const Dataset d = openDataset(ctx, file, path);
  requireNumeric(ctx, d, false);
  requireRows(ctx, d, count);
  // Row-major N x 3 in the file is exactly a column-major 3 x N matrix in memory.
  Eigen::Matrix3Xd values(3, static_cast<Eigen::Index>(count));
  readInto(ctx, d, H5T_NATIVE_DOUBLE, values.data());
  return values;
}

Eigen::VectorXd readDoubles(const Context& ctx, hid_t file, std::string_view path, hsize_t count) {
  const Dataset d = openDataset(ctx, file, path);
  requireNumeric(ctx, d, false);
  requireEntries(ctx, d, count);
  Eigen::VectorXd values(static_cast<Eigen::Index>(count));
  readInto(ctx, d, H5T_NATIVE_DOUBLE, values.data());
  return values;
}

std::vector<long long> readIntegers(const Context& ctx, hid_t file, std::string_view path, hsize_t count) {
  const Dataset d = openDataset(ctx, file, path);
  requireNumeric(ctx, d, true);
  requireEntries(ctx, d, count);
  // Read wide whatever the stored width, then range-check: HDF5 would silently clip on narrowing.
  std::vector<long long> values(static_cast<std::size_t>(count));
  readInto(ctx, d, H5T_NATIVE_LLONG, values.data());
  return values;
}

double readTime(const Context& ctx, hid_t file) {
  const std::string label = "attribute /time";
  const htri_t exists = H5Aexists(file, "time");
  if (exists < 0) ctx.failHdf5(label, "cannot query");
  if (exists == 0) return 0.0;
  Handle attribute(H5Aopen(file, "time", H5P_DEFAULT), H5Aclose);
  if (!attribute.valid()) ctx.failHdf5(label, "cannot open");
  Handle type(H5Aget_type(attribute.get()), H5Tclose);
  const H5T_class_t typeClass = H5Tget_class(type.get());
  if (typeClass != H5T_FLOAT && typeClass != H5T_INTEGER) {
    ctx.fail(label, fmt::format("expected a number, got {}", className(typeClass)));
  }
  Handle space(H5Aget_space(attribute.get()), H5Sclose);
  const hssize_t points = H5Sget_simple_extent_npoints(space.get());
  if (points != 1) ctx.fail(label, fmt::format("expected a single value, got {}", points));
  double time = 0.0;
  if (H5Aread(attribute.get(), H5T_NATIVE_DOUBLE, &time) < 0) ctx.failHdf5(label, "cannot read");
  if (!std::isfinite(time)) ctx.fail(label, fmt::format("time must be finite, got {}", time));
  return time;
}

std::string readStringAttribute(const Context& ctx, hid_t group, const std::string& key) {
  const std::string label = fmt::format("attribute /parameters/{}", key);
  Handle attribute(H5Aopen(group, key.c_str(), H5P_DEFAULT), H5Aclose);
  if (!attribute.valid()) ctx.failHdf5(label, "cannot open");
  Handle type(H5Aget_type(attribute.get()), H5Tclose);
  if (!type.valid()) ctx.failHdf5(label, "cannot read its type");
  const H5T_class_t typeClass = H5Tget_class(type.get());
  if (typeClass != H5T_STRING) ctx.fail(label, fmt::format("expected a string, got {}", className(typeClass)));
  Handle space(H5Aget_space(attribute.get()), H5Sclose);
  const hssize_t points = H5Sget_simple_extent_npoints(space.get());
  if (points != 1) ctx.fail(label, fmt::format("expected a single string, got {}", points));

  Handle memoryType(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_cset(memoryType.get(), H5Tget_cset(type.get()));  // HDF5 does not convert between character sets
  if (H5Tis_variable_str(type.get()) > 0) {
    H5Tset_size(memoryType.get(), H5T_VARIABLE);
    char* text = nullptr;
    if (H5Aread(attribute.get(), memoryType.get(), &text) < 0) ctx.failHdf5(label, "cannot read");
    std::string value = text != nullptr ? text : "";
    H5free_memory(text);
    return value;
  }
  const std::size_t size = H5Tget_size(type.get());
  // Null-padded memory type of the stored size keeps every character; the string ends at the first NUL.
  H5Tset_size(memoryType.get(), size);
  H5Tset_strpad(memoryType.get(), H5T_STR_NULLPAD);
  std::string value(size, '\0');
  if (H5Aread(attribute.get(), memoryType.get(), value.data()) < 0) ctx.failHdf5(label, "cannot read");
  value.resize(std::min(value.find('\0'), value.size()));
  return value;
}

std::map<std::string, std::string> readParameters(const Context& ctx, hid_t file) {
  std::map<std::string, std::string> parameters;
  if (!linkExists(file, "/parameters")) return parameters;
  Handle group(H5Gopen2(file, "/parameters", H5P_DEFAULT), H5Gclose);
  if (!group.valid()) ctx.failHdf5("group /parameters", "cannot open (is it a group?)");
  // Collect names first: an exception must not unwind through HDF5's C iteration.
  std::vector<std::string> names;
  const herr_t status = H5Aiterate2(
      group.get(), H5_INDEX_NAME, H5_ITER_INC, nullptr,
      [](hid_t, const char* name, const H5A_info_t*, void* out) -> herr_t {
        try {
          static_cast<std::vector<std::string>*>(out)->emplace_back(name);
          return 0;
        } catch (...) {
          return -1;
        }
      },
      &names);
  if (status < 0) ctx.failHdf5("group /parameters", "cannot list attributes");
  for (const std::string& name : names) parameters[name] = readStringAttribute(ctx, group.get(), name);
  return parameters;
}

/// The optional arrays: every dataset in /particles other than the built-in ones, N or N x 3 numbers,
/// in name order.
std::vector<ParticleArray> readArrays(const Context& ctx, hid_t file, hsize_t n) {
  std::vector<ParticleArray> arrays;
  Handle group(H5Gopen2(file, "/particles", H5P_DEFAULT), H5Gclose);
  if (!group.valid()) ctx.failHdf5("group /particles", "cannot open (is it a group?)");
  std::vector<std::string> names;
  const herr_t status = H5Literate(
      group.get(), H5_INDEX_NAME, H5_ITER_INC, nullptr,
      [](hid_t, const char* name, const H5L_info_t*, void* out) -> herr_t {
        try {
          static_cast<std::vector<std::string>*>(out)->emplace_back(name);
          return 0;
        } catch (...) {
          return -1;
        }
      },
      &names);
  if (status < 0) ctx.failHdf5("group /particles", "cannot list datasets");
  for (const std::string& name : names) {
    if (name == "position" || name == "velocity" || name == "angular_velocity" || name == "radius" || name == "id") {
      continue;
    }
    const std::string path = "/particles/" + name;
    const Dataset d = openDataset(ctx, file, path);
    requireNumeric(ctx, d, false);
    const bool scalar = d.shape.size() == 1 && d.shape[0] == n;
    const bool vector = d.shape.size() == 2 && d.shape[0] == n && d.shape[1] == 3;
    if (!scalar && !vector) {
      ctx.fail(d.label,
               fmt::format("an extra particle array must have shape {} or {} x 3, got {}", n, n, shapeText(d.shape)));
    }
    ParticleArray array{name, Eigen::MatrixXd(scalar ? 1 : 3, static_cast<Eigen::Index>(n))};
    readInto(ctx, d, H5T_NATIVE_DOUBLE, array.values.data());
    for (Eigen::Index i = 0; i < array.values.size(); ++i) {
      if (!std::isfinite(array.values.data()[i])) {
        ctx.fail(d.label,
                 fmt::format("particle {}: value {} is not finite", i / array.values.rows(), array.values.data()[i]));
      }
    }
    arrays.push_back(std::move(array));
  }
  return arrays;
}

void validate(const Context& ctx, ParticleData& data) {
  const Index n = data.count();
  const auto particle = [&](Index i) { return fmt::format("particle {} (id {})", i, data.id[std::size_t(i)]); };

  const std::string positionLabel = datasetLabel("/particles/position");
  for (Index i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) {
      const double x = data.position(k, i);
      if (!std::isfinite(x))
        ctx.fail(positionLabel, fmt::format("{}: {} = {} is not finite", particle(i), kAxis[k], x));
      if (!data.box.periodic(k) && !(x >= 0.0 && x <= data.box.length(k))) {
        ctx.fail(positionLabel, fmt::format("{}: {} = {} is outside the walled box [0, {}] along {}", particle(i),
                                            kAxis[k], x, data.box.length(k), kAxis[k]));
      }
    }
    data.position.col(i) = data.box.wrap(data.position.col(i));
  }
  const std::string radiusLabel = datasetLabel("/particles/radius");
  for (Index i = 0; i < n; ++i) {
    const double r = data.radius[i];
    if (!(std::isfinite(r) && r > 0.0)) {
      ctx.fail(radiusLabel, fmt::format("{}: radius must be positive and finite, got {}", particle(i), r));
    }
  }
  if (data.velocity) {
    const std::string velocityLabel = datasetLabel("/particles/velocity");
    for (Index i = 0; i < n; ++i) {
      for (int k = 0; k < 3; ++k) {
        const double v = (*data.velocity)(k, i);
        if (!std::isfinite(v)) {
          ctx.fail(velocityLabel, fmt::format("{}: v{} = {} is not finite", particle(i), kAxis[k], v));
        }
      }
    }
  }
  if (data.angularVelocity) {
    const std::string label = datasetLabel("/particles/angular_velocity");
    for (Index i = 0; i < n; ++i) {
      for (int k = 0; k < 3; ++k) {
        const double w = (*data.angularVelocity)(k, i);
        if (!std::isfinite(w)) ctx.fail(label, fmt::format("{}: w{} = {} is not finite", particle(i), kAxis[k], w));
      }
    }
  }
}

}  // namespace

void writeSnapshot(const std::filesystem::path& file, const ParticleData& data) {
  requireConsistentSizes(data);
  if (file.extension() == ".xmf") {
    throw ConfigError(fmt::format("{}: an HDF5 snapshot must not end in .xmf: that name is taken by its XDMF sidecar",
                                  file.string()));
  }
  requireStorableAttributes(data.attributes);

  const Context ctx(file);
  const QuietErrors quiet;
  // Both files go to temporaries beside their final names and are renamed only once complete, so an
  // interrupted or failed write leaves the previous snapshot (or nothing) under the final names.
  AtomicFile atomicH5(file);
  AtomicFile atomicXdmf(xdmfPath(file));
  Handle h5 = createFile(ctx, atomicH5);
  const hid_t f = h5.get();
  const auto n = static_cast<hsize_t>(data.count());
  {
    const Handle particles = createGroup(ctx, f, "/particles");
    writeDataset(ctx, f, "/particles/position", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n, 3}, data.position.data());
    if (data.velocity) {
      writeDataset(ctx, f, "/particles/velocity", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n, 3}, data.velocity->data());
    }
    if (data.angularVelocity) {
      writeDataset(ctx, f, "/particles/angular_velocity", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n, 3},
                   data.angularVelocity->data());
    }
    writeDataset(ctx, f, "/particles/radius", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n}, data.radius.data());
    static_assert(sizeof(Index) == 4, "/particles/id is stored as int32");
    writeDataset(ctx, f, "/particles/id", H5T_STD_I32LE, H5T_NATIVE_INT32, {n}, data.id.data());
    for (const ParticleArray& array : data.arrays) {
      const std::string path = "/particles/" + array.name;
      const auto rows = static_cast<hsize_t>(array.values.rows());
      // Column-major components x N is row-major N x components, as the vectors above.
      if (rows == 1) {
        writeDataset(ctx, f, path.c_str(), H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n}, array.values.data());
      } else {
        writeDataset(ctx, f, path.c_str(), H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {n, rows}, array.values.data());
      }
    }
  }
  {
    // Explicit Polyvertex connectivity for the XDMF readers (xdmf.hpp): 0..N-1, one vertex per cell.
    const Handle xdmf = createGroup(ctx, f, "/xdmf");
    std::vector<std::int32_t> vertices(static_cast<std::size_t>(n));
    for (std::size_t i = 0; i < vertices.size(); ++i) vertices[i] = static_cast<std::int32_t>(i);
    writeDataset(ctx, f, "/xdmf/polyvertex", H5T_STD_I32LE, H5T_NATIVE_INT32, {n, 1}, vertices.data());
  }
  writeBox(ctx, f, data.box);
  writeParametersAndTime(ctx, f, data.attributes, data.time);
  if (!hdf5::writeImage(h5, atomicH5.temporary().string())) {
    ctx.fail(fmt::format("cannot write the HDF5 file (disk full or not writable?){}", hdf5Detail()));
  }

  writeXdmf(xdmfPath(file).string(), atomicXdmf.temporary(), xdmfSnapshotXml(xdmfFrameOf(file, data), xdmfPath(file)));
  atomicH5.commit();
  atomicXdmf.commit();
}

namespace {

/// Open `file` read-only (call under QuietErrors). InputError if it is missing or not HDF5.
Handle openFile(const Context& ctx, const std::filesystem::path& file) {
  std::error_code ec;
  if (!std::filesystem::exists(file, ec)) ctx.fail("no such file");
  if (std::filesystem::is_directory(file, ec)) ctx.fail("is a directory, not an HDF5 file");
  const htri_t isHdf5 = H5Fis_hdf5(ctx.name().c_str());
  if (isHdf5 < 0) ctx.fail(fmt::format("cannot open{}", hdf5Detail()));
  if (isHdf5 == 0) ctx.fail("not an HDF5 file");
  Handle h5(H5Fopen(ctx.name().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!h5.valid()) ctx.fail(fmt::format("cannot open HDF5 file{}", hdf5Detail()));
  return h5;
}

/// /box/lengths and /box/periodic, validated.
Box readBox(const Context& ctx, hid_t f) {
  Eigen::Vector3d lengths;
  {
    const Eigen::VectorXd values = readDoubles(ctx, f, "/box/lengths", 3);
    for (int k = 0; k < 3; ++k) {
      if (!(std::isfinite(values[k]) && values[k] > 0.0)) {
        ctx.fail(datasetLabel("/box/lengths"),
                 fmt::format("box length along {} must be positive and finite, got {}", kAxis[k], values[k]));
      }
    }
    lengths = values;
  }
  std::array<Boundary, 3> boundaries{};
  {
    const std::vector<long long> values = readIntegers(ctx, f, "/box/periodic", 3);
    for (int k = 0; k < 3; ++k) {
      if (values[std::size_t(k)] != 0 && values[std::size_t(k)] != 1) {
        ctx.fail(datasetLabel("/box/periodic"), fmt::format("entry {} ({}) must be 1 (periodic) or 0 (wall), got {}", k,
                                                            kAxis[k], values[std::size_t(k)]));
      }
      boundaries[std::size_t(k)] = values[std::size_t(k)] == 1 ? Boundary::Periodic : Boundary::Wall;
    }
  }
  return Box(lengths, boundaries);
}

}  // namespace

ParticleData readSnapshot(const std::filesystem::path& file) {
  const Context ctx(file);
  const QuietErrors quiet;
  Handle h5 = openFile(ctx, file);
  const hid_t f = h5.get();

  ParticleData data;
  // The box first: wall checks need it, and a short dataset is easier to get right.
  data.box = readBox(ctx, f);

  // The particle count comes from /particles/position; every other per-particle dataset must agree.
  hsize_t n = 0;
  {
    const Dataset position = openDataset(ctx, f, "/particles/position");
    if (position.shape.size() != 2 || position.shape[1] != 3) {
      ctx.fail(position.label, fmt::format("expected shape N x 3, got {}", shapeText(position.shape)));
    }
    n = position.shape[0];
    if (n > hsize_t(std::numeric_limits<Index>::max())) {
      ctx.fail(position.label, fmt::format("{} particles exceed the maximum {}", n, std::numeric_limits<Index>::max()));
    }
  }
  data.position = readRows(ctx, f, "/particles/position", n);
  data.radius = readDoubles(ctx, f, "/particles/radius", n);
  if (linkExists(f, "/particles/velocity")) data.velocity = readRows(ctx, f, "/particles/velocity", n);
  if (linkExists(f, "/particles/angular_velocity")) {
    data.angularVelocity = readRows(ctx, f, "/particles/angular_velocity", n);
  }
  {
    const std::vector<long long> ids = readIntegers(ctx, f, "/particles/id", n);
    data.id.resize(ids.size());
    for (std::size_t i = 0; i < ids.size(); ++i) {
      if (ids[i] < 0 || ids[i] > std::numeric_limits<Index>::max()) {
        ctx.fail(datasetLabel("/particles/id"),
                 fmt::format("particle {}: id {} is outside [0, {}]", i, ids[i], std::numeric_limits<Index>::max()));
      }
      data.id[i] = static_cast<Index>(ids[i]);
    }
    std::vector<std::pair<Index, Index> > sorted(ids.size());  // (id, slot)
    for (std::size_t i = 0; i < ids.size(); ++i) sorted[i] = {data.id[i], static_cast<Index>(i)};
    std::sort(sorted.begin(), sorted.end());
    for (std::size_t i = 1; i < sorted.size(); ++i) {
      if (sorted[i].first == sorted[i - 1].first) {
        ctx.fail(datasetLabel("/particles/id"), fmt::format("id {} appears twice (particles {} and {})",
                                                            sorted[i].first, sorted[i - 1].second, sorted[i].second));
      }
    }
  }
  data.time = readTime(ctx, f);
  data.attributes = readParameters(ctx, f);
  data.arrays = readArrays(ctx, f, n);
  validate(ctx, data);
  return data;
}

// ---------------------------------------------------------------------------------------------------
// Contact files (core/io/contacts.hpp)

void writeContactsHdf5(const std::filesystem::path& file, const ContactData& data) {
  requireStorableAttributes(data.attributes);
  const Context ctx(file);
  const QuietErrors quiet;
  AtomicFile atomicH5(file);
  AtomicFile atomicXdmf(contactXdmfPath(file));
  Handle h5 = createFile(ctx, atomicH5);
  const hid_t f = h5.get();
  const auto m = static_cast<hsize_t>(data.count());
  {
    const Handle contacts = createGroup(ctx, f, "/contacts");
    static_assert(sizeof(Index) == 4, "/contacts/id_i is stored as int32");
    writeDataset(ctx, f, "/contacts/id_i", H5T_STD_I32LE, H5T_NATIVE_INT32, {m}, data.idI.data());
    writeDataset(ctx, f, "/contacts/id_j", H5T_STD_I32LE, H5T_NATIVE_INT32, {m}, data.idJ.data());
    writeDataset(ctx, f, "/contacts/centre", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {m, 3}, data.centre.data());
    writeDataset(ctx, f, "/contacts/branch", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {m, 3}, data.branch.data());
    writeDataset(ctx, f, "/contacts/overlap", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {m}, data.overlap.data());
    writeDataset(ctx, f, "/contacts/fn", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {m}, data.normalForce.data());
    Eigen::Matrix3Xd normal(3, data.count());
    for (Index c = 0; c < data.count(); ++c) normal.col(c) = data.normalForceVector(c);
    writeDataset(ctx, f, "/contacts/normal_force", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {m, 3}, normal.data());
    if (data.tangentialForce) {
      writeDataset(ctx, f, "/contacts/tangential_force", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {m, 3},
                   data.tangentialForce->data());
    }
  }
  {
    // The line cells of the XDMF sidecar: contact c runs from point 2c (centre of i) to 2c + 1 (centre + branch).
    const Handle xdmf = createGroup(ctx, f, "/xdmf");
    Eigen::Matrix3Xd points(3, 2 * data.count());
    std::vector<std::int32_t> lines(static_cast<std::size_t>(2 * m));
    for (Index c = 0; c < data.count(); ++c) {
      points.col(2 * c) = data.centre.col(c);
      points.col(2 * c + 1) = data.centre.col(c) + data.branch.col(c);
      lines[std::size_t(2 * c)] = static_cast<std::int32_t>(2 * c);
      lines[std::size_t(2 * c + 1)] = static_cast<std::int32_t>(2 * c + 1);
    }
    writeDataset(ctx, f, "/xdmf/points", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {2 * m, 3}, points.data());
    writeDataset(ctx, f, "/xdmf/lines", H5T_STD_I32LE, H5T_NATIVE_INT32, {m, 2}, lines.data());
  }
  writeBox(ctx, f, data.box);
  writeParametersAndTime(ctx, f, data.attributes, data.time);
  if (!hdf5::writeImage(h5, atomicH5.temporary().string())) {
    ctx.fail(fmt::format("cannot write the HDF5 file (disk full or not writable?){}", hdf5Detail()));
  }
  writeXdmf(contactXdmfPath(file).string(), atomicXdmf.temporary(),
            xdmfContactXml(xdmfContactFrameOf(file, data), contactXdmfPath(file)));
  atomicH5.commit();
  atomicXdmf.commit();
}

ContactData readContacts(const std::filesystem::path& file) {
  const Context ctx(file);
  const QuietErrors quiet;
  Handle h5 = openFile(ctx, file);
  const hid_t f = h5.get();
  ContactData data;
  data.box = readBox(ctx, f);
  hsize_t m = 0;
  {
    const Dataset overlap = openDataset(ctx, f, "/contacts/overlap");
    if (overlap.shape.size() != 1) {
      ctx.fail(overlap.label,
               fmt::format("expected a 1-d array (one entry per contact), got {}", shapeText(overlap.shape)));
    }
    m = overlap.shape[0];
    if (m > hsize_t(std::numeric_limits<Index>::max())) {
      ctx.fail(overlap.label, fmt::format("{} contacts exceed the maximum {}", m, std::numeric_limits<Index>::max()));
    }
  }
  data.overlap = readDoubles(ctx, f, "/contacts/overlap", m);
  data.normalForce = readDoubles(ctx, f, "/contacts/fn", m);
  data.centre = readRows(ctx, f, "/contacts/centre", m);
  data.branch = readRows(ctx, f, "/contacts/branch", m);
  if (linkExists(f, "/contacts/tangential_force"))
    data.tangentialForce = readRows(ctx, f, "/contacts/tangential_force", m);
  const std::vector<long long> idI = readIntegers(ctx, f, "/contacts/id_i", m);
  const std::vector<long long> idJ = readIntegers(ctx, f, "/contacts/id_j", m);
  data.idI.resize(idI.size());
  data.idJ.resize(idJ.size());
  for (std::size_t c = 0; c < idI.size(); ++c) {
    if (!(idI[c] >= 0 && idI[c] < idJ[c] && idJ[c] <= std::numeric_limits<Index>::max())) {
      ctx.fail(datasetLabel("/contacts/id_i"),
               fmt::format("contact {}: ids ({}, {}) must satisfy 0 <= id_i < id_j", c, idI[c], idJ[c]));
    }
    data.idI[c] = static_cast<Index>(idI[c]);
    data.idJ[c] = static_cast<Index>(idJ[c]);
  }
  data.time = readTime(ctx, f);
  data.attributes = readParameters(ctx, f);
  return data;
}

#endif  // POLYDEM_WITH_HDF5

}  // namespace polydem::io
