#pragma once
// Basic types shared by every polydem library.
#include <cstdint>

namespace polydem {

/// Particle index and stored particle id. 32 bits: 2^31 particles is far beyond one machine's memory.
using Index = std::int32_t;

inline constexpr double kPi = 3.14159265358979323846;

}  // namespace polydem
