// Line handling shared by the LAMMPS data and dump readers.
#include "core/io/lammps_text.hpp"

#include <fmt/format.h>

#include <charconv>
#include <fstream>

#include "core/errors.hpp"
#include "core/io/attributes.hpp"

namespace polydem::io::lammps {

Lines::Lines(const std::filesystem::path& path) : file(path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) fail(0, "no such file");
  if (std::filesystem::is_directory(path, ec)) fail(0, "is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(0, "cannot open for reading");
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    text.push_back(std::move(line));
  }
}

void Lines::fail(std::size_t line, std::string_view problem) const {
  if (line == 0) throw InputError(fmt::format("{}: {}", file.string(), problem));
  throw InputError(fmt::format("{}:{}: {}", file.string(), line, problem));
}

std::vector<std::string_view> words(std::string_view line) {
  line = line.substr(0, line.find('#'));
  std::vector<std::string_view> out;
  std::size_t at = 0;
  while (at < line.size()) {
    while (at < line.size() && (line[at] == ' ' || line[at] == '\t')) ++at;
    std::size_t end = at;
    while (end < line.size() && line[end] != ' ' && line[end] != '\t') ++end;
    if (end > at) out.push_back(line.substr(at, end - at));
    at = end;
  }
  return out;
}

double number(const Lines& lines, std::size_t line, std::string_view word, std::string_view what) {
  const auto value = parseFiniteDouble(word);
  if (!value) lines.fail(line, fmt::format("{}: '{}' is not a finite number", what, word));
  return *value;
}

long long integer(const Lines& lines, std::size_t line, std::string_view word, std::string_view what) {
  long long value = 0;
  const auto [end, ec] = std::from_chars(word.data(), word.data() + word.size(), value);
  if (ec != std::errc() || end != word.data() + word.size()) {
    lines.fail(line, fmt::format("{}: '{}' is not an integer", what, word));
  }
  return value;
}

}  // namespace polydem::io::lammps
