#pragma once
// Channel sizes from neighbour triangles (Ogarko's thesis §4.2, i.e. Ogarko, Rivas & Luding, submitted
// 2014, thesis §4.2): for every particle i and
// every 3-subset {a, b, c} of its weighted-Delaunay neighbours (the central particle is not a vertex),
// keep the triangle if it is acute, a^2 + b^2 > eps c^2 for every edge ordering with eps = 1 - 1e-12
// (right angles kept; footnote §4.3), and take the circle in the triangle's plane that is
// externally tangent to the three great circles of the neighbours (the Apollonius problem, §4.2)
// and contains none of their centres: the channel, of radius R_j. The statistic is the histogram of
// R_j / r_i, bin 0.01, normalised to unit area (§4.2). Peaks: 2/sqrt(3) - 1 (three touching equal
// spheres), sqrt(2) - 1 (square), 1 (three touching neighbours coplanar with the centre at 120 deg).
//
// Apollonius solver (our reconstruction of thesis §4.2): in plane coordinates with centre 1 at the
// origin, |x - c_k| = R + r_k minus the same equation for k = 1 is linear in (x, R):
//   2 c_k . x + 2 (r_k - r_1) R = |c_k|^2 - r_k^2 + r_1^2     (k = 2, 3)
// so x = x0 + R x1 (the triangle is acute, hence not degenerate), and |x|^2 = (R + r_1)^2 gives
//   (|x1|^2 - 1) R^2 + 2 (x0.x1 - r_1) R + |x0|^2 - r_1^2 = 0,
// solved without cancellation. Every positive root is a circle tangent from outside to all three (so it
// contains no centre); the smallest one is the gap circle. No positive root (overlapping circles): skip.
#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <vector>

#include "structure/delaunay_neighbours.hpp"

namespace polydem::structure {

inline constexpr double kAcuteEpsilon = 1.0 - 1e-12;

/// Radius of the circle in the plane of the three centres that is externally tangent to the three
/// circles (centre c_k, radius r_k) and contains no centre, or nothing if there is none. Does not apply
/// the acute filter. Centres in any frame (m).
std::optional<double> apolloniusGapRadius(const Eigen::Vector3d& c1, double r1, const Eigen::Vector3d& c2, double r2,
                                          const Eigen::Vector3d& c3, double r3);

/// True for acute (or right, within eps) triangles: a^2 + b^2 > eps c^2 for all three orderings.
bool acuteTriangle(const Eigen::Vector3d& c1, const Eigen::Vector3d& c2, const Eigen::Vector3d& c3,
                   double eps = kAcuteEpsilon);

struct ChannelOptions {
  double binWidth = 0.01;  ///< of R_j / r_i
  double eps = kAcuteEpsilon;
  double maxRatio = 1e4;  ///< channels with R_j / r_i >= this are counted in `overflow`, not binned
};

struct ChannelHistogram {
  double binWidth = 0.01;
  std::vector<double> density;       ///< f per bin [k w, (k + 1) w), integrates to 1
  std::vector<std::int64_t> counts;  ///< triangles per bin
  std::int64_t triangles = 0;        ///< 3-subsets examined
  std::int64_t acute = 0;            ///< passed the acute filter
  std::int64_t channels = 0;         ///< acute with a gap circle (histogrammed, plus overflow)
  std::int64_t overflow = 0;         ///< channels with R_j / r_i >= maxRatio (in mean/stddev, not in bins)
  double mean = 0.0, stddev = 0.0;   ///< of R_j / r_i over the channels
};

/// Histogram of R_j / r_i over every particle i and every acute neighbour triangle j (see top).
/// O(sum_i C(N_b(i), 3)): ~364 triangles per particle in a dense packing. Throws ConfigError for a
/// non-positive bin width, eps outside (0, 1], maxRatio <= bin width, or if `neighbours` and `spheres` disagree in
/// size.
ChannelHistogram channelSizes(const SphereView& spheres, const NeighbourList& neighbours,
                              const ChannelOptions& options = {});

}  // namespace polydem::structure
