#pragma once
// Argument checks shared by the cost-model files (hgrid_cost_psd, hgrid_cell_sizes, hgrid_optimiser).
// Internal: not part of the cost model's interface.
#include <fmt/format.h>

#include <cmath>

#include "broadphase/hgrid_cost_psd.hpp"
#include "core/errors.hpp"

namespace polydem::broadphase::detail {

inline void requireFiniteNonNegative(const char* key, double value) {
  if (!(value >= 0.0 && std::isfinite(value))) {
    throw ConfigError(fmt::format("{} must be >= 0 and finite, got {}", key, value));
  }
}

inline void requireFinitePositive(const char* key, double value) {
  if (!(value > 0.0 && std::isfinite(value))) {
    throw ConfigError(fmt::format("{} must be > 0 and finite, got {}", key, value));
  }
}

inline void requireLevels(int levels) {
  if (levels < 1) throw ConfigError(fmt::format("number of levels must be >= 1, got {}", levels));
}

/// All interaction diameters equal (to 1e-12): one level is the only sensible grid.
inline bool degenerate(const CostModelPsd& psd) { return !(psd.maxDiameter() > psd.minDiameter() * (1.0 + 1e-12)); }

}  // namespace polydem::broadphase::detail
