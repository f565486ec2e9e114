#pragma once
// CLI11 validators for numeric options: every number is finite and in range, and the message names
// the option (CLI11 prefixes it). CLI::Range alone lets NaN through (every comparison with NaN is
// false), so these check finiteness first.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <string>

#include "core/io/attributes.hpp"

namespace polydem::app {

/// "'TEXT' is not a finite number", but never echoing "nan" (reports never print nan, not even back).
inline std::string notFinite(const std::string& text) {
  const double v = std::strtod(text.c_str(), nullptr);
  if (std::isnan(v)) return "not a finite number (the value is not-a-number)";
  return fmt::format("'{}' is not a finite number", text);
}

/// A finite number in [lo, hi] (either bound may be infinite).
inline CLI::Validator finiteIn(double lo, double hi) {
  return CLI::Validator(
      [lo, hi](std::string& text) -> std::string {
        const auto value = io::parseFiniteDouble(text);
        if (!value) return notFinite(text);
        if (*value < lo || *value > hi) {
          if (std::isinf(hi)) return fmt::format("{} is below the smallest allowed value {:g}", text, lo);
          if (std::isinf(lo)) return fmt::format("{} is above the largest allowed value {:g}", text, hi);
          return fmt::format("{} is outside [{:g}, {:g}]", text, lo, hi);
        }
        return {};
      },
      fmt::format("FINITE in [{:g}, {:g}]", lo, hi));
}

/// A finite number in the open interval (lo, hi).
inline CLI::Validator finiteOpen(double lo, double hi) {
  return CLI::Validator(
      [lo, hi](std::string& text) -> std::string {
        const auto value = io::parseFiniteDouble(text);
        if (!value) return notFinite(text);
        if (!(*value > lo && *value < hi)) return fmt::format("{} is outside ({:g}, {:g})", text, lo, hi);
        return {};
      },
      fmt::format("FINITE in ({:g}, {:g})", lo, hi));
}

/// A finite number > 0.
inline CLI::Validator finitePositive() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        const auto value = io::parseFiniteDouble(text);
        if (!value) return notFinite(text);
        if (!(*value > 0.0)) return fmt::format("{} must be > 0", text);
        return {};
      },
      "POSITIVE");
}

/// A finite number >= 0.
inline CLI::Validator finiteNonNegative() { return finiteIn(0.0, std::numeric_limits<double>::infinity()); }

}  // namespace polydem::app
