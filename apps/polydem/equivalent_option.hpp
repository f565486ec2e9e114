#pragma once
// --equivalent bi|tri of `generate` and `jam`: replace the sampled distribution by its equivalent
// bidisperse or maximally equivalent tridisperse mixture (core/equivalent_mixture.hpp), same N.
#include <string>
#include <vector>

#include "core/size_distribution.hpp"

namespace CLI {
class App;
}  // namespace CLI

namespace polydem::app {

/// Adds --equivalent (none, bi, tri) storing into `which`.
void addEquivalentOption(CLI::App& cmd, std::string& which);

/// `count` radii of the equivalent mixture of `distribution` (analytic moments; integer counts by largest
/// remainders), or an empty vector when which == "none". `description` receives a one-line summary.
std::vector<double> equivalentRadii(const SizeDistribution& distribution, const std::string& which, Index count,
                                    std::string& description);

}  // namespace polydem::app
