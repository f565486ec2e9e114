#pragma once
// The particle-size information the HGrid cost model needs (hgrid_cost_model.hpp): the number density and
// the partial moments int r^k f(r) dr, k = 0..3, over bands of interaction diameter 2 r + skin, from an
// analytic SizeDistribution (exact) or a sample of radii (O(log N) prefix sums over the sorted radii).
// Every per-level quantity of the model is a linear combination of these four moments (thesis §2.2.3).
//
// Skin: bands are bands of the interaction diameter 2 r + skin (the HGrid's insertion rule); number
// densities come from the true radii: for an analytic PSD n = nu / V_p with V_p = (4 pi / 3) <r^3>
// (thesis eq. 2.14, d = 3).
//
// References (thesis numbering): V. Ogarko, PhD thesis on polydisperse smooth hard spheres (University of
// Twente), ch. 2; its ch. 2.1 is Ogarko & Luding, Comput. Phys. Commun. 183 (2012) 931 and its ch. 2.2 is
// Krijgsman, Ogarko & Luding, Comp. Part. Mech. 1 (2014) 357.
#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/size_distribution.hpp"
#include "core/types.hpp"

namespace polydem::broadphase {

/// The particle-size information the cost model needs, from an analytic distribution or a sample.
/// Cheap to copy (a sample's sorted radii and prefix sums are shared).
class CostModelPsd {
 public:
  /// Analytic f(r) at packing fraction nu (of the true radii). `distribution` must outlive this object.
  /// Throws ConfigError for nu <= 0, skin < 0, non-finite values, or an unbounded distribution (r_max =
  /// inf or r_min = 0: truncate a log-normal first). nu may exceed 1: centres are allowed to overlap.
  static CostModelPsd analytic(const SizeDistribution& distribution, double packingFraction, double skin = 0.0);
  /// A sample of radii (m, any order) in a box of volume `boxVolume` (m^3). O(N log N): sorts a copy and
  /// builds prefix sums of r^k. Throws ConfigError for an empty sample, a non-positive or non-finite
  /// radius, boxVolume <= 0 or skin < 0.
  static CostModelPsd sample(std::span<const double> radii, double boxVolume, double skin = 0.0);

  bool isSample() const { return sample_ != nullptr; }
  /// Sample size N (0 for an analytic PSD).
  Index sampleSize() const;
  double skin() const { return skin_; }
  /// Smallest interaction diameter 2 r_min + skin (m); the thesis's s_0.
  double minDiameter() const { return minDiameter_; }
  /// Largest interaction diameter 2 r_max + skin (m); the top cell size s_L.
  double maxDiameter() const { return maxDiameter_; }
  /// Particles per unit volume (1/m^3): N / V_box, or nu / V_p.
  double numberDensity() const { return numberDensity_; }
  /// {P, <r; band>, <r^2; band>, <r^3; band>}: number fraction and partial moments sum r^k / N (or
  /// int r^k f dr) of the particles with interaction diameter 2 r + skin in (lo, hi] (m). Analytic: four
  /// partialMoment calls; sample: two binary searches.
  std::array<double, 4> band(double lo, double hi) const;
  /// Number fraction with interaction diameter in (lo, hi]: band(lo, hi)[0] at a quarter of the cost.
  double fraction(double lo, double hi) const;
  /// band() of the consecutive levels (0, s_1], (s_1, s_2], ..., (s_{L-1}, s_L] into `out` (resized to L).
  /// A sample needs one binary search per size; an analytic PSD differences cumulative moments, which a
  /// small per-thread cache keeps across calls (an optimiser moves one size at a time).
  void levelBands(std::span<const double> cellSizes, std::vector<std::array<double, 4>>& out) const;
  /// Number of sample particles with 2 r + skin <= diameter (O(log N)); samples only.
  Index countAtMost(double diameter) const;
  /// Ascending radii of a sample (empty for an analytic PSD).
  std::span<const double> sortedRadii() const;
  /// e.g. "sample N=125001 V=... skin=0" or "uniform-volume rmin=1 omega=100, nu=0.7, skin=0".
  std::string describe() const;

 private:
  struct Sample;
  CostModelPsd() = default;
  const SizeDistribution* distribution_ = nullptr;
  std::shared_ptr<const Sample> sample_;
  double skin_ = 0.0;
  double minDiameter_ = 0.0;
  double maxDiameter_ = 0.0;
  double numberDensity_ = 0.0;
  double packingFraction_ = 0.0;
  std::array<double, 4> totalMoments_{};  // <r^k>, analytic
  std::uint64_t id_ = 0;                  // cache key of the analytic cumulative moments
};

}  // namespace polydem::broadphase
