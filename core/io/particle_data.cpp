#include "core/io/particle_data.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>

#include "core/errors.hpp"

namespace polydem::io {

void requireConsistentSizes(const ParticleData& data) {
  const Eigen::Index n = data.radius.size();
  if (data.position.cols() != n) {
    throw ConfigError(
        fmt::format("particle data: position has {} columns but radius has {} entries", data.position.cols(), n));
  }
  if (data.velocity && data.velocity->cols() != n) {
    throw ConfigError(
        fmt::format("particle data: velocity has {} columns but radius has {} entries", data.velocity->cols(), n));
  }
  if (data.angularVelocity && data.angularVelocity->cols() != n) {
    throw ConfigError(fmt::format("particle data: angular velocity has {} columns but radius has {} entries",
                                  data.angularVelocity->cols(), n));
  }
  if (static_cast<Eigen::Index>(data.id.size()) != n) {
    throw ConfigError(fmt::format("particle data: id has {} entries but radius has {}", data.id.size(), n));
  }
  for (std::size_t a = 0; a < data.arrays.size(); ++a) {
    const ParticleArray& array = data.arrays[a];
    const bool plain = !array.name.empty() && std::all_of(array.name.begin(), array.name.end(), [](unsigned char c) {
      return std::isalnum(c) != 0 || c == '_';
    });
    if (!plain) {
      throw ConfigError(fmt::format("particle data: array name '{}' must be letters, digits and '_'", array.name));
    }
    for (const char* reserved : {"position", "velocity", "angular_velocity", "radius", "id"}) {
      if (array.name == reserved) {
        throw ConfigError(fmt::format("particle data: array name '{}' is taken by a built-in dataset", array.name));
      }
    }
    if ((array.values.rows() != 1 && array.values.rows() != 3) || array.values.cols() != n) {
      throw ConfigError(fmt::format("particle data: array '{}' is {} x {}, expected 1 or 3 x {}", array.name,
                                    array.values.rows(), array.values.cols(), n));
    }
    for (std::size_t b = 0; b < a; ++b) {
      if (data.arrays[b].name == array.name) {
        throw ConfigError(fmt::format("particle data: array '{}' appears twice", array.name));
      }
    }
  }
}

}  // namespace polydem::io
