// Plain text particle files, see text_particles.hpp for the format.
//
// Numbers are parsed with std::from_chars: locale-independent and correctly rounded, so a file written
// with %.17g reads back bit-exactly. Rejected design: iostream >> double, which depends on the global
// locale and accepts trailing garbage ("1.5abc" reads as 1.5).
#include "core/io/text_particles.hpp"

#include <fmt/format.h>

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

#include "core/errors.hpp"
#include "core/io/safe_output.hpp"

namespace polydem::io {
namespace {

constexpr std::string_view kHeaderColumnName[] = {"N", "Lx", "Ly", "Lz"};
constexpr char kAxis[] = "xyz";

/// What a data column holds. The order is the only order allowed in a file.
enum class Column { Id, X, Y, Z, R, Vx, Vy, Vz, Wx, Wy, Wz };
constexpr std::string_view kColumnName[] = {"id", "x", "y", "z", "r", "vx", "vy", "vz", "wx", "wy", "wz"};
constexpr std::size_t kMaxColumns = 11;

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

/// A token for an error message: quoted, cut to 40 characters, control bytes shown as \xHH.
std::string formatToken(std::string_view token) {
  std::string out = "'";
  const std::size_t shown = std::min<std::size_t>(token.size(), 40);
  for (std::size_t i = 0; i < shown; ++i) {
    const auto c = static_cast<unsigned char>(token[i]);
    if (c < 0x20 || c == 0x7f) {
      out += fmt::format("\\x{:02x}", c);
    } else {
      out += static_cast<char>(c);
    }
  }
  if (shown < token.size()) out += "...";
  return out + "'";
}

// --- attribute strings: bare or double-quoted with escapes ------------------------------------------

/// Plain enough to write without quotes: printable ASCII except blank, '"', '\\', '=', '#'.
bool isPlain(std::string_view text) {
  if (text.empty()) return false;
  return std::all_of(text.begin(), text.end(), [](char ch) {
    const auto c = static_cast<unsigned char>(ch);
    return c > 0x20 && c < 0x7f && c != '"' && c != '\\' && c != '=' && c != '#';
  });
}

std::string quote(std::string_view text) {
  std::string out = "\"";
  for (char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    switch (ch) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (c < 0x20 || c == 0x7f) {
          out += fmt::format("\\x{:02x}", c);
        } else {
          out += ch;
        }
    }
  }
  return out + "\"";
}

std::string quoteIfNeeded(std::string_view text) { return isPlain(text) ? std::string(text) : quote(text); }

int hexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

/// A name the text format accepts for an array column: letters, digits and '_', not a built-in column
/// (x, vx, id, ...) and not a name taken by a built-in dataset (particle_data.hpp).
bool isArrayColumnName(std::string_view name) {
  if (name.empty() ||
      !std::all_of(name.begin(), name.end(), [](unsigned char c) { return std::isalnum(c) != 0 || c == '_'; })) {
    return false;
  }
  for (std::string_view builtin : kColumnName) {
    if (name == builtin) return false;
  }
  for (std::string_view reserved : {"position", "velocity", "angular_velocity", "radius"}) {
    if (name == reserved) return false;
  }
  return true;
}

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
    data.time = time_;
    data.attributes = std::move(attributes_);
    data.position = Eigen::Map<const Eigen::Matrix3Xd>(position_.data(), 3, expected_);
    data.radius = Eigen::Map<const Eigen::VectorXd>(radius_.data(), expected_);
    if (has(Column::Vx)) data.velocity = Eigen::Map<const Eigen::Matrix3Xd>(velocity_.data(), 3, expected_);
    if (has(Column::Wx)) {
      data.angularVelocity = Eigen::Map<const Eigen::Matrix3Xd>(angularVelocity_.data(), 3, expected_);
    }
    const std::size_t width = arrayColumnNames_.size();
    std::size_t first = 0;
    for (const auto& [name, components] : arrays_) {
      ParticleArray array{name, Eigen::MatrixXd(components, expected_)};
      for (Index i = 0; i < expected_; ++i) {
        for (int k = 0; k < components; ++k) {
          array.values(k, i) = arrayValues_[static_cast<std::size_t>(i) * width + first + static_cast<std::size_t>(k)];
        }
      }
      first += static_cast<std::size_t>(components);
      data.arrays.push_back(std::move(array));
    }
    if (has(Column::Id)) {
      data.id = std::move(id_);
      requireUniqueIds(data.id);
    } else {
      data.id.resize(static_cast<std::size_t>(expected_));
      for (Index i = 0; i < expected_; ++i) data.id[static_cast<std::size_t>(i)] = i;
    }
    return data;
  }

 private:
  [[noreturn]] void fail(int line, std::string_view problem) const {
    throw InputError(fmt::format("{}:{}: {}", name_, line, problem));
  }

  bool has(Column c) const { return std::find(columns_.begin(), columns_.end(), c) != columns_.end(); }

  void requireUniqueIds(const std::vector<Index>& ids) const {
    std::vector<std::pair<Index, std::size_t>> sorted(ids.size());  // (id, particle)
    for (std::size_t i = 0; i < ids.size(); ++i) sorted[i] = {ids[i], i};
    std::sort(sorted.begin(), sorted.end());
    for (std::size_t i = 1; i < sorted.size(); ++i) {
      if (sorted[i].first == sorted[i - 1].first) {
        const std::size_t a = std::min(sorted[i - 1].second, sorted[i].second);
        const std::size_t b = std::max(sorted[i - 1].second, sorted[i].second);
        fail(idLine_[b],
             fmt::format("column 1 (id): id {} appears twice (also on line {})", sorted[i].first, idLine_[a]));
      }
    }
  }

  /// `text` is everything after '#' on a full-line comment. Metadata keywords end in ':'.
  void parseComment(std::string_view text) {
    text = trim(text);
    std::size_t wordEnd = 0;
    while (wordEnd < text.size() && !isSpace(text[wordEnd]) && text[wordEnd] != ':') ++wordEnd;
    const std::string_view word = text.substr(0, wordEnd);
    std::string_view rest = text.substr(wordEnd);
    if (!rest.starts_with(':')) return;  // free text, e.g. "# boundaries are periodic"
    rest = trim(rest.substr(1));
    int* seen = nullptr;
    if (word == "boundaries") {
      seen = &boundariesLine_;
    } else if (word == "columns") {
      seen = &columnsLine_;
    } else if (word == "time") {
      seen = &timeLine_;
    } else if (word != "attribute") {
      return;  // free text that happens to contain a colon
    }
    if (headerLine_ != 0) {
      fail(lineNumber_, fmt::format("the {} comment must come before the header line (line {})", word, headerLine_));
    }
    if (seen != nullptr) {
      if (*seen != 0) fail(lineNumber_, fmt::format("{} given twice (first on line {})", word, *seen));
      *seen = lineNumber_;
    }
    if (word == "boundaries") parseBoundaries(rest);
    if (word == "columns") parseColumns(rest);
    if (word == "time") parseTime(rest);
    if (word == "attribute") parseAttribute(rest);
  }

  void parseBoundaries(std::string_view rest) {
    std::vector<std::string_view> words;
    splitWhitespace(rest, words);
    if (words.size() != 3) {
      fail(lineNumber_,
           fmt::format("boundaries comment: expected 3 words (periodic|wall for x y z), got {}", words.size()));
    }
    for (int k = 0; k < 3; ++k) {
      if (words[k] == "periodic") {
        boundaries_[k] = Boundary::Periodic;
      } else if (words[k] == "wall") {
        boundaries_[k] = Boundary::Wall;
      } else {
        fail(lineNumber_, fmt::format("boundaries comment: unknown boundary {} along {}: expected periodic or wall",
                                      formatToken(words[k]), kAxis[k]));
      }
    }
  }

  void parseColumns(std::string_view rest) {
    std::vector<std::string_view> words;
    splitWhitespace(rest, words);
    constexpr std::string_view kExpected = "expected [id] x y z r [vx vy vz] [wx wy wz] [array columns]";
    std::vector<Column> columns;
    std::size_t w = 0;
    const auto take = [&](std::initializer_list<Column> group) {
      if (w >= words.size() || words[w] != kColumnName[static_cast<int>(*group.begin())]) return false;
      for (Column c : group) {
        if (w >= words.size() || words[w] != kColumnName[static_cast<int>(c)]) {
          fail(lineNumber_, fmt::format("columns comment: {}, got {} at word {}", kExpected,
                                        w < words.size() ? formatToken(words[w]) : std::string("the end"), w + 1));
        }
        columns.push_back(c);
        ++w;
      }
      return true;
    };
    take({Column::Id});
    if (!take({Column::X, Column::Y, Column::Z, Column::R})) {
      fail(lineNumber_, fmt::format("columns comment: {}, got {}", kExpected,
                                    w < words.size() ? formatToken(words[w]) : std::string("nothing")));
    }
    take({Column::Vx, Column::Vy, Column::Vz});
    take({Column::Wx, Column::Wy, Column::Wz});
    // Optional arrays (ParticleData::arrays): NAME for one component, NAME_x NAME_y NAME_z for three.
    while (w < words.size()) {
      const std::string_view word = words[w];
      if (!isArrayColumnName(word)) {
        fail(lineNumber_, fmt::format("columns comment: {}, got {} at word {} (an array column is letters, digits "
                                      "and '_', not a built-in column or dataset name)",
                                      kExpected, formatToken(word), w + 1));
      }
      std::string name(word);
      int components = 1;
      if (word.ends_with("_x") && w + 2 < words.size()) {
        const std::string base(word.substr(0, word.size() - 2));
        if (words[w + 1] == base + "_y" && words[w + 2] == base + "_z" && isArrayColumnName(base)) {
          name = base;
          components = 3;
        }
      }
      for (const auto& [other, c] : arrays_) {
        if (other == name) {
          fail(lineNumber_, fmt::format("columns comment: array {} appears twice", formatToken(name)));
        }
      }
      for (int k = 0; k < components; ++k) {
        arrayColumnNames_.emplace_back(words[w + static_cast<std::size_t>(k)]);
      }
      arrays_.emplace_back(name, components);
      w += static_cast<std::size_t>(components);
    }
    columns_ = std::move(columns);
  }

  void parseTime(std::string_view rest) {
    const Parsed parsed = parseDouble(rest);
    if (parsed.status != Parsed::Ok || !std::isfinite(parsed.value)) {
      fail(lineNumber_, fmt::format("time comment: expected one finite number (seconds), got {}", formatToken(rest)));
    }
    time_ = parsed.value;
  }

  /// A bare word or a quoted string at the start of `text`; advances `text` past it.
  std::string parseString(std::string_view& text, std::string_view what, bool stopAtEquals) {
    if (!text.starts_with('"')) {
      std::size_t end = 0;
      while (end < text.size() && !(stopAtEquals && (isSpace(text[end]) || text[end] == '='))) {
        if (text[end] == '"') {
          fail(lineNumber_,
               fmt::format("attribute comment: {}: a '\"' inside a bare word; quote the whole {}", what, what));
        }
        ++end;
      }
      std::string word(trim(text.substr(0, end)));
      text.remove_prefix(end);
      return word;
    }
    std::string out;
    std::size_t i = 1;
    for (;;) {
      if (i >= text.size()) fail(lineNumber_, fmt::format("attribute comment: {}: missing closing '\"'", what));
      const char c = text[i++];
      if (c == '"') break;
      if (c != '\\') {
        out += c;
        continue;
      }
      if (i >= text.size()) fail(lineNumber_, fmt::format("attribute comment: {}: missing closing '\"'", what));
      const char e = text[i++];
      switch (e) {
        case '"':
          out += '"';
          break;
        case '\\':
          out += '\\';
          break;
        case 'n':
          out += '\n';
          break;
        case 'r':
          out += '\r';
          break;
        case 't':
          out += '\t';
          break;
        case 'x': {
          const int hi = i < text.size() ? hexDigit(text[i]) : -1;
          const int lo = i + 1 < text.size() ? hexDigit(text[i + 1]) : -1;
          if (hi < 0 || lo < 0) fail(lineNumber_, fmt::format("attribute comment: {}: \\x needs two hex digits", what));
          out += static_cast<char>(hi * 16 + lo);
          i += 2;
          break;
        }
        default:
          fail(lineNumber_, fmt::format("attribute comment: {}: unknown escape {} (use \\\\ \\\" \\n \\r \\t \\xHH)",
                                        what, formatToken(text.substr(i - 2, 2))));
      }
    }
    text.remove_prefix(i);
    return out;
  }

  void parseAttribute(std::string_view rest) {
    constexpr std::string_view kForm = "expected `attribute: KEY = VALUE`";
    std::string_view text = rest;
    const bool quotedKey = text.starts_with('"');
    std::string key = parseString(text, "key", true);
    if (key.empty() && !quotedKey) fail(lineNumber_, fmt::format("attribute comment: {}: the key is missing", kForm));
    if (key.empty()) fail(lineNumber_, "attribute comment: the key must not be empty");
    text = trim(text);
    if (!text.starts_with('=')) {
      fail(lineNumber_, fmt::format("attribute comment: {}: no '=' after the key {}", kForm, formatToken(key)));
    }
    text = trim(text.substr(1));
    std::string value;
    if (text.starts_with('"')) {
      value = parseString(text, "value", false);
      if (!trim(text).empty()) {
        fail(lineNumber_,
             fmt::format("attribute comment: text {} after the closing quote of the value", formatToken(trim(text))));
      }
    } else {
      value = std::string(trim(text));
    }
    const auto [it, inserted] = attributes_.emplace(std::move(key), std::move(value));
    if (!inserted) {
      fail(lineNumber_, fmt::format("attribute {} given twice (first on line {})", formatToken(it->first),
                                    attributeLine_[it->first]));
    }
    attributeLine_[it->first] = lineNumber_;
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
      fail(lineNumber_,
           fmt::format("header column 1 (N): particle count must be a non-negative integer, got {}", formatToken(n)));
    }
    if (count < 0) {
      fail(lineNumber_,
           fmt::format("header column 1 (N): particle count must be a non-negative integer, got {}", count));
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
        fail(lineNumber_,
             fmt::format("header column {} ({}): cannot parse {} as a number", k + 2, column, formatToken(token)));
      }
      if (parsed.status == Parsed::OutOfRange || !(std::isfinite(parsed.value) && parsed.value > 0.0)) {
        fail(lineNumber_, fmt::format("header column {} ({}): box length must be positive and finite, got {}", k + 2,
                                      column, formatToken(token)));
      }
      lengths[k] = parsed.value;
    }
    box_ = Box(lengths, boundaries_);

    // Cap the reservation: a corrupt header must not allocate gigabytes before the data runs out.
    const std::size_t reserve = std::min<std::size_t>(static_cast<std::size_t>(expected_), 1u << 20);
    position_.reserve(3 * reserve);
    radius_.reserve(reserve);
  }

  /// The columns of a file without a `# columns:` line, from the count on its first data line.
  void inferColumns(std::size_t count) {
    using C = Column;
    if (count != 4 && count != 7 && count != 10) {
      fail(lineNumber_, fmt::format("expected 4 columns (x y z r), 7 (x y z r vx vy vz) or 10 (x y z r vx vy vz wx wy "
                                    "wz), got {}",
                                    count));
    }
    columns_ = {C::X, C::Y, C::Z, C::R};
    if (count >= 7) columns_.insert(columns_.end(), {C::Vx, C::Vy, C::Vz});
    if (count == 10) columns_.insert(columns_.end(), {C::Wx, C::Wy, C::Wz});
  }

  void parseParticle(const std::vector<std::string_view>& tokens) {
    if (found_ == expected_) {
      fail(lineNumber_, fmt::format("extra data line: the header (line {}) declares N = {}, all already read",
                                    headerLine_, expected_));
    }
    if (firstDataLine_ == 0) {
      if (columns_.empty()) inferColumns(tokens.size());
      firstDataLine_ = lineNumber_;
    }
    const std::size_t width = columns_.size() + arrayColumnNames_.size();
    if (tokens.size() != width) {
      if (columnsLine_ != 0) {
        fail(lineNumber_,
             fmt::format("expected {} columns (as declared on line {}), got {}", width, columnsLine_, tokens.size()));
      }
      fail(lineNumber_,
           fmt::format("expected {} columns (as on line {}), got {}", columns_.size(), firstDataLine_, tokens.size()));
    }

    double values[kMaxColumns] = {};
    for (std::size_t c = 0; c < columns_.size(); ++c) {
      const std::string_view token = tokens[c];
      const std::string_view name = kColumnName[static_cast<int>(columns_[c])];
      if (columns_[c] == Column::Id) {
        parseId(token, c);
        continue;
      }
      const Parsed parsed = parseDouble(token);
      if (parsed.status == Parsed::Unparsable) {
        fail(lineNumber_, fmt::format("column {} ({}): cannot parse {} as a number", c + 1, name, formatToken(token)));
      }
      if (parsed.status == Parsed::OutOfRange) {
        fail(lineNumber_,
             fmt::format("column {} ({}): value {} is out of the range of a double", c + 1, name, formatToken(token)));
      }
      if (!std::isfinite(parsed.value)) {
        fail(lineNumber_, fmt::format("column {} ({}): value {} is not finite", c + 1, name, formatToken(token)));
      }
      values[static_cast<int>(columns_[c])] = parsed.value;
    }
    for (std::size_t a = 0; a < arrayColumnNames_.size(); ++a) {
      const std::size_t c = columns_.size() + a;
      const std::string_view token = tokens[c];
      const std::string& name = arrayColumnNames_[a];
      const Parsed parsed = parseDouble(token);
      if (parsed.status != Parsed::Ok || !std::isfinite(parsed.value)) {
        fail(lineNumber_,
             fmt::format("column {} ({}): expected a finite number, got {}", c + 1, name, formatToken(token)));
      }
      arrayValues_.push_back(parsed.value);
    }
    const std::size_t offset = has(Column::Id) ? 1 : 0;  // token index of x
    const double r = values[static_cast<int>(Column::R)];
    if (!(r > 0.0)) {
      fail(lineNumber_,
           fmt::format("column {} (r): radius must be positive, got {}", offset + 4, formatToken(tokens[offset + 3])));
    }
    Eigen::Vector3d x(values[static_cast<int>(Column::X)], values[static_cast<int>(Column::Y)],
                      values[static_cast<int>(Column::Z)]);
    for (int k = 0; k < 3; ++k) {
      if (!box_.periodic(k) && !(x[k] >= 0.0 && x[k] <= box_.length(k))) {
        fail(lineNumber_,
             fmt::format("column {} ({}): centre {} is outside the walled box [0, {}] along {}", offset + k + 1,
                         kColumnName[1 + k], formatToken(tokens[offset + k]), box_.length(k), kAxis[k]));
      }
    }
    x = box_.wrap(x);
    position_.insert(position_.end(), x.data(), x.data() + 3);
    radius_.push_back(r);
    if (has(Column::Vx)) velocity_.insert(velocity_.end(), values + int(Column::Vx), values + int(Column::Vz) + 1);
    if (has(Column::Wx)) {
      angularVelocity_.insert(angularVelocity_.end(), values + int(Column::Wx), values + int(Column::Wz) + 1);
    }
    ++found_;
  }

  void parseId(std::string_view token, std::size_t c) {
    long long id = 0;
    const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), id);
    if (ec != std::errc() || end != token.data() + token.size() || id < 0 || id > std::numeric_limits<Index>::max()) {
      fail(lineNumber_, fmt::format("column {} (id): expected an integer in [0, {}], got {}", c + 1,
                                    std::numeric_limits<Index>::max(), formatToken(token)));
    }
    id_.push_back(static_cast<Index>(id));
    idLine_.push_back(lineNumber_);
  }

  std::filesystem::path file_;
  std::string name_;
  std::array<Boundary, 3> boundaries_;
  Box box_;
  int lineNumber_ = 0;
  int boundariesLine_ = 0;
  int columnsLine_ = 0;
  int timeLine_ = 0;
  int headerLine_ = 0;
  int firstDataLine_ = 0;
  std::vector<Column> columns_;                      // from `# columns:` or the first data line
  std::vector<std::pair<std::string, int>> arrays_;  // array columns after the built-in ones: name, components
  std::vector<std::string> arrayColumnNames_;        // one per array column, in file order
  std::vector<double> arrayValues_;                  // arrayColumnNames_.size() per particle
  Index expected_ = 0;
  Index found_ = 0;
  double time_ = 0.0;
  std::map<std::string, std::string> attributes_;
  std::map<std::string, int> attributeLine_;
  std::vector<double> position_, radius_, velocity_, angularVelocity_;
  std::vector<Index> id_;
  std::vector<int> idLine_;
};

