#include "integrators/time_step.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <vector>

#include "core/errors.hpp"

namespace polydem::integrators {

std::string TimeStepChoice::describe() const {
  const std::string second = slotB >= 0
                                 ? fmt::format("id {}, r = {:g}", idB, radiusB)
                                 : fmt::format("the wall {}{}", (-1 - slotB) & 1 ? "+" : "-", "xyz"[(-1 - slotB) >> 1]);
  return fmt::format("dt = {:.6g} s = t_c,min / {:g}; t_c,min = {:.6g} s, set by particle id {} (r = {:g}) and {}", dt,
                     stepsPerContact, contactDuration, idA, radiusA, second);
}

TimeStepChoice chooseTimeStep(const contact::ContactModel& model, const ParticleStore& particles, const Box& box,
                              double stepsPerContact, double impactSpeed) {
  if (!(stepsPerContact >= kMinStepsPerContact) || !std::isfinite(stepsPerContact)) {
    throw ConfigError(fmt::format(
        "run.dt_factor (steps per contact) must be a finite number >= {:g}, got {}: fewer steps per contact "
        "make velocity Verlet inaccurate and then unstable",
        kMinStepsPerContact, stepsPerContact));
  }
  const Index n = particles.count();
  if (n == 0) throw ConfigError("no particles: cannot choose a time step");
  const bool hertz = model.parameters().normal == contact::NormalModel::Hertz;
  if (hertz && !(impactSpeed > 0.0 && std::isfinite(impactSpeed))) {
    throw ConfigError(fmt::format(
        "contact.reference_velocity must be > 0 for the Hertz law when the particles start at rest (the contact "
        "duration depends on the impact speed), got {}",
        impactSpeed));
  }

  // The sample: lightest two, smallest two, largest, and radius quantiles.
  const Eigen::VectorXd& radius = particles.radius();
  const Eigen::VectorXd& inverseMass = particles.inverseMass();
  std::vector<Index> byRadius(static_cast<std::size_t>(n));
  std::iota(byRadius.begin(), byRadius.end(), Index{0});
  std::sort(byRadius.begin(), byRadius.end(), [&](Index a, Index b) { return radius[a] < radius[b]; });
  std::vector<Index> byMass = byRadius;
  std::partial_sort(byMass.begin(), byMass.begin() + std::min<Index>(2, n), byMass.end(),
                    [&](Index a, Index b) { return inverseMass[a] > inverseMass[b]; });
  std::vector<Index> sample = {byMass[0], byRadius[0], byRadius.back()};
  if (n > 1) {
    sample.push_back(byMass[1]);
    sample.push_back(byRadius[1]);
  }
  constexpr Index kQuantiles = 64;
  for (Index q = 0; q < std::min(kQuantiles, n); ++q) {
    sample.push_back(byRadius[static_cast<std::size_t>((static_cast<std::int64_t>(q) * (n - 1)) /
                                                       std::max<Index>(1, std::min(kQuantiles, n) - 1))]);
  }
  std::sort(sample.begin(), sample.end());
  sample.erase(std::unique(sample.begin(), sample.end()), sample.end());

  TimeStepChoice best;
  best.contactDuration = std::numeric_limits<double>::infinity();
  auto consider = [&](double tc, Index a, Index b) {
    if (tc < best.contactDuration) {
      best.contactDuration = tc;
      best.slotA = a;
      best.slotB = b;
    }
  };
  for (std::size_t p = 0; p < sample.size(); ++p) {
    const Index a = sample[p];
    for (std::size_t q = p + 1; q < sample.size(); ++q) {
      const Index b = sample[q];
      const double meff = 1.0 / (inverseMass[a] + inverseMass[b]);
      const double reff = radius[a] * radius[b] / (radius[a] + radius[b]);
      consider(model.contactDuration(meff, reff, impactSpeed), a, b);
    }
    for (int face = 0; face < 6; ++face) {
      if (box.periodic(face >> 1)) continue;
      consider(model.contactDuration(1.0 / inverseMass[a], radius[a], impactSpeed), a, -1 - face);
    }
  }
  if (!std::isfinite(best.contactDuration)) {
    // One particle in a periodic box: no contact can occur; use a copy of itself as the partner.
    const Index a = sample[0];
    best.contactDuration = model.contactDuration(0.5 / inverseMass[a], 0.5 * radius[a], impactSpeed);
    best.slotA = best.slotB = a;
  }
  best.stepsPerContact = stepsPerContact;
  best.dt = best.contactDuration / stepsPerContact;
  best.idA = particles.id()[static_cast<std::size_t>(best.slotA)];
  best.radiusA = radius[best.slotA];
  if (best.slotB >= 0) {
    best.idB = particles.id()[static_cast<std::size_t>(best.slotB)];
    best.radiusB = radius[best.slotB];
  }
  if (!(best.dt > 0.0 && std::isfinite(best.dt))) {
    throw ConfigError(
        fmt::format("could not choose a time step (t_c,min = {}): check masses and stiffness", best.contactDuration));
  }
  return best;
}

}  // namespace polydem::integrators
