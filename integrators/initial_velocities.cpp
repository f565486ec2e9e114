#include "integrators/initial_velocities.hpp"

#include <fmt/format.h>

#include <cmath>
#include <random>

#include "core/errors.hpp"

namespace polydem::integrators {

double assignImpactVelocities(const contact::ContactModel& model, ParticleStore& particles, double overlapFraction,
                              std::uint64_t seed) {
  if (!(overlapFraction > 0.0 && std::isfinite(overlapFraction))) {
    throw ConfigError(fmt::format("velocities.overlap must be > 0, got {}", overlapFraction));
  }
  const Index n = particles.count();
  if (n == 0) return 0.0;
  const Eigen::VectorXd& im = particles.inverseMass();
  Index lightest = 0;
  for (Index i = 1; i < n; ++i) {
    if (im[i] > im[lightest]) lightest = i;
  }
  const double mmin = 1.0 / im[lightest];
  const double rmin = particles.radius()[lightest];
  const double target = model.speedForOverlap(overlapFraction * rmin, 0.5 * mmin, 0.5 * rmin);
  const double sigma = target / std::sqrt(kPi);

  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  Eigen::Matrix3Xd& v = particles.velocity();
  Eigen::Vector3d momentum = Eigen::Vector3d::Zero();
  double mass = 0.0;
  for (Index i = 0; i < n; ++i) {
    const double s = sigma * std::sqrt(mmin * im[i]);
    for (int k = 0; k < 3; ++k) v(k, i) = s * gauss(rng);
    momentum += v.col(i) / im[i];
    mass += 1.0 / im[i];
  }
  if (n > 1) v.colwise() -= momentum / mass;
  if (particles.features().rotation) particles.angularVelocity().setZero();
  return target;
}

}  // namespace polydem::integrators
