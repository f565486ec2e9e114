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
}

PressureJammingResult jamToPressure(FireMinimiser& minimiser, const PressureJammingSettings& settings,
                                    const JammingStepCallback& onStep, const FireMinimiser::Progress& fireProgress,
                                    bool stopOnInterrupt) {
  settings.validate();
  PressureJammingResult result;
  const double target = settings.targetPressure;
  // p ~ (phi - phi_J)^e near jamming: the false position works on p^(1/e), which is linear there.
  const bool hertz = minimiser.settings().contact.normal == contact::NormalModel::Hertz;
  auto linearised = [&](double p) { return hertz ? std::pow(p, 2.0 / 3.0) : p; };
  double lo = 0.0, pLo = 0.0, hi = 0.0, pHi = 0.0;
  double step = settings.initialStep;
  std::string action = "start";

  for (int s = 0;; ++s) {
    const FireResult fire = minimiser.minimise(fireProgress, stopOnInterrupt);
    ++result.steps;
    result.fireIterations += fire.iterations;
    result.lastFire = fire;
    const double phi = minimiser.packingFraction();
    const double p = fire.last.reducedPressure;
    result.packingFraction = phi;
    result.reducedPressure = p;
    if (onStep) onStep(JammingStep{s, phi, p, action, fire});

    if (fire.stopReason == "interrupted") {
      result.stopReason = "interrupted";
      break;
    }
    if (!fire.converged) {
      result.stopReason = fmt::format("not converged: residual {:.3g} after {} iterations ({})", fire.last.residual,
                                      fire.iterations, fire.stopReason);
      break;
    }
    if (std::abs(p - target) <= settings.pressureTolerance * target) {
      result.reached = true;
      result.stopReason = "target reached";
      break;
    }
    if (p < target) {
      lo = phi;
      pLo = p;
    } else {
      hi = phi;
      pHi = p;
    }
    if (result.steps >= settings.maxSteps) {
      result.stopReason = fmt::format("step budget: {} minimisations", settings.maxSteps);
      break;
    }
    double next = phi;
    if (hi == 0.0) {
      next = phi * (1.0 + step);
      step = std::min(2.0 * step, settings.maxStep);
      action = "compress";
    } else if (lo == 0.0) {
      next = phi * (1.0 - step);
      step = std::min(2.0 * step, settings.maxStep);
      action = "decompress";
    } else {
      if ((hi - lo) / hi < settings.minBracket) {
        result.stopReason =
            fmt::format("bracket below round-off: phi in [{:.15g}, {:.15g}] with p/k {:.4g} and {:.4g}, target {:.4g}",
                        lo, hi, pLo, pHi, target);
        break;
      }
      // Below jamming (p ~ 0: below 1e-3 target) phi_J lies anywhere in the bracket: bisect. Both jammed:
      // false position.
      double frac = 0.5;
      if (pLo > 1e-3 * target) {
        frac = (linearised(target) - linearised(pLo)) / (linearised(pHi) - linearised(pLo));
        frac = std::clamp(frac, 0.1, 0.9);
      }
      next = lo + frac * (hi - lo);
      action = next > phi ? "compress" : "decompress";
    }
    minimiser.scaleRadii(std::cbrt(next / phi));
  }
  result.lowPhi = lo;
  result.highPhi = hi;
  return result;
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
