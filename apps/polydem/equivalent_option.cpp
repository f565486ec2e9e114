#include "apps/polydem/equivalent_option.hpp"

#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>

#include "core/equivalent_mixture.hpp"
#include "core/errors.hpp"
#include "core/moments.hpp"

namespace polydem::app {

void addEquivalentOption(CLI::App& cmd, std::string& which) {
  cmd.add_option("--equivalent", which,
                 "replace the distribution by its equivalent mixture: bi (matches <a>..<a^3>) or tri (matches "
                 "<a>..<a^5>); integer counts by largest remainders")
      ->check(CLI::IsMember({"none", "bi", "tri"}))
      ->capture_default_str();
}

std::vector<double> equivalentRadii(const SizeDistribution& distribution, const std::string& which, Index count,
                                    std::string& description) {
  if (which == "none") return {};
  if (which != "bi" && which != "tri") {
    throw ConfigError(fmt::format("--equivalent must be none, bi or tri, got '{}'", which));
  }
  const Moments m = momentsOf(distribution);
  const Mixture mix = which == "bi" ? equivalentBidisperse(m) : equivalentTridisperse(m);
  std::vector<double> radii = mixtureRadii(mix, count);
  description = fmt::format("{} equivalent of {}: {}", which == "bi" ? "bidisperse" : "tridisperse",
                            distribution.describe(), mix.describe());
  std::string counts;
  for (double r : mix.radius) {
    counts += fmt::format("{}{}", counts.empty() ? "" : ":", std::count(radii.begin(), radii.end(), r));
  }
  description += fmt::format("; counts {}", counts);
  return radii;
}

}  // namespace polydem::app
