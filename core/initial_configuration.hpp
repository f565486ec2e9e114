#pragma once
// Initial configurations: a box sized for a target packing fraction and sphere centres in it, either
// without overlaps (random sequential addition) or with overlaps allowed (independent uniform centres).
// Lengths in metres (any consistent unit); packing fraction = total sphere volume / box volume.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/box.hpp"
#include "core/size_distribution.hpp"
#include "core/types.hpp"

namespace polydem {

struct PackingRequest {
  std::vector<double> radii;                 ///< one per sphere, > 0; output keeps this order
  double packingFraction = 0.3;              ///< in (0, 1); sets the box volume
  Eigen::Vector3d aspect = {1.0, 1.0, 1.0};  ///< box edge ratios, > 0
  std::array<Boundary, 3> boundaries = {Boundary::Periodic, Boundary::Periodic, Boundary::Periodic};
  std::uint64_t seed = 1;                       ///< std::mt19937_64 seed for the centres
  std::int64_t maxAttemptsPerParticle = 20000;  ///< RSA gives up after this many rejected trial centres
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

enum class Placement {
  RandomSequentialAddition,  ///< no overlaps (randomSequentialAddition)
  RandomOverlapping          ///< independent uniform centres (randomOverlapping)
};

/// What a start packing is made of: the radii (a sample of a distribution, or given), their order, the
/// placement. The shared recipe of `polydem generate`, `jam` and `relax`.
struct StartPackingRequest {
  Index count = 0;                           ///< spheres sampled when `radii` is empty
  Sampling sampling = Sampling::Systematic;  ///< how the sample is drawn
  std::vector<double> radii;                 ///< given radii (e.g. an equivalent mixture) instead of a sample
  double packingFraction = 0.3;              ///< as in PackingRequest
  Eigen::Vector3d aspect = {1.0, 1.0, 1.0};
  std::array<Boundary, 3> boundaries = {Boundary::Periodic, Boundary::Periodic, Boundary::Periodic};
  std::uint64_t seed = 1;  ///< seeds the sample, the shuffle (seed ^ kStartShuffleSalt) and the centres
  Placement placement = Placement::RandomSequentialAddition;
};

/// Salt of the shuffle's std::mt19937_64 seed, so that the shuffle and the sample draw differently.
inline constexpr std::uint64_t kStartShuffleSalt = 0x9e3779b97f4a7c15ULL;

struct StartPacking {
  Configuration configuration;  ///< box, centres, radii in the shuffled order
  std::vector<Index> id;        ///< 0..N-1
  std::string distribution;     ///< distribution.describe(), for the file's "distribution" attribute
};

/// A start packing: radii sampled from `distribution` (request.count, request.sampling, request.seed)
/// unless request.radii is given, shuffled with std::mt19937_64(seed ^ kStartShuffleSalt) so that sizes
/// are not sorted in memory, then placed by request.placement. Throws what the placement throws.
StartPacking makeStartPacking(const SizeDistribution& distribution, const StartPackingRequest& request);

}  // namespace polydem
