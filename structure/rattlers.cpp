#include "structure/rattlers.hpp"

#include <fmt/format.h>

#include <cmath>

#include "core/errors.hpp"
#include "core/types.hpp"

namespace polydem::structure {

VelocityRattlers velocityRattlers(const Eigen::Matrix3Xd& velocity, const Eigen::VectorXd& radius, const Box& box,
                                  double threshold) {
  if (!(threshold > 0.0) || !std::isfinite(threshold)) {
    throw ConfigError(fmt::format("velocity rattlers: threshold must be finite and > 0, got {}", threshold));
  }
  const Index n = static_cast<Index>(radius.size());
  if (velocity.cols() != n) {
    throw ConfigError(fmt::format("velocity rattlers: {} velocities for {} particles", velocity.cols(), n));
  }
  if (!velocity.allFinite()) throw ConfigError("velocity rattlers: the velocities contain NaN or infinity");
  VelocityRattlers out;
  out.rattler.assign(static_cast<std::size_t>(n), 0);
  if (n == 0) return out;
  const double meanSquare = velocity.colwise().squaredNorm().sum() / n;
  if (!(meanSquare > 0.0)) {
    throw ConfigError(
        "velocity rattlers: every velocity is zero, so there is no speed scale (was the file written "
        "with `polydem jam --velocities`?)");
  }
  out.rmsSpeed = std::sqrt(meanSquare);
  const double limit2 = threshold * threshold * meanSquare;
  double rattlerVolume = 0.0, totalVolume = 0.0;
  for (Index i = 0; i < n; ++i) {
    const double v = 4.0 / 3.0 * kPi * radius[i] * radius[i] * radius[i];
    totalVolume += v;
    if (velocity.col(i).squaredNorm() <= limit2) {
      out.rattler[i] = 1;
      ++out.count;
      rattlerVolume += v;
    }
  }
  out.numberFraction = double(out.count) / n;
  out.volumeFraction = rattlerVolume / box.volume();
  out.volumeShare = totalVolume > 0.0 ? rattlerVolume / totalVolume : 0.0;
  return out;
}

}  // namespace polydem::structure
