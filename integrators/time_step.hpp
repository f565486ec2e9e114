#pragma once
// The automatic time step: dt = t_c,min / f, with t_c,min the shortest head-on contact duration over
// the particle pairs (and particle-wall pairs) that can occur and f the number of steps per contact.
//
// Which pair is shortest depends on the law: constant linear stiffness -> the smallest reduced mass;
// radius-scaled linear -> the smallest m_eff / R_eff; Hertz -> also the impact speed. Rather than
// special-case each, chooseTimeStep() evaluates the law on all pairs of a sample of particles: the two
// lightest, the two smallest, the largest, and 64 radius quantiles (at most ~70^2 / 2 pairs), plus
// each with a wall when the box has walls. Pairs are of distinct particles, so a two-particle scene
// gets exactly the duration of its one pair. Ogarko & Luding, Comput. Phys. Commun. 183 (2012) 931
// (thesis ch. 2.1.4) set dt from the smallest contact duration without stating f; the default f = 50
// (DemSettings::stepsPerContact) is the common DEM choice, not theirs.
#include <string>

#include "contact/contact_law.hpp"
#include "core/box.hpp"
#include "core/particle_store.hpp"

namespace polydem::integrators {

inline constexpr double kMinStepsPerContact = 5.0;

struct TimeStepChoice {
  double dt = 0.0;               ///< s
  double contactDuration = 0.0;  ///< t_c,min, s
  double stepsPerContact = 0.0;  ///< f = t_c,min / dt
  Index slotA = -1, slotB = -1;  ///< the pair that set t_c,min; slotB = -1 - face for a wall
  Index idA = -1, idB = -1;      ///< their stored ids (idB = -1 for a wall)
  double radiusA = 0.0, radiusB = 0.0;
  /// "dt = 1.2e-05 s = t_c,min / 50, t_c,min = 6.1e-04 s (particles id 3, r = 0.5 and id 17, r = 0.5)"
  std::string describe() const;
};

/// t_c,min and dt = t_c,min / stepsPerContact. `impactSpeed` (m/s) is the Hertz reference speed
/// (ignored by the linear law). Throws ConfigError if stepsPerContact < 5 (naming run.dt_factor), for
/// an empty store, or for a Hertz law without a positive impact speed. O(N + 70^2).
TimeStepChoice chooseTimeStep(const contact::ContactModel& model, const ParticleStore& particles, const Box& box,
                              double stepsPerContact, double impactSpeed);

}  // namespace polydem::integrators
