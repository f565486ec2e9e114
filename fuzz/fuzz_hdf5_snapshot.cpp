// libFuzzer target: io::readSnapshot on HDF5 files built from the fuzzer's bytes.
//
// Structure-aware rather than raw bytes: the input decides which of the snapshot's datasets and
// attributes exist, with which type, shape and values (NaN, infinities, huge ids, wrong ranks, strings
// where numbers belong, groups where datasets belong), and the file is written with the HDF5 library to a
// temporary path. Raw byte mutation would mostly exercise libhdf5's own superblock parser, which is not
// ours to fix; this reaches every check of our reader. A few inputs are also used as raw bytes (first
// byte 0xFF) so a truncated or corrupt file still goes through the open path.
// Properties: only InputError escapes readSnapshot; a file that reads writes back (writeSnapshot) and
// reads again to the same data.
#include <fuzzer/FuzzedDataProvider.h>
#include <hdf5.h>

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "core/errors.hpp"
#include "core/io/hdf5_snapshot.hpp"
#include "fuzz/fuzz_support.hpp"

namespace {

enum class Kind : std::uint8_t { F64, F32, I32, I8, U64, String, Group };

hid_t fileType(Kind kind) {
  switch (kind) {
    case Kind::F64:
      return H5T_IEEE_F64LE;
    case Kind::F32:
      return H5T_IEEE_F32LE;
    case Kind::I32:
      return H5T_STD_I32LE;
    case Kind::I8:
      return H5T_STD_I8LE;
    default:
      return H5T_STD_U64LE;
  }
}

double interestingDouble(FuzzedDataProvider& in) {
  switch (in.ConsumeIntegralInRange<int>(0, 7)) {
    case 0:
      return std::numeric_limits<double>::quiet_NaN();
    case 1:
      return std::numeric_limits<double>::infinity();
    case 2:
      return -std::numeric_limits<double>::infinity();
    case 3:
      return -0.0;
    case 4:
      return std::numeric_limits<double>::denorm_min();
    default:
      return in.ConsumeFloatingPointInRange<double>(-4.0, 12.0);
  }
}

/// A dataset at `path` whose kind, shape and values come from the input; `n` is the particle count the
/// other datasets use, so consistent shapes are frequent.
void writeDataset(FuzzedDataProvider& in, hid_t file, const char* path, hsize_t n, hsize_t columns) {
  if (in.ConsumeIntegralInRange<int>(0, 9) == 0) return;  // missing
  const auto kind =
      static_cast<Kind>(in.ConsumeIntegralInRange<int>(0, 9) < 7 ? 0 : in.ConsumeIntegralInRange<int>(0, 6));
  if (kind == Kind::Group) {
    H5Gclose(H5Gcreate2(file, path, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
    return;
  }
  std::vector<hsize_t> dims;
  if (in.ConsumeIntegralInRange<int>(0, 7) != 0) {
    dims.push_back(n);
    if (columns > 0) dims.push_back(columns);
  } else {
    const int rank = in.ConsumeIntegralInRange<int>(0, 3);
    for (int r = 0; r < rank; ++r) dims.push_back(in.ConsumeIntegralInRange<hsize_t>(0, 5));
  }
  hsize_t total = 1;
  for (hsize_t d : dims) total *= d;
  const hid_t space = dims.empty() ? H5Screate(H5S_SCALAR) : H5Screate_simple(int(dims.size()), dims.data(), nullptr);
  if (kind == Kind::String) {
    const hid_t type = H5Tcopy(H5T_C_S1);
    H5Tset_size(type, 8);
    const hid_t d = H5Dcreate2(file, path, type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    std::string text(8 * total, 'x');
    if (total > 0) H5Dwrite(d, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, text.data());
    H5Dclose(d);
    H5Tclose(type);
  } else {
    std::vector<double> values(total);
    for (double& v : values) {
      v = kind == Kind::F64 || kind == Kind::F32 ? interestingDouble(in)
                                                 : static_cast<double>(in.ConsumeIntegralInRange<int>(-3, 300));
    }
    if (kind == Kind::U64 && !values.empty() && in.ConsumeBool()) values[0] = 1e19;  // beyond int64
    const hid_t d = H5Dcreate2(file, path, fileType(kind), space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    if (total > 0) H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data());
    H5Dclose(d);
  }
  H5Sclose(space);
}

void writeAttribute(FuzzedDataProvider& in, hid_t location, const std::string& name) {
  const int kind = in.ConsumeIntegralInRange<int>(0, 4);
  const bool array = in.ConsumeIntegralInRange<int>(0, 5) == 0;
  const hsize_t two = 2;
  const hid_t space = array ? H5Screate_simple(1, &two, nullptr) : H5Screate(H5S_SCALAR);
  if (kind <= 1) {  // variable or fixed-length string
    const hid_t type = H5Tcopy(H5T_C_S1);
    const std::string value = in.ConsumeRandomLengthString(40);
    H5Tset_size(type, kind == 0 ? H5T_VARIABLE : std::max<std::size_t>(1, value.size()));
    if (in.ConsumeBool()) H5Tset_cset(type, H5T_CSET_UTF8);
    const hid_t a = H5Acreate2(location, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT);
    if (a >= 0) {
      if (kind == 0) {
        const char* texts[2] = {value.c_str(), value.c_str()};
        H5Awrite(a, type, texts);
      } else {
        std::string buffer = value;
        buffer.resize(std::max<std::size_t>(1, value.size()) * 2, '\0');
        H5Awrite(a, type, buffer.data());
      }
      H5Aclose(a);
    }
    H5Tclose(type);
  } else {
    const double values[2] = {interestingDouble(in), interestingDouble(in)};
    const hid_t a =
        H5Acreate2(location, name.c_str(), kind == 2 ? H5T_IEEE_F64LE : H5T_STD_I32LE, space, H5P_DEFAULT, H5P_DEFAULT);
    if (a >= 0) {
      H5Awrite(a, H5T_NATIVE_DOUBLE, values);
      H5Aclose(a);
    }
  }
  H5Sclose(space);
}

bool bitEqual(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  // memcmp must not see the null buffer of an empty matrix.
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         (a.size() == 0 || std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<std::size_t>(a.size())) == 0);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace polydem;
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // building odd files is noisy by design
  const auto file = fuzz::scratch("snapshot.h5");
  if (size > 0 && data[0] == 0xFF) {
    fuzz::writeBytes(file, data + 1, size - 1);
  } else {
    FuzzedDataProvider in(data, size);
    const hid_t f = H5Fcreate(file.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    if (f < 0) return 0;
    const hsize_t n = in.ConsumeIntegralInRange<hsize_t>(0, 6);
    if (in.ConsumeIntegralInRange<int>(0, 9) != 0)
      H5Gclose(H5Gcreate2(f, "/box", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
    writeDataset(in, f, "/box/lengths", 3, 0);
    writeDataset(in, f, "/box/periodic", 3, 0);
    if (in.ConsumeIntegralInRange<int>(0, 9) != 0) {
      H5Gclose(H5Gcreate2(f, "/particles", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
    }
    writeDataset(in, f, "/particles/position", n, 3);
    writeDataset(in, f, "/particles/radius", n, 0);
    writeDataset(in, f, "/particles/id", n, 0);
    if (in.ConsumeBool()) writeDataset(in, f, "/particles/velocity", n, 3);
    if (in.ConsumeBool()) writeDataset(in, f, "/particles/angular_velocity", n, 3);
    if (in.ConsumeBool()) writeAttribute(in, f, "time");
    if (in.ConsumeBool()) {
      const hid_t g = H5Gcreate2(f, "/parameters", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
      const int count = in.ConsumeIntegralInRange<int>(0, 4);
      for (int k = 0; k < count; ++k) {
        std::string name = in.ConsumeRandomLengthString(12);
        if (name.empty() || name.find('\0') != std::string::npos || name == ".") name = "k" + std::to_string(k);
        writeAttribute(in, g, name);
      }
      H5Gclose(g);
    }
    H5Fclose(f);
  }
  io::ParticleData read;
  try {
    read = io::readSnapshot(file);
  } catch (const InputError&) {
    return 0;
  }
  const auto copy = fuzz::scratch("copy.h5");
  try {
    io::writeSnapshot(copy, read);
  } catch (const ConfigError&) {
    return 0;  // e.g. an attribute holding a NUL: refused by the writer with a message
  }
  const io::ParticleData back = io::readSnapshot(copy);
  if (!(back.box == read.box) || !bitEqual(back.position, read.position) || !bitEqual(back.radius, read.radius) ||
      back.id != read.id || back.attributes != read.attributes || back.time != read.time ||
      back.velocity.has_value() != read.velocity.has_value() ||
      back.angularVelocity.has_value() != read.angularVelocity.has_value()) {
    fuzz::broken("snapshot changed on a write/read round trip");
  }
  return 0;
}
