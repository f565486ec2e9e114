// Equivalent bi- and tridisperse mixtures as Gaussian quadratures of f(a); see equivalent_mixture.hpp.
// Chebyshev algorithm: W. Gautschi, Orthogonal Polynomials: Computation and Approximation (2004), §2.1.7;
// Golub-Welsch: Math. Comp. 23, 221 (1969). Closed forms: Ogarko's thesis eqs. 3.20-3.21 (§3.1 appendix),
// 3.39-3.42 (§3.3.2).
#include "core/equivalent_mixture.hpp"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/errors.hpp"

namespace polydem {

namespace {

using Matrix3l = Eigen::Matrix<long double, 3, 3>;

double omega0(double omega) {
  if (!(omega >= 1.0) || !std::isfinite(omega)) {
    throw ConfigError(fmt::format("omega must be >= 1 and finite, got {}", omega));
  }
  return (omega - 1.0) / (omega + 1.0);
}

void requireMean(double mean) {
  if (!(mean > 0.0) || !std::isfinite(mean)) {
    throw ConfigError(fmt::format("mean radius must be > 0 and finite, got {}", mean));
  }
}

}  // namespace

std::string Mixture::describe() const {
  std::string s = fmt::format("{} species:", size());
  for (std::size_t i = 0; i < size(); ++i) {
    s += fmt::format("{} a = {:.6g} (number {:.6g}, volume {:.6g})", i ? "," : "", radius[i], numberFraction[i],
                     volumeFraction[i]);
  }
  return s;
}

Mixture makeMixture(std::vector<double> radius, std::vector<double> numberFraction) {
  if (radius.size() != numberFraction.size()) {
    throw ConfigError(fmt::format("mixture: {} radii but {} number fractions", radius.size(), numberFraction.size()));
  }
  if (radius.empty()) throw ConfigError("mixture: no species");
  double total = 0.0;
  for (std::size_t i = 0; i < radius.size(); ++i) {
    if (!(radius[i] > 0.0) || !std::isfinite(radius[i])) {
      throw ConfigError(fmt::format("mixture: radius {} must be > 0 and finite, got {}", i, radius[i]));
    }
    if (!(numberFraction[i] >= 0.0) || !std::isfinite(numberFraction[i])) {
      throw ConfigError(
          fmt::format("mixture: number fraction {} must be >= 0 and finite, got {}", i, numberFraction[i]));
    }
    total += numberFraction[i];
  }
  if (!(total > 0.0)) throw ConfigError("mixture: number fractions sum to 0");
  std::vector<std::size_t> order(radius.size());
  std::iota(order.begin(), order.end(), 0);
  // Index tie-break = the stable order (no std::stable_sort buffer; see integrators::mortonOrder).
  std::sort(order.begin(), order.end(),
            [&](std::size_t i, std::size_t j) { return radius[i] > radius[j] || (radius[i] == radius[j] && i < j); });
  Mixture m;
  double volume = 0.0;
  for (std::size_t i : order) {
    m.radius.push_back(radius[i]);
    m.numberFraction.push_back(numberFraction[i] / total);
    volume += numberFraction[i] / total * radius[i] * radius[i] * radius[i];
  }
  for (std::size_t i = 0; i < m.size(); ++i) {
    m.volumeFraction.push_back(m.numberFraction[i] * m.radius[i] * m.radius[i] * m.radius[i] / volume);
  }
  return m;
}

Mixture gaussMixture(const Moments& moments, int nodes) {
  if (nodes < 1 || nodes > 3)
    throw ConfigError(fmt::format("equivalent mixture: nodes must be 1, 2 or 3, got {}", nodes));
  if (moments.distinctRadii > 0) nodes = std::min(nodes, moments.distinctRadii);
  const double mean = moments.mean();

  // Chebyshev algorithm on the central scaled moments mu_l = M^c_l (y = a/<a> - 1), l = 0 .. 2n - 1.
  // sigma_k(l) = sum_j sigma_{k-1}(l+1) - alpha_{k-1} sigma_{k-1}(l) - beta_{k-1} sigma_{k-2}(l).
  constexpr int kMax = 3;
  long double alpha[kMax] = {}, beta[kMax] = {};
  long double prev2[2 * kMax] = {}, prev[2 * kMax] = {}, cur[2 * kMax] = {};
  for (int l = 0; l < 2 * kMax; ++l) prev[l] = moments.central[static_cast<std::size_t>(l)];
  alpha[0] = prev[1] / prev[0];
  beta[0] = prev[0];
  int n = 1;
  for (int k = 1; k < nodes; ++k) {
    for (int l = k; l <= 2 * nodes - k - 1; ++l) {
      cur[l] = prev[l + 1] - alpha[k - 1] * prev[l] - beta[k - 1] * prev2[l];
    }
    const long double b = cur[k] / prev[k - 1];
    // beta_k = ||pi_k||^2 / ||pi_{k-1}||^2 vanishes when the measure has only k support points.
    if (!(b > (k == 1 ? 1e-24L : 1e-9L * beta[1]))) break;
    beta[k] = b;
    alpha[k] = cur[k + 1] / cur[k] - prev[k] / prev[k - 1];
    ++n;
    for (int l = 0; l < 2 * kMax; ++l) {
      prev2[l] = prev[l];
      prev[l] = cur[l];
    }
  }

  // Golub-Welsch: nodes are the eigenvalues of the Jacobi matrix, weights the squared first components.
  Matrix3l jacobi = Matrix3l::Zero();
  for (int k = 0; k < n; ++k) {
    jacobi(k, k) = alpha[k];
    if (k + 1 < n) jacobi(k, k + 1) = jacobi(k + 1, k) = std::sqrt(beta[k + 1]);
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>> solver(
      jacobi.topLeftCorner(n, n));
  std::vector<double> radius, weight;
  for (int j = 0; j < n; ++j) {
    const long double x = 1.0L + solver.eigenvalues()[j];
    const long double w = solver.eigenvectors()(0, j) * solver.eigenvectors()(0, j);
    if (!(x > 0.0L) || !(w > 0.0L)) {
      throw ConfigError(fmt::format(
          "equivalent {}-component mixture: node {} has radius {}<a> and weight {}; the moments (O1 {}, O2 {}) "
          "are not those of a distribution of positive radii",
          n, j, static_cast<double>(x), static_cast<double>(w), moments.o1, moments.o2));
    }
    radius.push_back(static_cast<double>(x) * mean);
    weight.push_back(static_cast<double>(w));
  }
  return makeMixture(std::move(radius), std::move(weight));
}

std::vector<double> mixtureRadii(const Mixture& mixture, Index count) {
  if (count < 0) throw ConfigError(fmt::format("mixture sample: count must be >= 0, got {}", count));
  const std::size_t s = mixture.size();
  std::vector<Index> number(s);
  std::vector<double> remainder(s);
  Index assigned = 0;
  for (std::size_t i = 0; i < s; ++i) {
    const double exact = mixture.numberFraction[i] * static_cast<double>(count);
    number[i] = static_cast<Index>(std::floor(exact));
    remainder[i] = exact - static_cast<double>(number[i]);
    assigned += number[i];
  }
  std::vector<std::size_t> order(s);
  std::iota(order.begin(), order.end(), 0);
  // Species are sorted largest radius first, so the index tie-break (the stable order) favours larger radii.
  std::sort(order.begin(), order.end(), [&](std::size_t i, std::size_t j) {
    return remainder[i] > remainder[j] || (remainder[i] == remainder[j] && i < j);
  });
  for (std::size_t k = 0; assigned < count && s > 0; k = (k + 1) % s) {
    ++number[order[k]];
    ++assigned;
  }
  std::vector<double> radii;
  radii.reserve(static_cast<std::size_t>(count));
  for (std::size_t i = 0; i < s; ++i) radii.insert(radii.end(), static_cast<std::size_t>(number[i]), mixture.radius[i]);
  return radii;
}

BidisperseRatios bidisperseFromRatios(double o1, double o2) {
  if (!(o1 > 0.0 && o1 < 1.0 && o2 > o1 * o1 && o2 < o1)) {
    throw ConfigError(fmt::format(
        "bidisperse equivalent needs 0 < O1 < 1 and O1^2 < O2 < O1 (not monodisperse), got O1 = {}, O2 = {}", o1, o2));
  }
  // Eqs. 3.20-3.21 (Ogarko & Luding, J. Chem. Phys. 136 (2012) 124508; reconstructed from garbled print).
  const double lambda = std::sqrt(o2) * std::sqrt(4.0 * o1 * o1 * o1 + o2 - 3.0 * o1 * (2.0 + o1) * o2 + 4.0 * o2 * o2);
  BidisperseRatios r;
  r.largeNumberFraction = 0.5 + (3.0 * o1 * o2 - o2 - 2.0 * o1 * o1 * o1) / (2.0 * lambda);
  r.sizeRatio = (2.0 * o1 * o1 * o1 + 2.0 * o2 * o2 + o2 - 4.0 * o1 * o2 - o1 * o1 * o2 + (1.0 - o1) * lambda) /
                (2.0 * (o2 - o1) * (o1 * o1 - o2));
  return r;
}

Mixture uniformSizeTridisperse(double omega, double mean) {
  requireMean(mean);
  const double w0 = omega0(omega);
  if (w0 == 0.0) return makeMixture({mean}, {1.0});
  // Eqs. 3.39-3.40: n1 = 5/18, n2 = 8/18, delta1 = (5 + sqrt(15) w0)/18, delta2 = 8/18 (delta_i = n_i a_i/<a>).
  const double n1 = 5.0 / 18.0, n2 = 8.0 / 18.0;
  const double d1 = (5.0 + std::sqrt(15.0) * w0) / 18.0, d2 = 8.0 / 18.0;
  const double n3 = 1.0 - n1 - n2, d3 = 1.0 - d1 - d2;
  return makeMixture({mean * d1 / n1, mean * d2 / n2, mean * d3 / n3}, {n1, n2, n3});
}

Mixture kurtosisTridisperse(double beta2, double omega, double mean) {
  requireMean(mean);
  const double w0 = omega0(omega);
  if (!(beta2 > 1.0) || !(w0 > 0.0) || !(beta2 < 3.0 / (w0 * w0))) {
    throw ConfigError(fmt::format("kurtosis family: beta2 must lie in (1, 3/w0^2) = (1, {:.6g}) for omega {}, got {}",
                                  w0 > 0.0 ? 3.0 / (w0 * w0) : 1.0, omega, beta2));
  }
  const double n1 = 1.0 / (2.0 * beta2), n2 = (beta2 - 1.0) / beta2;
  const double spread = w0 * std::sqrt(beta2 / 3.0);  // = sqrt(3 beta2)/6 for omega = 3 (eq. 3.42)
  return makeMixture({mean * (1.0 + spread), mean, mean * (1.0 - spread)}, {n1, n2, n1});
}

}  // namespace polydem
