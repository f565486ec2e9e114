#pragma once
// Moments and moment-based descriptors of a radius distribution (number-weighted):
//   raw <a^k> (k = 0..5), mean diameters D_pq = 2 (<a^p>/<a^q>)^(1/(p-q)),
//   O1 = <a><a^2>/<a^3> = D10/D32, O2 = <a^2>^3/<a^3>^2 = (D20/D32)^2       (Ogarko's thesis eq. 3.6, §3.1.2)
//   delta = std/mean = sqrt(O2/O1^2 - 1), A = 1/(delta^2 + 1) = O1^2/O2     (§3.1 appendix)
//   scaled M_k = <a^k>/<a>^k, central M^c_k = <(a - <a>)^k>/<a>^k,
//   kurtosis beta2 = M^c_4/(M^c_2)^2                                          (§3.2, §3.3.2)
// Bounds: 0 < O1 <= 1 and O1^2 <= O2 <= O1, equalities only for a monodisperse distribution
// (thesis §3.1.2, reconstructed: the printed text of the bounds is garbled).
//
// Sources: analytic, from SizeDistribution::moment(k); or a sample of radii (a particle file's radii).
// For a sample the central moments are summed directly around the sample mean (two passes), which
// keeps their relative accuracy for narrow distributions where M^c_2 = M_2 - 1 would cancel.
#include <array>
#include <span>
#include <string>

#include "core/size_distribution.hpp"

namespace polydem {

struct Moments {
  std::array<double, 6> raw{};      ///< <a^k>, k = 0..5, normalised: raw[0] = 1 (units m^k)
  std::array<double, 6> scaled{};   ///< M_k = <a^k>/<a>^k (dimensionless, M_0 = M_1 = 1)
  std::array<double, 6> central{};  ///< M^c_k = <(a - <a>)^k>/<a>^k (M^c_0 = 1, M^c_1 = 0)
  double o1 = 1.0;                  ///< <a><a^2>/<a^3>
  double o2 = 1.0;                  ///< <a^2>^3/<a^3>^2
  double delta = 0.0;               ///< polydispersity std/mean of the radii
  double a = 1.0;                   ///< A = <a>^2/<a^2> = 1/(delta^2 + 1)
  double kurtosis = 0.0;            ///< beta2 = M^c_4/(M^c_2)^2; NaN when monodisperse()
  /// Samples: number of distinct radii, counted up to kMaxDistinct (= "more"); 0 = not known (analytic).
  int distinctRadii = 0;
  static constexpr int kMaxDistinct = 4;

  double mean() const { return raw[1]; }
  /// Mean diameter D_pq = 2 (<a^p>/<a^q>)^(1/(p-q)) for p != q in 0..5. Throws ConfigError otherwise.
  double diameter(int p, int q) const;
  /// True when the distribution has a single radius (delta below 1e-12).
  bool monodisperse() const { return !(delta > 1e-12); }
  /// Multi-line human-readable summary.
  std::string describe() const;
};

/// Moments from raw moments <a^k>, k = 0..5 (any positive normalisation raw[0]; divided out).
/// `central`, if given, are the scaled central moments (otherwise computed from the raw ones).
/// Throws ConfigError if raw[0] or raw[1] is not positive and finite or a moment is not finite.
Moments momentsFromRaw(const std::array<double, 6>& raw, const std::array<double, 6>* central = nullptr);

/// Analytic moments of a distribution (SizeDistribution::moment).
Moments momentsOf(const SizeDistribution& distribution);

/// Moments of a sample of radii, O(N), compensated sums. Throws ConfigError for an empty sample and for
/// a radius that is not positive and finite (naming its index and value).
Moments momentsOfSample(std::span<const double> radii);

}  // namespace polydem
