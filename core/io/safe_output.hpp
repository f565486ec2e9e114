#pragma once
// Outputs that never lose work: paths checked before a run starts, files written atomically.
//
// checkOutputPath() is called for every output of a command before any computation, so a run of hours
// cannot end in "cannot write": the directory must exist and be writable, the path must not be a
// directory, and it must not name one of the command's inputs (a scene file, a particle file).
//
// AtomicFile gives a temporary name in the same directory as the final file; the writer writes there and
// commit() renames it over the final name (rename(2) within one directory is atomic on POSIX file
// systems). Destroyed without commit() (an exception, an interrupt handled by unwinding) it removes the
// temporary, so the final name holds either the old complete file or the new complete file, never a
// truncated one.
#include <chrono>
#include <filesystem>
#include <iosfwd>
#include <span>
#include <string>
#include <string_view>

namespace polydem::io {

/// Throw ConfigError "WHAT 'PATH': problem" unless `output` can be created or replaced: its directory
/// exists and is writable, `output` is not a directory, and it is not the same file as any of `inputs`
/// (compared after resolving symlinks and relative paths). `what` names the option or scene key.
void checkOutputPath(const std::filesystem::path& output, std::string_view what,
                     std::span<const std::filesystem::path> inputs = {});

/// True if `a` and `b` name the same file (same canonical path, or same inode when both exist).
bool samePath(const std::filesystem::path& a, const std::filesystem::path& b);

/// A temporary file beside `final` that replaces it on commit().
class AtomicFile {
 public:
  explicit AtomicFile(std::filesystem::path final);
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  ~AtomicFile();

  /// Where to write: ".NAME.tmp-PID-COUNTER" in the directory of the final file.
  const std::filesystem::path& temporary() const { return temporary_; }
  const std::filesystem::path& final() const { return final_; }
  /// Rename the temporary over the final name (fsync of the data first). Throws InputError on failure.
  void commit();

 private:
  std::filesystem::path final_;
  std::filesystem::path temporary_;
  bool committed_ = false;
};

/// Write `text` to `file` atomically. Throws InputError naming the file if it cannot be written.
void writeFileAtomically(const std::filesystem::path& file, std::string_view text);

/// Flushes a stream that grows during a run (CSV time series) at most every `seconds` of wall time,
/// so an interrupted run keeps its rows up to a few seconds before the interrupt.
class PeriodicFlush {
 public:
  explicit PeriodicFlush(double seconds = 2.0) : seconds_(seconds), last_(std::chrono::steady_clock::now()) {}
  /// Flush `out` if `seconds` have passed since the last flush.
  void operator()(std::ostream& out);

 private:
  double seconds_;
  std::chrono::steady_clock::time_point last_;
};

}  // namespace polydem::io
