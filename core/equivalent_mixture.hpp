#pragma once
// Equivalent discrete mixtures of a polydisperse radius distribution (Ogarko's thesis ch. 3):
//   equivalent bidisperse mixture: two radii matching <a>, <a^2>, <a^3> (hence O1, O2, the fluid EOS and,
//     at equal N and V, the packing fraction)                             (eqs. 3.20-3.21, §3.1 appendix)
//   maximally equivalent tridisperse mixture: three radii matching <a> .. <a^5>  (§3.2, §3.3.2)
// Both are the 2- resp. 3-node Gaussian quadrature of f(a) (Ogarko & Luding, J. Chem. Phys. 136 (2012)
// 124508; Soft Matter 9 (2013) 9530): nodes = radii, weights = number fractions; Tables 3.1, 3.3, 3.4 of the seed are
// reproduced by it (tests/core/equivalent_mixture_test.cpp).
//
// Design: the rule is built in the centred scaled variable y = a/<a> - 1 from the central moments M^c_k
// (k = 0..5) with the modified-free Chebyshev algorithm (recurrence coefficients alpha_k, beta_k from
// moments, in long double), then Golub-Welsch (eigen-decomposition of the Jacobi matrix). Centring keeps
// the moment (Hankel) matrix far better conditioned than raw a^k; for n <= 3 nodes long double leaves
// >= 10 correct digits even for UV omega = 100 (M_5 ~ 2e4) and log-normal sigma = 1 (smallest weight ~1e-5),
// which the tests check against the closed forms. A distribution with fewer support points than nodes
// (monodisperse; a bidisperse sample asked for three nodes) gives fewer components: a recurrence
// coefficient beta_k <= 1e-9 beta_1 ends the rule, and for samples the exact count of distinct radii caps it.
#include <string>
#include <vector>

#include "core/moments.hpp"
#include "core/types.hpp"

namespace polydem {

/// A discrete mixture: species sorted by radius, largest first.
struct Mixture {
  std::vector<double> radius;          ///< m (same unit as the distribution)
  std::vector<double> numberFraction;  ///< sums to 1
  std::vector<double> volumeFraction;  ///< share of the particle volume, n_i a_i^3 / <a^3>; sums to 1

  std::size_t size() const { return radius.size(); }
  /// "3 species: a = ... (n = ..., volume ...), ...".
  std::string describe() const;
};

/// Build a mixture from radii and number fractions (any order; sorted descending, fractions normalised).
/// Throws ConfigError for sizes that differ, no species, a radius <= 0 or a fraction < 0 / not finite.
Mixture makeMixture(std::vector<double> radius, std::vector<double> numberFraction);

/// The `nodes`-point Gaussian quadrature of the distribution with these moments (nodes = 1, 2 or 3):
/// matches <a^k> for k = 0 .. 2 nodes - 1. Fewer species when the distribution has fewer support points.
/// Throws ConfigError for nodes outside 1..3, and if the moments are not those of a distribution of
/// positive radii (a non-positive node or weight).
Mixture gaussMixture(const Moments& moments, int nodes);
/// Equivalent bidisperse mixture (matches <a>, <a^2>, <a^3>).
inline Mixture equivalentBidisperse(const Moments& moments) { return gaussMixture(moments, 2); }
/// Maximally equivalent tridisperse mixture (matches <a> .. <a^5>).
inline Mixture equivalentTridisperse(const Moments& moments) { return gaussMixture(moments, 3); }

/// `count` radii realising the mixture with integer numbers of particles. Rounding rule (largest
/// remainders): species i first gets floor(n_i N); the particles still missing go, one each, to the
/// species with the largest remainders n_i N - floor(n_i N) (ties: the larger radius). Radii returned
/// grouped by species, largest first. Throws ConfigError for count < 0.
std::vector<double> mixtureRadii(const Mixture& mixture, Index count);

// --- Closed forms of the seed, for tests and cross-checks -------------------------------------------

/// Equivalent bidisperse mixture from O1, O2 (eqs. 3.20-3.21, reconstructed from garbled print):
/// size ratio R_bi = a_large/a_small >= 1 and number fraction of the large species.
/// Throws ConfigError unless 0 < O1 < 1 and O1^2 < O2 < O1 (not monodisperse).
struct BidisperseRatios {
  double sizeRatio = 1.0;
  double largeNumberFraction = 0.5;
};
BidisperseRatios bidisperseFromRatios(double o1, double o2);

/// The maximally equivalent tridisperse mixture of the uniform-size (US) distribution with size ratio
/// omega and mean radius `mean`: fractions 5:8:5, radii <a>(1 + sqrt(3/5) w0), <a>, <a>(1 - sqrt(3/5) w0),
/// w0 = (omega - 1)/(omega + 1) (eqs. 3.39-3.40, §3.3.2).
Mixture uniformSizeTridisperse(double omega, double mean);

/// Tridisperse mixtures matching <a> and the central moments M^c_2, M^c_3, M^c_5 of US(omega) (the seed's
/// "scaled moments k = 2, 3, 5", §3.2) with the kurtosis beta2 = M^c_4/(M^c_2)^2 free
/// (eqs. 3.41-3.42, printed for omega = 3, §3.3.2): n1 = n3 = 1/(2 beta2), n2 = (beta2 - 1)/beta2,
/// radii <a>(1 +- w0 sqrt(beta2/3)), <a>. For omega = 3 (w0 = 1/2) this is the seed's
/// delta1 = (6 + sqrt(3 beta2))/(12 beta2); other omega are our generalisation. beta2 = 1.8 is the
/// 5:8:5 rule. Throws ConfigError unless 1 < beta2 < 3/w0^2 (all radii positive, middle species present).
Mixture kurtosisTridisperse(double beta2, double omega, double mean);

}  // namespace polydem