std::string_view boundaryWord(Boundary b) { return b == Boundary::Periodic ? "periodic" : "wall"; }

/// True if the ids are 0..N-1 in order: the text writer then leaves the id column out.
bool trivialIds(const std::vector<Index>& ids) {
  for (std::size_t i = 0; i < ids.size(); ++i) {
    if (ids[i] != static_cast<Index>(i)) return false;
  }
  return true;
}

}  // namespace

ParticleData readText(const std::filesystem::path& file, std::array<Boundary, 3> defaultBoundaries) {
  return TextReader(file, defaultBoundaries).read();
}

void writeText(const std::filesystem::path& file, const ParticleData& data) {
  requireConsistentSizes(data);
  const std::string name = file.string();
  for (const auto& [key, value] : data.attributes) {
    if (key.empty()) throw ConfigError(fmt::format("{}: particle data: attribute keys must not be empty", name));
  }
  const bool withId = !trivialIds(data.id);
  if (withId) {
    std::vector<Index> sorted = data.id;
    std::sort(sorted.begin(), sorted.end());
    if (!sorted.empty() && sorted.front() < 0) {
      throw ConfigError(fmt::format("{}: particle data: id {} is negative", name, sorted.front()));
    }
    const auto twice = std::adjacent_find(sorted.begin(), sorted.end());
    if (twice != sorted.end()) throw ConfigError(fmt::format("{}: particle data: id {} appears twice", name, *twice));
  }

  const Box& box = data.box;
  const bool withVelocity = data.velocity.has_value();
  const bool withAngular = data.angularVelocity.has_value();
  fmt::memory_buffer buffer;
  auto sink = std::back_inserter(buffer);
  fmt::format_to(sink,
                 "# polydem particles (SI units): metadata comments, the header N Lx Ly Lz, one line per particle\n");
  std::string arrayColumns;
  for (const ParticleArray& a : data.arrays) {
    if (!isArrayColumnName(a.name)) {
      throw ConfigError(
          fmt::format("{}: particle data: array '{}' has the name of a built-in text column", name, a.name));
    }
    arrayColumns += a.values.rows() == 3 ? fmt::format(" {0}_x {0}_y {0}_z", a.name) : " " + a.name;
  }
  fmt::format_to(sink, "# columns: {}x y z r{}{}{}\n", withId ? "id " : "", withVelocity ? " vx vy vz" : "",
                 withAngular ? " wx wy wz" : "", arrayColumns);
  fmt::format_to(sink, "# boundaries: {} {} {}\n", boundaryWord(box.boundary(0)), boundaryWord(box.boundary(1)),
                 boundaryWord(box.boundary(2)));
  fmt::format_to(sink, "# time: {:.17g}\n", data.time);
  for (const auto& [key, value] : data.attributes) {
    fmt::format_to(sink, "# attribute: {} = {}\n", quoteIfNeeded(key), quoteIfNeeded(value));
  }
  fmt::format_to(sink, "{} {:.17g} {:.17g} {:.17g}\n", data.count(), box.length(0), box.length(1), box.length(2));

  AtomicFile atomic(file);
  std::ofstream out(atomic.temporary(), std::ios::binary | std::ios::trunc);
  if (!out) throw InputError(fmt::format("{}: cannot open for writing: {}", name, std::strerror(errno)));
  const auto flush = [&] {
    out.write(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    buffer.clear();
  };
  for (Index i = 0; i < data.count(); ++i) {
    if (withId) fmt::format_to(sink, "{} ", data.id[static_cast<std::size_t>(i)]);
    const auto x = data.position.col(i);
    fmt::format_to(sink, "{:.17g} {:.17g} {:.17g} {:.17g}", x[0], x[1], x[2], data.radius[i]);
    if (withVelocity) {
      const auto v = data.velocity->col(i);
      fmt::format_to(sink, " {:.17g} {:.17g} {:.17g}", v[0], v[1], v[2]);
    }
    if (withAngular) {
      const auto w = data.angularVelocity->col(i);
      fmt::format_to(sink, " {:.17g} {:.17g} {:.17g}", w[0], w[1], w[2]);
    }
    for (const ParticleArray& a : data.arrays) {
      for (Eigen::Index k = 0; k < a.values.rows(); ++k) fmt::format_to(sink, " {:.17g}", a.values(k, i));
    }
    buffer.push_back('\n');
    if (buffer.size() > (1u << 16)) flush();
  }
  flush();
  out.close();
  if (!out) throw InputError(fmt::format("{}: write failed: {}", name, std::strerror(errno)));
  atomic.commit();
}

}  // namespace polydem::io
