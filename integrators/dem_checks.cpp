// DemSimulation's stability checks and the errors of a run that went wrong: every SimulationError names
// the step, the particles and the likely cause with a concrete fix (see dem_simulation.hpp).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/errors.hpp"
#include "integrators/dem_simulation.hpp"

namespace polydem::integrators {

namespace {

std::string faceName(int face) { return fmt::format("{}{}", (face & 1) ? "+" : "-", "xyz"[face >> 1]); }

}  // namespace

std::string DemSimulation::dtHint() const {
  const double f = timeStep_.stepsPerContact;
  const std::string law =
      fmt::format("{} = {:g}", model_.parameters().normal == contact::NormalModel::Linear ? "k" : "K",
                  model_.parameters().stiffness);
  if (settings_.timeStep > 0.0) {
    // The user fixed dt: run.dt_factor has no effect, so the fix must name run.dt.
    return fmt::format(
        "run.dt = {:.4g} s is too large for stiffness {}: it is t_c,min / {:.3g} (t_c,min = {:.4g} s); "
        "use run.dt <= {:.4g} s (t_c,min / 50), or remove run.dt and let run.dt_factor choose it",
        dt_, law, f, timeStep_.contactDuration, timeStep_.contactDuration / 50.0);
  }
  return fmt::format(
      "dt too large for stiffness {}: dt = {:.4g} s is t_c,min / {:.3g} (t_c,min = {:.4g} s); use "
      "run.dt_factor f >= {:g}",
      law, dt_, f, timeStep_.contactDuration, std::max(50.0, std::ceil(2.0 * f)));
}

void DemSimulation::blowUp(Index slot, const std::string& what) const {
  // A blow-up is a property of the run, not of the input: name the step, the particle, its speed and
  // the energy against the start, so nobody goes looking for a bad coordinate in the input file.
  const Eigen::Matrix3Xd& v = particles_.velocity();
  Index fastest = 0;
  double fastestSpeed = -1.0;
  for (Index i = 0; i < particles_.count(); ++i) {
    const double speed = v.col(i).norm();
    if (!(speed <= fastestSpeed)) {  // NaN counts as fastest
      fastestSpeed = speed;
      fastest = i;
    }
  }
  double kinetic = 0.0;
  for (Index i = 0; i < particles_.count(); ++i) kinetic += 0.5 * v.col(i).squaredNorm() / particles_.inverseMass()[i];
  fail(fmt::format("blow-up: particle id {} has {}; fastest particle id {} at {:.3g} m/s, kinetic energy {:.4g} J "
                   "(total energy at step 0: {:.4g} J)",
                   particles_.id()[static_cast<std::size_t>(slot)], what,
                   particles_.id()[static_cast<std::size_t>(fastest)], fastestSpeed, kinetic, initialEnergy_),
       dtHint());
}

void DemSimulation::fail(const std::string& what, const std::string& cause) const {
  // The energy against step 0 tells a blow-up (energy grown by orders of magnitude) from a local fault.
  const double energy = energies().total();
  std::string energyText;
  if (std::isfinite(energy)) {
    const bool blowUp = std::abs(energy) > 10.0 * std::abs(initialEnergy_) && initialEnergy_ != 0.0;
    energyText = fmt::format(
        "; total energy {:.4g} J (step 0: {:.4g} J){}", energy, initialEnergy_,
        blowUp ? fmt::format(", {:.3g} times larger: the run blew up", energy / initialEnergy_) : std::string());
  } else {
    energyText = fmt::format("; total energy not finite (step 0: {:.4g} J): the run blew up", initialEnergy_);
  }
  throw SimulationError(
      fmt::format("step {} (t = {:.6g} s): {}{}. Likely cause: {}", step_, time(), what, energyText, cause));
}

contact::ContactStats DemSimulation::checkStability() const {
  const Index n = particles_.count();
  const Eigen::Matrix3Xd& x = particles_.position();
  const Eigen::Matrix3Xd& v = particles_.velocity();
  auto idOf = [&](Index slot) { return particles_.id()[static_cast<std::size_t>(slot)]; };
  double maxSpeed = 0.0;
  for (Index i = 0; i < n; ++i) {
    const bool rotationBad = particles_.features().rotation && !particles_.angularVelocity().col(i).allFinite();
    if (!x.col(i).allFinite() || !v.col(i).allFinite() || rotationBad) {
      fail(fmt::format("particle id {} (r = {:g}) has a non-finite {}", idOf(i), particles_.radius()[i],
                       !x.col(i).allFinite() ? "position" : (rotationBad ? "angular velocity" : "velocity")),
           dtHint());
    }
    maxSpeed = std::max(maxSpeed, v.col(i).norm());
    for (int k = 0; k < 3; ++k) {
      if (box_.periodic(k)) continue;
      if (x(k, i) < 0.0 || x(k, i) > box_.length(k)) {
        const double needed =
            model_.stiffnessForOverlap(0.05 * particles_.radius()[i], 1.0 / particles_.inverseMass()[i],
                                       particles_.radius()[i], std::max(maxSpeed, v.col(i).norm()));
        fail(fmt::format("particle id {} (r = {:g}) left the walled box through the {} wall ({} = {:g}, box {})",
                         idOf(i), particles_.radius()[i], faceName(2 * k + (x(k, i) > 0.0 ? 1 : 0)), "xyz"[k], x(k, i),
                         box_.describe()),
             timeStep_.stepsPerContact < 20.0
                 ? dtHint()
                 : fmt::format("the wall contact is too soft for the impact speed ({:.3g} m/s): stiffness >= {:.3g} "
                               "keeps that impact below 5% of the radius",
                               v.col(i).norm(), needed));
      }
    }
  }

  const contact::ContactStats stats = contactStats();
  if (stats.maxOverlapRatio > settings_.stability.maxOverlapFraction) {
    const Index i = stats.maxOverlapI, j = stats.maxOverlapJ;
    const double ri = particles_.radius()[i];
    std::string partner;
    double meff, reff, rsmall, speed;
    if (j >= 0) {
      const double rj = particles_.radius()[j];
      partner = fmt::format("particle id {} (r = {:g})", idOf(j), rj);
      meff = 1.0 / (particles_.inverseMass()[i] + particles_.inverseMass()[j]);
      reff = ri * rj / (ri + rj);
      rsmall = std::min(ri, rj);
    } else {
      partner = fmt::format("the {} wall", faceName(-1 - j));
      meff = 1.0 / particles_.inverseMass()[i];
      reff = ri;
      rsmall = ri;
    }
    speed = std::max(2.0 * maxSpeed, 1e-300);
    const double needed = model_.stiffnessForOverlap(0.05 * rsmall, meff, reff, speed);
    const std::string cause =
        timeStep_.stepsPerContact < 20.0 ? dtHint()
        : settings_.impactOverlap > 0.0
            ? fmt::format(
                  "the impacts are too fast: the initial velocities were scaled so that two smallest "
                  "particles overlap by velocities.overlap = {:g} of their radius, and larger or faster "
                  "pairs overlap more; lower velocities.overlap (changing the stiffness only rescales the "
                  "velocities again)",
                  settings_.impactOverlap)
            : fmt::format(
                  "stiffness {:g} too soft for the impact speeds (fastest particle {:.3g} m/s): stiffness >= "
                  "{:.3g} keeps a head-on impact of this pair below 5% of the smaller radius; or start slower "
                  "(seed protocol: 1% overlap of the smallest particles)",
                  model_.parameters().stiffness, maxSpeed, needed);
    fail(fmt::format("particle id {} (r = {:g}) and {} overlap by {:.3g} of the smaller radius (limit {:g})", idOf(i),
                     ri, partner, stats.maxOverlapRatio, settings_.stability.maxOverlapFraction),
         cause);
  }

  if (conservative_) {
    const double energy = energies(stats).total();
    const double scale = std::max(std::abs(initialEnergy_), std::numeric_limits<double>::min());
    const double growth = (energy - initialEnergy_) / scale;
    if (growth > settings_.stability.energyTolerance) {
      fail(fmt::format("total energy grew by {:.3g}% since step 0 (from {:.6g} J to {:.6g} J) in an elastic run "
                       "(tolerance {:g}%)",
                       100.0 * growth, initialEnergy_, energy, 100.0 * settings_.stability.energyTolerance),
           dtHint());
    }
  }
  return stats;
}

}  // namespace polydem::integrators
