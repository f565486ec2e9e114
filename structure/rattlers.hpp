#pragma once
// Rattlers by speed (Ogarko's thesis §3.2, Fig. 3.10(b); Ogarko & Luding, Soft Matter 9 (2013) 9530): during a
// Lubachevsky-Stillinger compression every collision heats the system and the thermostat rescales all velocities by one
// factor, so spheres that rarely collide (rattlers) end with almost no speed while jammed ones keep a scaled speed ~ 1.
// Criterion: |v_i| / v_rms <= threshold, v_rms = sqrt(<|v|^2>) (the thesis does not state its normalisation; the rms
// speed makes the test independent of the thermostat's temperature). The seed uses 1e-4 and finds the same rattlers for
// 1e-3 .. 1e-6 (§3.2). The geometric (contact count) rattlers are edmd::analyseContacts().
#include <Eigen/Core>
#include <vector>

#include "core/box.hpp"
#include "core/types.hpp"

namespace polydem::structure {

struct VelocityRattlers {
  std::vector<char> rattler;  ///< 1 = rattler
  Index count = 0;
  double numberFraction = 0.0;  ///< count / N
  double volumeFraction = 0.0;  ///< nu_r: rattler volume / box volume
  double volumeShare = 0.0;     ///< rattler volume / particle volume
  double rmsSpeed = 0.0;        ///< v_rms (m/s)
};

/// Rattlers with |v_i| <= threshold v_rms. O(N). Throws ConfigError for a threshold that is not finite
/// and > 0, mismatched sizes, non-finite velocities, or all speeds zero (no scale).
VelocityRattlers velocityRattlers(const Eigen::Matrix3Xd& velocity, const Eigen::VectorXd& radius, const Box& box,
                                  double threshold = 1e-4);

}  // namespace polydem::structure
