#include "core/io/safe_output.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <system_error>

#include "core/errors.hpp"

namespace polydem::io {

namespace fs = std::filesystem;

bool samePath(const fs::path& a, const fs::path& b) {
  std::error_code ea, eb;
  if (fs::exists(a, ea) && fs::exists(b, eb)) {
    std::error_code e;
    const bool same = fs::equivalent(a, b, e);
    if (!e) return same;
  }
  const fs::path ca = fs::weakly_canonical(fs::absolute(a), ea);
  const fs::path cb = fs::weakly_canonical(fs::absolute(b), eb);
  if (ea || eb) return fs::absolute(a).lexically_normal() == fs::absolute(b).lexically_normal();
  return ca == cb;
}

void checkOutputPath(const fs::path& output, std::string_view what, std::span<const fs::path> inputs) {
  if (output.empty()) throw ConfigError(fmt::format("{}: empty path", what));
  std::error_code ec;
  if (fs::is_directory(output, ec)) {
    throw ConfigError(fmt::format("{} '{}': is a directory, expected a file name", what, output.string()));
  }
  const fs::path dir = output.parent_path().empty() ? fs::path(".") : output.parent_path();
  if (!fs::is_directory(dir, ec)) {
    throw ConfigError(
        fmt::format("{} '{}': directory '{}' does not exist (create it first)", what, output.string(), dir.string()));
  }
  if (::access(dir.c_str(), W_OK | X_OK) != 0) {
    throw ConfigError(fmt::format("{} '{}': directory '{}' is not writable", what, output.string(), dir.string()));
  }
  if (fs::exists(output, ec) && ::access(output.c_str(), W_OK) != 0 && ::geteuid() != 0) {
    throw ConfigError(fmt::format("{} '{}': the file exists and is not writable", what, output.string()));
  }
  for (const fs::path& input : inputs) {
    if (!input.empty() && samePath(output, input)) {
      throw ConfigError(fmt::format("{} '{}': is the input '{}'; choose another name so the input is not overwritten",
                                    what, output.string(), input.string()));
    }
  }
}

namespace {
std::atomic<unsigned> temporaryCounter{0};
}

AtomicFile::AtomicFile(fs::path final) : final_(std::move(final)) {
  const fs::path dir = final_.parent_path();
  const std::string name =
      fmt::format(".{}.tmp-{}-{}", final_.filename().string(), static_cast<long>(::getpid()), temporaryCounter++);
  temporary_ = dir.empty() ? fs::path(name) : dir / name;
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    std::error_code ec;
    fs::remove(temporary_, ec);
  }
}

void AtomicFile::commit() {
  if (committed_) return;
  // Data on disk before the rename, so a crash right after it cannot leave an empty file.
  const int fd = ::open(temporary_.c_str(), O_RDONLY);
  if (fd < 0) {
    throw InputError(fmt::format("{}: cannot open the temporary file {}: {}", final_.string(), temporary_.string(),
                                 std::strerror(errno)));
  }
  ::fsync(fd);
  ::close(fd);
  if (std::rename(temporary_.c_str(), final_.c_str()) != 0) {
    throw InputError(
        fmt::format("{}: cannot rename {} to it: {}", final_.string(), temporary_.string(), std::strerror(errno)));
  }
  committed_ = true;
}

void writeFileAtomically(const fs::path& file, std::string_view text) {
  AtomicFile atomic(file);
  {
    std::ofstream out(atomic.temporary(), std::ios::binary);
    if (!out) throw InputError(fmt::format("{}: cannot write", file.string()));
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
    out.close();
    if (!out) throw InputError(fmt::format("{}: write failed", file.string()));
  }
  atomic.commit();
}

void PeriodicFlush::operator()(std::ostream& out) {
  const auto now = std::chrono::steady_clock::now();
  if (std::chrono::duration<double>(now - last_).count() >= seconds_) {
    out.flush();
    last_ = now;
  }
}

}  // namespace polydem::io
