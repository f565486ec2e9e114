#pragma once
// Seeded starts for the minimiser tests: equal spheres at independent random centres (overlaps allowed) in
// a periodic cube, and the minimiser settings the tests share (radius-scaled harmonic contacts, k = 1).
#include <cstdint>
#include <string>
#include <vector>

#include "core/initial_configuration.hpp"
#include "core/particle_store.hpp"
#include "integrators/fire_minimiser.hpp"

namespace polydem::test {

struct SoftStart {
  ParticleStore particles;
  Box box;
};

/// N spheres of radius 0.5 (or the given radii) at random centres at packing fraction phi, periodic.
inline SoftStart randomSoftStart(Index n, double phi, std::uint64_t seed, std::vector<double> radii = {}) {
  PackingRequest req;
  req.radii = radii.empty() ? std::vector<double>(static_cast<std::size_t>(n), 0.5) : std::move(radii);
  req.packingFraction = phi;
  req.seed = seed;
  const Configuration c = randomOverlapping(req);
  SoftStart s{ParticleStore(static_cast<Index>(c.radius.size()), Features{}), c.box};
  s.particles.position() = c.position;
  s.particles.radius() = c.radius;
  s.particles.setMassesFromDensity(1.0);
  for (Index i = 0; i < s.particles.count(); ++i) s.particles.id()[static_cast<std::size_t>(i)] = i;
  return s;
}

/// Harmonic contacts k_ij = k R_eff (k = 1, so p/k is the pressure), elastic, frictionless.
inline integrators::MinimiserSettings harmonicSettings(const std::string& broadPhase = "linked-cell") {
  integrators::MinimiserSettings s;
  s.contact.normal = contact::NormalModel::Linear;
  s.contact.scaling = contact::StiffnessScaling::Radius;
  s.contact.stiffness = 1.0;
  s.broadPhase = broadPhase;
  return s;
}

}  // namespace polydem::test
