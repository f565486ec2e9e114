#include "integrators/pressure_jamming.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/errors.hpp"
#include "core/interrupt.hpp"

namespace polydem::integrators {

void PressureJammingSettings::validate() const {
  if (!(targetPressure > 0.0 && targetPressure < 1.0)) {
    throw ConfigError(fmt::format(
        "jam_soft.target_pressure must be in (0, 1) (reduced p/k; soft-sphere jamming is the limit p/k -> 0), got {}",
        targetPressure));
  }
  if (!(pressureTolerance > 0.0 && pressureTolerance < 1.0)) {
    throw ConfigError(fmt::format("jam_soft.pressure_tolerance must be in (0, 1), got {}", pressureTolerance));
  }
  if (!(initialStep > 0.0 && initialStep <= 0.5)) {
    throw ConfigError(fmt::format("jam_soft.initial_step must be in (0, 0.5], got {}", initialStep));
  }
  if (!(maxStep >= initialStep && maxStep <= 0.5)) {
    throw ConfigError(fmt::format("jam_soft.max_step must be in [initial_step, 0.5], got {}", maxStep));
  }
  if (!(minBracket > 0.0 && minBracket < 1e-3)) {
    throw ConfigError(fmt::format("jam_soft.min_bracket must be in (0, 1e-3), got {}", minBracket));
  }
  if (maxSteps < 1) throw ConfigError(fmt::format("jam_soft.max_steps must be >= 1, got {}", maxSteps));
  if (!(jammingEstimate == 0.0 || (jammingEstimate > 0.0 && jammingEstimate < 1.0))) {
    throw ConfigError(fmt::format("jam_soft.jamming_estimate must be 0 (none) or a packing fraction in (0, 1), got {}",
                                  jammingEstimate));
  }
}

jamming::ContactNetwork softContactNetwork(const FireMinimiser& minimiser, const std::string& broadPhase) {
  jamming::ContactOptions options;
  options.relativeGap = 0.0;  // contacts are the overlapping pairs
  options.minContacts = 4;    // d + 1
  options.broadPhase = broadPhase;
  const Eigen::Matrix3Xd x = minimiser.wrappedPositions();
  return jamming::analyseContacts(SphereView{x, minimiser.particles().radius()}, minimiser.box(), options);
}

std::vector<SizeClassRattlers> rattlersBySize(const Eigen::VectorXd& radius, const std::vector<char>& rattler,
                                              int classes) {
  std::vector<SizeClassRattlers> out;
  if (radius.size() == 0 || classes < 1) return out;
  const double rMin = radius.minCoeff(), rMax = radius.maxCoeff();
  const int bins = rMax > rMin ? classes : 1;
  const double width = bins > 1 ? std::log(rMax / rMin) / bins : 1.0;
  out.resize(static_cast<std::size_t>(bins));
  for (int b = 0; b < bins; ++b) {
    out[b].rLow = rMin * std::exp(width * b);
    out[b].rHigh = b + 1 == bins ? rMax : rMin * std::exp(width * (b + 1));
  }
  for (Eigen::Index i = 0; i < radius.size(); ++i) {
    int b = bins > 1 ? static_cast<int>(std::log(radius[i] / rMin) / width) : 0;
    b = std::clamp(b, 0, bins - 1);
    ++out[b].count;
    if (rattler[static_cast<std::size_t>(i)]) ++out[b].rattlers;
  }
  return out;
}

}  // namespace polydem::integrators
