#pragma once
// Initial velocities for relaxation runs, following the preparation protocol ("Experimental setup") of
// Ogarko & Luding, Comput. Phys. Commun. 183 (2012) 931, numerical experiments (V. Ogarko, PhD thesis,
// University of Twente, ch. 2.1.4): random velocities scaled so that two of the smallest (lightest) particles
// colliding head-on reach a maximum overlap of about `overlapFraction` (1%) of their radius.
//
// Velocities are Gaussian with equipartition (per-component sigma_i = sigma sqrt(m_min / m_i), the
// state an event-driven growth stage leaves behind), total momentum removed. For a Maxwellian gas the
// normal approach speed of colliding pairs of the lightest particles has mean sqrt(pi) sigma (the
// Rayleigh mean of the relative velocity weighted by the collision rate), so sigma = v* / sqrt(pi)
// with v* the head-on speed that gives the target overlap under the undamped law.
#include <cstdint>

#include "contact/contact_law.hpp"
#include "core/particle_store.hpp"

namespace polydem::integrators {

/// Overwrite the velocities (and zero angular velocities). Returns v* (m/s), the head-on speed of two
/// lightest particles that reaches the target overlap. Throws ConfigError for overlapFraction <= 0.
double assignImpactVelocities(const contact::ContactModel& model, ParticleStore& particles, double overlapFraction,
                              std::uint64_t seed);

}  // namespace polydem::integrators
