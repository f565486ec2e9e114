#include "core/io/attributes.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>

#include "core/errors.hpp"

namespace polydem::io {

std::optional<double> parseFiniteDouble(std::string_view text) {
  const std::string s(text);
  const char* begin = s.c_str();
  while (*begin == ' ' || *begin == '\t') ++begin;
  if (*begin == '\0') return std::nullopt;
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(begin, &end);
  while (*end == ' ' || *end == '\t') ++end;
  if (*end != '\0' || errno == ERANGE || !std::isfinite(value)) return std::nullopt;
  return value;
}

std::optional<double> numericAttribute(const ParticleData& data, const std::string& key,
                                       const std::filesystem::path& file) {
  const auto it = data.attributes.find(key);
  if (it == data.attributes.end()) return std::nullopt;
  const std::optional<double> value = parseFiniteDouble(it->second);
  if (!value) {
    throw InputError(fmt::format("{}: attribute {}: '{}' is not a finite number", file.string(), key, it->second));
  }
  return value;
}

double requireNumericAttribute(const ParticleData& data, const std::string& key, const std::filesystem::path& file) {
  const std::optional<double> value = numericAttribute(data, key, file);
  if (!value) throw InputError(fmt::format("{}: attribute {} is missing", file.string(), key));
  return *value;
}

}  // namespace polydem::io
