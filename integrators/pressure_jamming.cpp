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

PressureJammingResult jamToPressure(FireMinimiser& minimiser, const PressureJammingSettings& settings,
                                    const JammingStepCallback& onStep, const FireMinimiser::Progress& fireProgress,
                                    bool stopOnInterrupt) {
  settings.validate();
  PressureJammingResult result;
  const double target = settings.targetPressure;
  // p ~ (phi - phi_J)^e near jamming: the false position works on p^(1/e), which is linear there.
  const bool hertz = minimiser.settings().contact.normal == contact::NormalModel::Hertz;
  auto linearised = [&](double p) { return hertz ? std::pow(p, 2.0 / 3.0) : p; };
  double lo = 0.0, hi = 0.0;
  double step = settings.initialStep;
  std::string action = "start";
  int lastDirection = 0;
  bool reversed = false;
  double lastPhi = 0.0, lastPressure = 0.0;

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
    const int direction = p < target ? 1 : -1;  // compress below the target, decompress above
    if (direction > 0) {
      lo = phi;
    } else {
      hi = phi;
    }
    if (result.steps >= settings.maxSteps) {
      result.stopReason = fmt::format("step budget: {} minimisations", settings.maxSteps);
      break;
    }
    // O'Hern et al.'s bisection, local: the step halves at each reversal of direction (and doubles, up to
    // maxStep, until the first one). Each state grows from the previous one, so the protocol follows the
    // configuration it has (a state left far above may unjam on decompression and jam again elsewhere, which
    // makes a global bracket stale).
    if (lastDirection != 0 && direction != lastDirection) {
      reversed = true;
      step *= 0.5;
    } else if (!reversed && lastDirection != 0) {
      step = std::min(2.0 * step, settings.maxStep);
    }
    if (step < settings.minBracket) {
      result.stopReason = fmt::format(
          "step below round-off: phi {:.15g} at p/k {:.4g}, relative step {:.3g}, target {:.4g}", phi, p, step, target);
      break;
    }
    double next = phi * (1.0 + direction * step);
    // Two jammed states in a row: the secant on p^(1/e), linear in phi near jamming, within the step.
    if (lastPressure > 1e-3 * target && p > 1e-3 * target && lastPressure != p) {
      const double secant =
          phi + (linearised(target) - linearised(p)) * (phi - lastPhi) / (linearised(p) - linearised(lastPressure));
      if (std::abs(secant - phi) <= step * phi) next = secant;
    } else if (settings.jammingEstimate > 0.0 && p > 1e-3 * target && phi > settings.jammingEstimate) {
      // One jammed state and the start's phi_J estimate: the secant through (estimate, 0) and this state.
      const double secant =
          settings.jammingEstimate + (phi - settings.jammingEstimate) * linearised(target) / linearised(p);
      if (std::abs(secant - phi) <= step * phi) next = secant;
    }
    action = next > phi ? "compress" : "decompress";
    lastDirection = direction;
    lastPhi = phi;
    lastPressure = p;
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
