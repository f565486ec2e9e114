#pragma once
// Internal to core/io: RAII handles for the HDF5 C API, shared by the snapshot and checkpoint files.
#include "polydem/config.hpp"

#if POLYDEM_WITH_HDF5
#include <hdf5.h>

#include <fstream>
#include <string>
#include <utility>
#include <vector>

namespace polydem::io::hdf5 {

/// Owns one hid_t and closes it with the matching H5?close.
class Handle {
 public:
  using Closer = herr_t (*)(hid_t);
  Handle() = default;
  Handle(hid_t id, Closer close) : id_(id), close_(close) {}
  Handle(Handle&& other) noexcept : id_(std::exchange(other.id_, H5I_INVALID_HID)), close_(other.close_) {}
  Handle& operator=(Handle&& other) noexcept {
    if (this != &other) {
      reset();
      id_ = std::exchange(other.id_, H5I_INVALID_HID);
      close_ = other.close_;
    }
    return *this;
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() { reset(); }

  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }
  /// Close now and report whether closing succeeded (closing a file flushes it).
  bool close() {
    const herr_t status = id_ >= 0 ? close_(id_) : 0;
    id_ = H5I_INVALID_HID;
    return status >= 0;
  }
  void reset() {
    if (id_ >= 0) close_(id_);
    id_ = H5I_INVALID_HID;
  }

 private:
  hid_t id_ = H5I_INVALID_HID;
  Closer close_ = nullptr;
};

/// Turns off HDF5's automatic error printing for its lifetime; we report errors as exceptions.
class QuietErrors {
 public:
  QuietErrors() {
    H5Eget_auto2(H5E_DEFAULT, &function_, &clientData_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  QuietErrors(const QuietErrors&) = delete;
  QuietErrors& operator=(const QuietErrors&) = delete;
  ~QuietErrors() { H5Eset_auto2(H5E_DEFAULT, function_, clientData_); }

 private:
  H5E_auto2_t function_ = nullptr;
  void* clientData_ = nullptr;
};

/// Create an HDF5 file in memory (core driver, no backing store): nothing touches the disk until
/// writeImage(), so a full disk or a file-size limit is an ordinary write error in our code instead of
/// a half-closed HDF5 file that the library trips over again at exit. Invalid handle on failure.
inline Handle createInMemoryFile(const std::string& name, hid_t fcpl) {
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  if (!fapl.valid() || H5Pset_fapl_core(fapl.get(), std::size_t(1) << 20, 0) < 0) return Handle();
  return Handle(H5Fcreate(name.c_str(), H5F_ACC_TRUNC, fcpl, fapl.get()), H5Fclose);
}

/// Flush the in-memory file `f`, write its image to `path`, close `f`. False on any failure.
inline bool writeImage(Handle& f, const std::string& path) {
  if (H5Fflush(f.get(), H5F_SCOPE_GLOBAL) < 0) return false;
  const ssize_t size = H5Fget_file_image(f.get(), nullptr, 0);
  if (size < 0) return false;
  std::vector<char> image(static_cast<std::size_t>(size));
  if (size > 0 && H5Fget_file_image(f.get(), image.data(), image.size()) != size) return false;
  if (!f.close()) return false;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) return false;
  out.write(image.data(), static_cast<std::streamsize>(image.size()));
  out.close();
  return static_cast<bool>(out);
}

}  // namespace polydem::io::hdf5
#endif
