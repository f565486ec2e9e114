#include "apps/polydem/common.hpp"

#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <limits>
#include <sstream>

#include "apps/polydem/validators.hpp"
#include "core/errors.hpp"
#include "core/io/attributes.hpp"

namespace polydem::app {

void addDistributionOptions(CLI::App& cmd, DistributionSpec& spec, std::string& fractionKind) {
  cmd.add_option("--dist", spec.kind,
                 "size distribution: mono, bi, uniform-radius (us), uniform-volume (uv), power-law, log-normal (ln)")
      ->check(CLI::IsMember(
          {"mono", "bi", "uniform-radius", "us", "uniform-volume", "uv", "power-law", "log-normal", "ln"}))
      ->capture_default_str();
  cmd.add_option("--rmin", spec.rmin, "smallest radius (mono: the radius; log-normal: lower cut, 0 = none)")
      ->check(finiteNonNegative())
      ->capture_default_str();
  // omega >= 1 except log-normal's 0 (untruncated); makeDistribution() checks the kind-specific rule.
  cmd.add_option("--omega", spec.omega, "size ratio rmax/rmin (bi: large/small; log-normal: 0 = untruncated)")
      ->check(finiteNonNegative())
      ->capture_default_str();
  cmd.add_option("--alpha", spec.alpha, "power-law exponent, f(r) ~ r^alpha")
      ->check(finiteIn(-std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()))
      ->capture_default_str();
  cmd.add_option("--sigma", spec.sigma, "log-normal width")->check(finitePositive())->capture_default_str();
  cmd.add_option("--median", spec.median, "log-normal median radius a0")
      ->check(finitePositive())
      ->capture_default_str();
  cmd.add_option("--large-fraction", spec.largeFraction, "bi: fraction of the large species")
      ->check(finiteIn(0.0, 1.0))
      ->capture_default_str();
  cmd.add_option("--fraction-kind", fractionKind, "bi: the fraction counts volume or number")
      ->check(CLI::IsMember({"volume", "number"}))
      ->capture_default_str();
}

const std::vector<std::string>& distributionOptionNames() {
  static const std::vector<std::string> names = {"--dist",  "--rmin",   "--omega",          "--alpha",
                                                 "--sigma", "--median", "--large-fraction", "--fraction-kind"};
  return names;
}

std::string firstGivenOption(const CLI::App& cmd, const std::vector<std::string>& names) {
  for (const std::string& name : names) {
    const CLI::Option* option = cmd.get_option_no_throw(name);
    if (option != nullptr && option->count() > 0) return name;
  }
  return {};
}

CLI::Validator boundaryNames() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        try {
          parseBoundaries(text);
        } catch (const ConfigError& e) {
          return e.what();
        }
        return {};
      },
      "periodic|walls|X,Y,Z");
}

void finishDistributionSpec(DistributionSpec& spec, const std::string& fractionKind) {
  spec.fractionKind = fractionKind == "number" ? FractionKind::Number : FractionKind::Volume;
}

std::array<Boundary, 3> parseBoundaries(const std::string& text) {
  auto one = [&](const std::string& word) {
    if (word == "periodic") return Boundary::Periodic;
    if (word == "wall" || word == "walls") return Boundary::Wall;
    throw ConfigError(fmt::format("boundary '{}' in '{}': expected periodic or wall", word, text));
  };
  std::vector<std::string> words;
  std::stringstream in(text);
  std::string word;
  while (std::getline(in, word, ',')) words.push_back(word);
  if (words.size() == 1) {
    const Boundary b = one(words[0]);
    return {b, b, b};
  }
  if (words.size() != 3) {
    throw ConfigError(fmt::format("boundaries '{}': give one value or three comma-separated values", text));
  }
  return {one(words[0]), one(words[1]), one(words[2])};
}

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

}  // namespace polydem::app
