#pragma once
// Pressure-controlled jamming of frictionless soft spheres (O'Hern, Silbert, Liu & Nagel, Phys. Rev. E 68,
// 011306 (2003), section II): grow (or shrink) every radius by a common factor, minimise the energy with
// FIRE after each change, and home in on the packing fraction at which the minimised reduced pressure p/k
// equals a target (down to 1e-7 and below). Each state grows from the previous one: compress while p is
// below the target, decompress while above, halving the relative step at each reversal (the step doubles, up
// to maxStep, until the first reversal). Two jammed states in a row give the secant on p^(1/e) (e = 1
// harmonic, 3/2 Hertz: p ~ (phi - phi_J)^e, so p^(1/e) is linear in phi near jamming), taken when it lies
// within the current step (with one jammed state and a known phi_J estimate of the start, the secant
// through (estimate, 0) and that state). A global bisection bracket is not used: a state far above unjams on
// decompression and jams again at another phi, so an old upper end becomes stale (seen in tests at N = 256). Reached
// when |p - target| <= pressureTolerance x target.
//
// phi_J is the packing fraction at the final state (at p/k = target it differs from the p -> 0 limit by
// about target / (dp/dphi), 1e-7 at the default target). Contacts, rattlers and the backbone's contact
// number are from jamming::analyseContacts on the overlapping pairs (gap <= 0): rattlers are spheres with
// fewer than d + 1 = 4 contacts among non-rattlers, removed recursively (jamming/contact_network.hpp).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "integrators/fire_minimiser.hpp"
#include "jamming/contact_network.hpp"

namespace polydem::integrators {

struct PressureJammingSettings {
  double targetPressure = 1e-6;     ///< reduced pressure p / FireMinimiser::pressureUnit(), > 0
  double pressureTolerance = 0.05;  ///< relative: reached when |p - target| <= this x target
  double initialStep = 1e-3;        ///< first relative change of phi (dphi / phi)
  double maxStep = 0.02;            ///< largest relative change of phi per step while unbracketed
  double minBracket = 1e-13;        ///< give up when the bracket's relative width falls below (round-off)
  int maxSteps = 300;               ///< minimisations in all
  /// phi_J of the start if known (0 = none), e.g. the estimate phi / (1 - 3/P) of a hard-sphere packing at
  /// reduced pressure P (`polydem jam`): while only one jammed state is known, the secant runs through
  /// (jammingEstimate, p = 0) and that state, taken like the two-state secant only within the current step.
  double jammingEstimate = 0.0;
  /// Throws ConfigError naming the key (jam_soft.target_pressure, ...).
  void validate() const;
};

/// One minimisation of the protocol.
struct JammingStep {
  int step = 0;
  double packingFraction = 0.0;
  double reducedPressure = 0.0;
  std::string action;  ///< "start", "compress", "decompress", "bracket"
  FireResult fire;
};

struct PressureJammingResult {
  bool reached = false;
  std::string stopReason;  ///< "target reached", "not converged: ...", "step budget", "step below round-off", ...
  int steps = 0;
  std::int64_t fireIterations = 0;  ///< FIRE steps over every minimisation
  double packingFraction = 0.0;     ///< phi at the final state: phi_J at the target pressure
  double reducedPressure = 0.0;
  double lowPhi = 0.0, highPhi = 0.0;  ///< the last phi below and above the target (0 = none)
  FireResult lastFire;
};

using JammingStepCallback = std::function<void(const JammingStep&)>;

/// Run the protocol on `minimiser` from its current state. The progress callback of each minimisation is
/// `fireProgress`; `onStep` is called after each. With `stopOnInterrupt`, polls polydem::interruptRequested().
/// A minimisation that does not converge ends the protocol (stopReason "not converged: ..."). `Minimiser`:
/// FireMinimiser, or parallel::DistributedFire (the same protocol on MPI ranks): minimise(), packingFraction(),
/// scaleRadii() and settings().
template <class Minimiser>
PressureJammingResult jamToPressure(Minimiser& minimiser, const PressureJammingSettings& settings,
                                    const JammingStepCallback& onStep = {},
                                    const FireMinimiser::Progress& fireProgress = {}, bool stopOnInterrupt = false);

/// Contact network of the minimised state: contacts are overlapping pairs (relative gap <= 0), rattlers
/// removed recursively with fewer than 4 contacts (jamming::analyseContacts).
jamming::ContactNetwork softContactNetwork(const FireMinimiser& minimiser, const std::string& broadPhase);

/// Rattler fraction per size class: `classes` bins of equal width in log r between r_min and r_max.
struct SizeClassRattlers {
  double rLow = 0.0, rHigh = 0.0;
  Index count = 0, rattlers = 0;
};
std::vector<SizeClassRattlers> rattlersBySize(const Eigen::VectorXd& radius, const std::vector<char>& rattler,
                                              int classes);

template <class Minimiser>
PressureJammingResult jamToPressure(Minimiser& minimiser, const PressureJammingSettings& settings,
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

}  // namespace polydem::integrators
