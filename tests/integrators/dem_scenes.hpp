#pragma once
// Small seeded DEM scenes for the integrator tests: head-on pairs timed to touch at a half step, and
// non-overlapping gases on a jittered lattice.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "core/box.hpp"
#include "core/particle_store.hpp"
#include "integrators/dem_simulation.hpp"

namespace polydem::test {

/// Two spheres on the x axis of a periodic box, approaching with relative speed `speed` (zero total
/// momentum), unit density. Placed so that the gap closes after `steps + 1/2` steps of `dt`: with
/// dt = t_c / f exactly, the contact then starts and ends half-way between steps, where velocity
/// Verlet's midpoint treatment of the force jump at contact onset is second-order accurate.
struct HeadOn {
  ParticleStore particles;
  Box box;
};

inline HeadOn headOn(double r1, double r2, double speed, double dt, double stepsBeforeContact, bool rotation = false) {
  HeadOn s{ParticleStore(2, Features{.rotation = rotation}), Box()};
  const double edge = 4.0 * (2.0 * std::max(r1, r2)) + 10.0 * (r1 + r2);
  s.box = Box::cubic(edge, Boundary::Periodic);
  s.particles.radius() << r1, r2;
  s.particles.setMassesFromDensity(1.0);
  const double m1 = 1.0 / s.particles.inverseMass()[0], m2 = 1.0 / s.particles.inverseMass()[1];
  const double gap = (stepsBeforeContact + 0.5) * dt * speed;
  const double x1 = 0.5 * edge - 0.5 * (r1 + r2 + gap);
  s.particles.position().col(0) << x1, 0.5 * edge, 0.5 * edge;
  s.particles.position().col(1) << x1 + r1 + r2 + gap, 0.5 * edge, 0.5 * edge;
  s.particles.velocity().col(0) << speed * m2 / (m1 + m2), 0.0, 0.0;
  s.particles.velocity().col(1) << -speed * m1 / (m1 + m2), 0.0, 0.0;
  return s;
}

/// `radii.size()` spheres, unit density, on a jittered cubic lattice in a cube sized for the packing
/// fraction (clamped so that lattice sites keep the spheres apart). No overlaps.
inline ParticleStore latticeGas(const std::vector<double>& radii, double packing, Box& box, std::uint64_t seed,
                                bool rotation = false,
                                std::array<Boundary, 3> boundaries = {Boundary::Periodic, Boundary::Periodic,
                                                                      Boundary::Periodic}) {
  const auto n = static_cast<Index>(radii.size());
  double volume = 0.0, rmax = 0.0;
  for (double r : radii) {
    volume += 4.0 / 3.0 * kPi * r * r * r;
    rmax = std::max(rmax, r);
  }
  const int perSide = static_cast<int>(std::ceil(std::cbrt(static_cast<double>(n))));
  double edge = std::cbrt(volume / packing);
  edge = std::max(edge, perSide * 2.0 * rmax * 1.05);
  edge = std::max(edge, 2.0 * (2.0 * rmax + rmax));
  box = Box(Eigen::Vector3d::Constant(edge), boundaries);
  ParticleStore p(n, Features{.rotation = rotation});
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double spacing = edge / perSide;
  std::vector<int> sites(static_cast<std::size_t>(perSide) * perSide * perSide);
  for (std::size_t k = 0; k < sites.size(); ++k) sites[k] = static_cast<int>(k);
  std::shuffle(sites.begin(), sites.end(), rng);
  for (Index i = 0; i < n; ++i) {
    const int s = sites[static_cast<std::size_t>(i)];
    const double r = radii[static_cast<std::size_t>(i)];
    p.radius()[i] = r;
    const double room = std::max(0.0, 0.5 * spacing - r) * 0.9;
    const int c[3] = {s % perSide, (s / perSide) % perSide, s / (perSide * perSide)};
    for (int k = 0; k < 3; ++k) p.position()(k, i) = (c[k] + 0.5) * spacing + room * u(rng);
  }
  p.setMassesFromDensity(1.0);
  return p;
}

/// Final state in id order (slots change with the spatial sort).
inline Eigen::Matrix3Xd positionsById(const ParticleStore& p) {
  Eigen::Matrix3Xd out(3, p.count());
  for (Index i = 0; i < p.count(); ++i) out.col(p.id()[static_cast<std::size_t>(i)]) = p.position().col(i);
  return out;
}
inline Eigen::Matrix3Xd velocitiesById(const ParticleStore& p) {
  Eigen::Matrix3Xd out(3, p.count());
  for (Index i = 0; i < p.count(); ++i) out.col(p.id()[static_cast<std::size_t>(i)]) = p.velocity().col(i);
  return out;
}

}  // namespace polydem::test
