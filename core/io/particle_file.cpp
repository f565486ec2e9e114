// Plain text particle files, see particle_file.hpp for the format.
//
// Numbers are parsed with std::from_chars: locale-independent and correctly rounded, so a file written
// with %.17g reads back bit-exactly. Rejected design: iostream >> double, which depends on the global
// locale and accepts trailing garbage ("1.5abc" reads as 1.5).
#include "core/io/particle_file.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <string_view>
#include <system_error>

#include <fmt/format.h>

#include "core/errors.hpp"
#include "core/io/hdf5_snapshot.hpp"

namespace polydem::io {
namespace {

constexpr std::string_view kColumnName[] = {"x", "y", "z", "r", "vx", "vy", "vz"};
constexpr std::string_view kHeaderColumnName[] = {"N", "Lx", "Ly", "Lz"};
constexpr char kAxis[] = "xyz";

bool isSpace(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f'; }

std::string_view trim(std::string_view s) {
  while (!s.empty() && isSpace(s.front())) s.remove_prefix(1);
  while (!s.empty() && isSpace(s.back())) s.remove_suffix(1);
  return s;
}

void splitWhitespace(std::string_view s, std::vector<std::string_view>& out) {
  out.clear();
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && isSpace(s[i])) ++i;
    const std::size_t start = i;
    while (i < s.size() && !isSpace(s[i])) ++i;
    if (i > start) out.push_back(s.substr(start, i - start));
  }
}

struct Parsed {
  enum Status { Ok, Unparsable, OutOfRange } status;
  double value;
};

/// The whole token as a double (nan/inf are Ok: callers check finiteness).
Parsed parseDouble(std::string_view token) {
  // from_chars rejects a leading '+', which printf-style writers never emit but people do.
  if (token.size() > 1 && token.front() == '+' && token[1] != '-' && token[1] != '+') token.remove_prefix(1);
  double value = 0.0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (end != token.data() + token.size()) return {Parsed::Unparsable, 0.0};
  // Overflow (1e999) or underflow below the smallest subnormal (1e-400); subnormals themselves are Ok.
  if (ec == std::errc::result_out_of_range) return {Parsed::OutOfRange, 0.0};
  if (ec != std::errc()) return {Parsed::Unparsable, 0.0};
  return {Parsed::Ok, value};
}

std::string formatToken(std::string_view token) { return fmt::format("'{}'", token); }

class TextReader {
 public:
  TextReader(const std::filesystem::path& file, std::array<Boundary, 3> defaultBoundaries)
      : file_(file), name_(file.string()), boundaries_(defaultBoundaries) {}

  ParticleData read() {
    std::error_code ec;
    if (std::filesystem::is_directory(file_, ec)) {
      throw InputError(fmt::format("{}: cannot open for reading: is a directory", name_));
    }
    std::ifstream in(file_, std::ios::binary);
    if (!in) throw InputError(fmt::format("{}: cannot open for reading: {}", name_, std::strerror(errno)));

    std::string line;
    std::vector<std::string_view> tokens;
    while (std::getline(in, line)) {
      ++lineNumber_;
      std::string_view content = line;
      const std::size_t hash = content.find('#');
      if (hash != std::string_view::npos) {
        if (trim(content.substr(0, hash)).empty()) parseComment(content.substr(hash + 1));
        content = content.substr(0, hash);
      }
      content = trim(content);
      if (content.empty()) continue;
      splitWhitespace(content, tokens);
      if (headerLine_ == 0) {
        parseHeader(tokens);
      } else {
        parseParticle(tokens);
      }
    }
    if (in.bad()) fail(lineNumber_, fmt::format("read error: {}", std::strerror(errno)));

    const int lastLine = std::max(lineNumber_, 1);
    if (headerLine_ == 0) fail(lastLine, "no header line `N Lx Ly Lz` (the file is empty or only comments)");
    if (found_ < expected_) {
      fail(lastLine, fmt::format("truncated: expected {} particles (header on line {}), found {}", expected_,
                                 headerLine_, found_));
    }

    ParticleData data;
    data.box = box_;
    data.position = Eigen::Map<const Eigen::Matrix3Xd>(position_.data(), 3, expected_);
    data.radius = Eigen::Map<const Eigen::VectorXd>(radius_.data(), expected_);
    if (columns_ == 7) data.velocity = Eigen::Map<const Eigen::Matrix3Xd>(velocity_.data(), 3, expected_);
    data.id.resize(static_cast<std::size_t>(expected_));
    for (Index i = 0; i < expected_; ++i) data.id[static_cast<std::size_t>(i)] = i;
    return data;
  }

 private:
  [[noreturn]] void fail(int line, std::string_view problem) const {
    throw InputError(fmt::format("{}:{}: {}", name_, line, problem));
  }

