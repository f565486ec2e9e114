#pragma once
// Particle size distributions (number densities of radii) and their sampling.
//
// Definitions follow Ogarko's thesis ch. 2.2.4 and ch. 3:
//   mono            all radii r0
//   bi              radii r_s and r_b = omega r_s, the large species given as a volume or number fraction
//   uniform-radius  f(r) = const on [rmin, omega rmin]            (the seed's "US", alpha = 0)
//   uniform-volume  f(r) ~ r^-3 on [rmin, omega rmin]             (the seed's "UV": equal total particle
//                   volume in every radius interval, so small particles dominate by number)
//   power-law       f(r) ~ r^alpha on [rmin, omega rmin], any real alpha (alpha = -1 uses logarithms)
//   log-normal      f(r) = exp(-ln^2(r/a0) / (2 sigma^2)) / (sigma sqrt(2 pi) r), eq. 3.46 of the seed,
//                   optionally truncated to [rmin, rmax]
// All radii in metres (any consistent length unit).
#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/types.hpp"

namespace polydem {

enum class Sampling {
  Systematic,  ///< r_i = F^-1((i + u) / N), one uniform u: the rare largest sizes are always present
  Random       ///< r_i = F^-1(u_i), independent uniforms
};

enum class FractionKind { Volume, Number };

/// What a user asks for (command line, scene file); turned into a distribution by makeDistribution().
struct DistributionSpec {
  std::string kind = "mono";   ///< mono, bi, uniform-radius, uniform-volume, power-law, log-normal
  double rmin = 1.0;           ///< smallest radius (mono: the radius; log-normal: lower truncation or 0)
  double omega = 1.0;          ///< size ratio rmax / rmin (bi: r_b / r_s; log-normal: 0 = untruncated)
  double alpha = 0.0;          ///< power-law exponent
  double sigma = 0.5;          ///< log-normal width
  double median = 1.0;         ///< log-normal a0
  double largeFraction = 0.5;  ///< bi: fraction of the large species
  FractionKind fractionKind = FractionKind::Volume;
};

class SizeDistribution {
 public:
  virtual ~SizeDistribution() = default;
  /// e.g. "uniform-volume rmin=1 omega=10".
  virtual std::string describe() const = 0;
  virtual double minRadius() const = 0;
  virtual double maxRadius() const = 0;
  /// Cumulative number fraction F(r) = P(R <= r).
  virtual double cdf(double r) const = 0;
  /// Inverse CDF for q in [0, 1] (the smallest r with F(r) >= q for discrete distributions).
  virtual double quantile(double q) const = 0;
  /// Partial moment: integral of r^k f(r) dr over (a, b], analytic. partialMoment(k, 0, inf) = <r^k>.
  /// Atoms of discrete distributions count when they lie in (a, b].
  virtual double partialMoment(int k, double a, double b) const = 0;
  /// Raw moment <r^k>, analytic.
  double moment(int k) const;

  /// The smallest N whose systematic sample holds every species of a discrete distribution (bi: each
  /// species with a positive number fraction n_k gets round(N n_k) >= 1 spheres); 0 when any N works
  /// (continuous families, mono). May exceed the largest Index: then no N can represent it.
  virtual std::int64_t smallestRepresentativeCount() const { return 0; }

  /// N radii. Systematic sampling uses one uniform offset drawn from `seed`; Random uses N.
  /// Uniforms come from std::mt19937_64(seed), u = (draw >> 11) / 2^53 in [0, 1): Systematic takes the first
  /// as u and returns r_i = quantile((i + u) / N) in ascending order (bi and mono: exactly round(N n_k) of
  /// each radius); Random returns quantile(u_i) in draw order. Unbounded families still give finite radii.
  /// Throws ConfigError, naming the smallest N that works, when 0 < N < smallestRepresentativeCount()
  /// (e.g. size ratio 1000 with so few spheres that no large one is drawn), and for Random sampling when a
  /// species of positive fraction is absent from the draw.
  std::vector<double> sample(Index count, Sampling sampling, std::uint64_t seed) const;

 protected:
  /// Systematic sample r_i = quantile((i + u) / N), i = 0..N-1 (ascending). Discrete families override
  /// it so that every species gets exactly round(N n_k) particles whatever u is.
  virtual void sampleSystematic(Index count, double u, std::vector<double>& out) const;
};

/// Build a distribution; throws ConfigError naming the bad field (rmin <= 0, omega < 1, sigma <= 0,
/// fraction outside [0, 1], unknown kind listing the valid ones).
std::unique_ptr<SizeDistribution> makeDistribution(const DistributionSpec& spec);

/// Inverse of the standard normal CDF, Phi^-1(p) for p in (0, 1); -inf at 0, +inf at 1. Accurate to a
/// few ulp, also deep in the lower tail (pass the smaller of p and 1 - p when it matters).
double standardNormalQuantile(double p);

/// Raw moments <r^k>, k = 0..5, of a sample.
std::array<double, 6> sampleMoments(std::span<const double> radii);

}  // namespace polydem
