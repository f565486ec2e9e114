#pragma once
// Checkpoint files: the complete state of a run (relax or jam) as named arrays and strings in one HDF5
// file, written atomically, so that `--resume FILE` continues the run byte-identically.
//
// Layout: /checkpoint (group) with attributes "kind" (e.g. "relax", "jam") and "format" (integer version);
//   /checkpoint/real/NAME     1-D double datasets (a 3 x N matrix is stored column-major, length 3N)
//   /checkpoint/integer/NAME  1-D int64 datasets
//   /checkpoint/text/NAME     scalar string attributes of the group /checkpoint/text
// Values are stored bit-exact. Reading is strict: a missing entry or a wrong length throws InputError
// naming the file and the entry.
//
// Built without HDF5 (POLYDEM_WITH_HDF5=OFF), both functions throw ConfigError.
#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace polydem::io {

struct Checkpoint {
  std::string kind;  ///< what wrote it: "relax", "jam"
  std::map<std::string, std::vector<double>> real;
  std::map<std::string, std::vector<std::int64_t>> integer;
  std::map<std::string, std::string> text;
  std::filesystem::path source;  ///< set by readCheckpoint(), for messages

  void putScalar(const std::string& name, double v) { real[name] = {v}; }
  void putInteger(const std::string& name, std::int64_t v) { integer[name] = {v}; }
  void putVector(const std::string& name, const Eigen::VectorXd& v);
  void putMatrix(const std::string& name, const Eigen::Matrix3Xd& m);

  /// Accessors throw InputError "FILE: checkpoint entry NAME: problem" when absent or of the wrong size.
  double scalar(const std::string& name) const;
  std::int64_t integerScalar(const std::string& name) const;
  Eigen::VectorXd vector(const std::string& name) const;
  /// A 3 x `columns` matrix stored by putMatrix().
  Eigen::Matrix3Xd matrix(const std::string& name, std::int64_t columns) const;
  const std::vector<double>& reals(const std::string& name) const;
  const std::vector<std::int64_t>& integers(const std::string& name) const;
  const std::string& string(const std::string& name) const;
  bool has(const std::string& name) const { return real.count(name) || integer.count(name) || text.count(name); }
};

/// Write `checkpoint` to `file` atomically (temporary beside it, then rename). Throws InputError if the
/// file cannot be written, ConfigError for an empty kind or entry name.
void writeCheckpoint(const std::filesystem::path& file, const Checkpoint& checkpoint);

/// Read a checkpoint. `expectedKind` non-empty: throw InputError unless the file's kind matches (a jam
/// checkpoint given to relax --resume, say).
Checkpoint readCheckpoint(const std::filesystem::path& file, const std::string& expectedKind = {});

}  // namespace polydem::io