  // `text` is everything after '#' on a full-line comment.
  void parseComment(std::string_view text) {
    text = trim(text);
    constexpr std::string_view kKey = "boundaries";
    if (!text.starts_with(kKey)) return;
    std::string_view rest = trim(text.substr(kKey.size()));
    if (!rest.starts_with(':')) return;  // just a comment that happens to start with "boundaries"
    rest.remove_prefix(1);

    if (boundariesLine_ != 0) fail(lineNumber_, fmt::format("boundaries given twice (first on line {})", boundariesLine_));
    if (headerLine_ != 0) {
      fail(lineNumber_, fmt::format("the boundaries comment must come before the header line (line {})", headerLine_));
    }
    std::vector<std::string_view> words;
    splitWhitespace(rest, words);
    if (words.size() != 3) {
      fail(lineNumber_, fmt::format("boundaries comment: expected 3 words (periodic|wall for x y z), got {}",
                                    words.size()));
    }
    for (int k = 0; k < 3; ++k) {
      if (words[k] == "periodic") {
        boundaries_[k] = Boundary::Periodic;
      } else if (words[k] == "wall") {
        boundaries_[k] = Boundary::Wall;
      } else {
        fail(lineNumber_, fmt::format("boundaries comment: unknown boundary '{}' along {}: expected periodic or wall",
                                      words[k], kAxis[k]));
      }
    }
    boundariesLine_ = lineNumber_;
  }

  void parseHeader(const std::vector<std::string_view>& tokens) {
    headerLine_ = lineNumber_;
    if (tokens.size() != 4) {
      fail(lineNumber_, fmt::format("header: expected 4 columns `N Lx Ly Lz`, got {}", tokens.size()));
    }
    long long count = 0;
    const std::string_view n = tokens[0];
    const auto [end, ec] = std::from_chars(n.data(), n.data() + n.size(), count);
    if (ec != std::errc() || end != n.data() + n.size()) {
      fail(lineNumber_, fmt::format("header column 1 (N): particle count must be a non-negative integer, got {}",
                                    formatToken(n)));
    }
    if (count < 0) {
      fail(lineNumber_, fmt::format("header column 1 (N): particle count must be a non-negative integer, got {}",
                                    count));
    }
    if (count > std::numeric_limits<Index>::max()) {
      fail(lineNumber_, fmt::format("header column 1 (N): particle count {} exceeds the maximum {}", count,
                                    std::numeric_limits<Index>::max()));
    }
    expected_ = static_cast<Index>(count);

    Eigen::Vector3d lengths;
    for (int k = 0; k < 3; ++k) {
      const std::string_view token = tokens[static_cast<std::size_t>(k + 1)];
      const Parsed parsed = parseDouble(token);
      const std::string_view column = kHeaderColumnName[k + 1];
      if (parsed.status == Parsed::Unparsable) {
        fail(lineNumber_, fmt::format("header column {} ({}): cannot parse {} as a number", k + 2, column,
                                      formatToken(token)));
      }
      if (parsed.status == Parsed::OutOfRange || !(std::isfinite(parsed.value) && parsed.value > 0.0)) {
        fail(lineNumber_, fmt::format("header column {} ({}): box length must be positive and finite, got {}",
                                      k + 2, column, formatToken(token)));
      }
      lengths[k] = parsed.value;
    }
    box_ = Box(lengths, boundaries_);

    // Cap the reservation: a corrupt header must not allocate gigabytes before the data runs out.
    const std::size_t reserve = std::min<std::size_t>(static_cast<std::size_t>(expected_), 1u << 20);
    position_.reserve(3 * reserve);
    radius_.reserve(reserve);
  }

  void parseParticle(const std::vector<std::string_view>& tokens) {
    if (found_ == expected_) {
      fail(lineNumber_, fmt::format("extra data line: the header (line {}) declares N = {}, all already read",
                                    headerLine_, expected_));
    }
    if (columns_ == 0) {
      if (tokens.size() != 4 && tokens.size() != 7) {
        fail(lineNumber_, fmt::format("expected 4 columns (x y z r) or 7 (x y z r vx vy vz), got {}", tokens.size()));
      }
      columns_ = static_cast<int>(tokens.size());
      firstDataLine_ = lineNumber_;
      if (columns_ == 7) velocity_.reserve(position_.capacity());
    } else if (static_cast<int>(tokens.size()) != columns_) {
      fail(lineNumber_, fmt::format("expected {} columns (as on line {}), got {}", columns_, firstDataLine_,
                                    tokens.size()));
    }

    double values[7];
    for (int c = 0; c < columns_; ++c) {
      const std::string_view token = tokens[static_cast<std::size_t>(c)];
      const Parsed parsed = parseDouble(token);
      if (parsed.status == Parsed::Unparsable) {
        fail(lineNumber_, fmt::format("column {} ({}): cannot parse {} as a number", c + 1, kColumnName[c],
                                      formatToken(token)));
      }
      if (parsed.status == Parsed::OutOfRange) {
        fail(lineNumber_, fmt::format("column {} ({}): value {} is out of the range of a double", c + 1,
                                      kColumnName[c], formatToken(token)));
      }
      if (!std::isfinite(parsed.value)) {
        fail(lineNumber_, fmt::format("column {} ({}): value {} is not finite", c + 1, kColumnName[c],
                                      formatToken(token)));
      }
      values[c] = parsed.value;
    }
    if (!(values[3] > 0.0)) {
      fail(lineNumber_, fmt::format("column 4 (r): radius must be positive, got {}", formatToken(tokens[3])));
    }
    Eigen::Vector3d x(values[0], values[1], values[2]);
    for (int k = 0; k < 3; ++k) {
      if (!box_.periodic(k) && !(x[k] >= 0.0 && x[k] <= box_.length(k))) {
        fail(lineNumber_, fmt::format("column {} ({}): centre {} is outside the walled box [0, {}] along {}", k + 1,
                                      kColumnName[k], formatToken(tokens[static_cast<std::size_t>(k)]),
                                      box_.length(k), kAxis[k]));
      }
    }
    x = box_.wrap(x);
    position_.insert(position_.end(), x.data(), x.data() + 3);
    radius_.push_back(values[3]);
    if (columns_ == 7) velocity_.insert(velocity_.end(), values + 4, values + 7);
    ++found_;
  }

