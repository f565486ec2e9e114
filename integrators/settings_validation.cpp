// The checks of the settings a scene file fills (run.* stability limits, [compression]): kept apart from
// the time loop's code so that the scene reader needs nothing of the engine but these and the structs'
// headers (fuzz/CMakeLists.txt builds the scene reader's fuzz target from exactly such files).
#include <fmt/format.h>

#include <cmath>

#include "core/errors.hpp"
#include "integrators/dem_simulation.hpp"
#include "integrators/soft_compression.hpp"

namespace polydem::integrators {

void StabilityLimits::validate() const {
  if (checkInterval < 0) {
    throw ConfigError(fmt::format("run.check_interval must be >= 0 (0 = never), got {}", checkInterval));
  }
  if (!(maxOverlapFraction > 0.0 && std::isfinite(maxOverlapFraction))) {
    throw ConfigError(fmt::format("run.max_overlap_fraction must be > 0, got {}", maxOverlapFraction));
  }
  if (!(energyTolerance > 0.0 && std::isfinite(energyTolerance))) {
    throw ConfigError(fmt::format("run.energy_tolerance must be > 0, got {}", energyTolerance));
  }
}

void CompressionSettings::validate() const {
  if (!(targetPacking > 0.0 && targetPacking < 1.0)) {
    throw ConfigError(fmt::format("compression.packing_fraction must be in (0, 1), got {}", targetPacking));
  }
  if (!(growthRate > 0.0 && growthRate <= 0.1)) {
    throw ConfigError(
        fmt::format("compression.growth_rate must be in (0, 0.1] (relative radius growth per contact "
                    "duration), got {}",
                    growthRate));
  }
  if (!(damping > 0.0 && std::isfinite(damping))) {
    throw ConfigError(fmt::format("compression.damping must be > 0, got {}", damping));
  }
  if (!(relaxedOverlap > 0.0 && std::isfinite(relaxedOverlap))) {
    throw ConfigError(fmt::format("compression.max_overlap must be > 0, got {}", relaxedOverlap));
  }
  if (maxSteps < 1) throw ConfigError(fmt::format("compression.max_steps must be >= 1, got {}", maxSteps));
}

}  // namespace polydem::integrators
