#pragma once
// Initial configurations: a box sized for a target packing fraction and sphere centres in it, either
// without overlaps (random sequential addition) or with overlaps allowed (independent uniform centres).
// Lengths in metres (any consistent unit); packing fraction = total sphere volume / box volume.
#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "core/box.hpp"

namespace polydem {

struct PackingRequest {
  std::vector<double> radii;                     ///< one per sphere, > 0; output keeps this order
  double packingFraction = 0.3;                  ///< in (0, 1); sets the box volume
  Eigen::Vector3d aspect = {1.0, 1.0, 1.0};      ///< box edge ratios, > 0
  std::array<Boundary, 3> boundaries = {Boundary::Periodic, Boundary::Periodic, Boundary::Periodic};
  std::uint64_t seed = 1;                        ///< std::mt19937_64 seed for the centres
  std::int64_t maxAttemptsPerParticle = 20000;   ///< RSA gives up after this many rejected trial centres
};

struct Configuration {
  Box box;
  Eigen::Matrix3Xd position;  ///< 3 x N centres, column i for radii[i]; inside [0, L) on periodic axes
  Eigen::VectorXd radius;     ///< N radii, equal to the request's radii
};

/// Box volume = total sphere volume / packingFraction (edges proportional to aspect); random sequential
/// addition, largest spheres first, non-overlapping (gap >= 0 under minimum image on periodic axes; on
/// walled axes the whole sphere lies inside [r, L - r]). Expected O(N) with a private multi-level grid.
/// Throws ConfigError for bad requests (packingFraction outside (0, 1), non-positive radius or aspect,
/// a sphere wider than the box) and, naming the packing fraction reached and pointing to `polydem jam`,
/// when a sphere cannot be placed within maxAttemptsPerParticle attempts.
Configuration randomSequentialAddition(const PackingRequest& request);

/// Random centres with no excluded volume (overlaps allowed) at the given nominal packing fraction: for
/// cost-model checks and broad-phase tests. Same box and validation as randomSequentialAddition. O(N).
Configuration randomOverlapping(const PackingRequest& request);

}  // namespace polydem
