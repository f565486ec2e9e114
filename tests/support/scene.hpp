#pragma once
// Seeded scene generators shared by the tests and the benchmarks.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "broadphase/broad_phase.hpp"
#include "core/box.hpp"
#include "core/moments.hpp"
#include "core/particle_store.hpp"

namespace polydem::test {

struct SceneSpec {
  Index count = 1000;
  std::string distribution = "mono";  ///< any DistributionSpec kind; "bi" uses equal volumes
  double sizeRatio = 1.0;             ///< omega
  double packing = 0.3;               ///< nominal packing fraction (centres are random: overlaps allowed)
  bool periodic = true;               ///< all axes periodic, else all walls
  std::uint64_t seed = 1;
};

struct Scene {
  Box box;
  Eigen::Matrix3Xd centre;
  Eigen::VectorXd radius;
  SphereView spheres() const { return {centre, radius}; }
  double minRadius() const { return radius.size() ? radius.minCoeff() : 1.0; }
};

/// Random centres (uniform, overlapping) with systematically sampled radii in a cube sized for the
/// nominal packing fraction, enlarged if needed so periodic axes hold 2 cut-offs (skin up to rmin).
Scene makeScene(const SceneSpec& spec);

/// Pairs reported by `backend` with the given skin, sorted.
std::vector<broadphase::Pair> pairsFrom(std::string_view backend, const Scene& scene, double skin);

/// Order-independent checksum of a pair set (makes a fast wrong answer visible in benchmarks).
std::uint64_t checksum(const std::vector<broadphase::Pair>& pairs);

/// Analytic moments of the distribution family `kind` with size ratio `omega` (log-normal: width `sigma`),
/// other DistributionSpec fields at their defaults.
Moments analyticMoments(const std::string& kind, double omega, double sigma = 0.5);

}  // namespace polydem::test
