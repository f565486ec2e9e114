#include "core/io/particle_data.hpp"

#include <fmt/format.h>

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
}

}  // namespace polydem::io
