#pragma once
// The one list of broad-phase backends. Tests, benchmarks and the CLI iterate it.
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "broadphase/broad_phase.hpp"

namespace polydem::broadphase {

/// Create a backend by its command-line name. `auto` picks the backend expected to be cheapest for
/// the spheres it is built on. Unknown names throw ConfigError listing the valid ones.
std::unique_ptr<BroadPhase> makeBroadPhase(std::string_view name);

/// Names of the backends compiled into this build (without `auto`), in registry order.
std::vector<std::string> backendNames();

}  // namespace polydem::broadphase