  std::filesystem::path file_;
  std::string name_;
  std::array<Boundary, 3> boundaries_;
  Box box_;
  int lineNumber_ = 0;
  int boundariesLine_ = 0;
  int headerLine_ = 0;
  int firstDataLine_ = 0;
  int columns_ = 0;  // 4 or 7 once the first particle line is read
  Index expected_ = 0;
  Index found_ = 0;
  std::vector<double> position_, radius_, velocity_;
};

std::string_view boundaryWord(Boundary b) { return b == Boundary::Periodic ? "periodic" : "wall"; }

}  // namespace

bool isHdf5Path(const std::filesystem::path& file) {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext == ".h5" || ext == ".hdf5";
}

void requireConsistentSizes(const ParticleData& data) {
  const Eigen::Index n = data.radius.size();
  if (data.position.cols() != n) {
    throw ConfigError(fmt::format("particle data: position has {} columns but radius has {} entries",
                                  data.position.cols(), n));
  }
  if (data.velocity && data.velocity->cols() != n) {
    throw ConfigError(fmt::format("particle data: velocity has {} columns but radius has {} entries",
                                  data.velocity->cols(), n));
  }
  if (static_cast<Eigen::Index>(data.id.size()) != n) {
    throw ConfigError(fmt::format("particle data: id has {} entries but radius has {}", data.id.size(), n));
  }
}

ParticleData readText(const std::filesystem::path& file, std::array<Boundary, 3> defaultBoundaries) {
  return TextReader(file, defaultBoundaries).read();
}

void writeText(const std::filesystem::path& file, const ParticleData& data) {
  requireConsistentSizes(data);
  const std::string name = file.string();
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  if (!out) throw InputError(fmt::format("{}: cannot open for writing: {}", name, std::strerror(errno)));

  const Box& box = data.box;
  const bool withVelocity = data.velocity.has_value();
  fmt::memory_buffer buffer;
  auto sink = std::back_inserter(buffer);
  fmt::format_to(sink, "# polydem particles: N Lx Ly Lz, then one line `x y z r{}` per particle (SI units)\n",
                 withVelocity ? " vx vy vz" : "");
  fmt::format_to(sink, "# boundaries: {} {} {}\n", boundaryWord(box.boundary(0)), boundaryWord(box.boundary(1)),
                 boundaryWord(box.boundary(2)));
  fmt::format_to(sink, "{} {:.17g} {:.17g} {:.17g}\n", data.count(), box.length(0), box.length(1), box.length(2));

  const auto flush = [&] {
    out.write(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    buffer.clear();
  };
  for (Index i = 0; i < data.count(); ++i) {
    const auto x = data.position.col(i);
    fmt::format_to(sink, "{:.17g} {:.17g} {:.17g} {:.17g}", x[0], x[1], x[2], data.radius[i]);
    if (withVelocity) {
      const auto v = data.velocity->col(i);
      fmt::format_to(sink, " {:.17g} {:.17g} {:.17g}", v[0], v[1], v[2]);
    }
    buffer.push_back('\n');
    if (buffer.size() > (1u << 16)) flush();
  }
  flush();
  out.close();
  if (!out) throw InputError(fmt::format("{}: write failed: {}", name, std::strerror(errno)));
}

ParticleData readParticles(const std::filesystem::path& file, std::array<Boundary, 3> defaultBoundaries) {
  if (isHdf5Path(file)) return readSnapshot(file);
  return readText(file, defaultBoundaries);
}

void writeParticles(const std::filesystem::path& file, const ParticleData& data) {
  if (isHdf5Path(file)) {
    writeSnapshot(file, data);
  } else {
    writeText(file, data);
  }
}

}  // namespace polydem::io
