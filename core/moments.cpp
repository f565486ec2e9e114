// Moments and descriptors of a radius distribution; definitions in moments.hpp (Ogarko's thesis §3.1-3.3).
#include "core/moments.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/errors.hpp"

namespace polydem {

namespace {

/// Neumaier-compensated running sum.
struct CompensatedSum {
  double sum = 0.0, compensation = 0.0;
  void add(double term) {
    const double t = sum + term;
    compensation += std::abs(sum) >= std::abs(term) ? (sum - t) + term : (term - t) + sum;
    sum = t;
  }
  double value() const { return sum + compensation; }
};

double binomial(int n, int k) {
  double c = 1.0;
  for (int i = 1; i <= k; ++i) c = c * (n - k + i) / i;
  return c;
}

}  // namespace

double Moments::diameter(int p, int q) const {
  if (p < 0 || p > 5 || q < 0 || q > 5 || p == q) {
    throw ConfigError(fmt::format("mean diameter D_{}{} needs p != q, both in 0..5", p, q));
  }
  return 2.0 * std::pow(raw[static_cast<std::size_t>(p)] / raw[static_cast<std::size_t>(q)], 1.0 / (p - q));
}

std::string Moments::describe() const {
  std::string s = fmt::format("<a> {:.6g}  <a^2> {:.6g}  <a^3> {:.6g}  <a^4> {:.6g}  <a^5> {:.6g}\n", raw[1], raw[2],
                              raw[3], raw[4], raw[5]);
  s += fmt::format("M_k (k = 2..5) {:.6g} {:.6g} {:.6g} {:.6g}\n", scaled[2], scaled[3], scaled[4], scaled[5]);
  // Issue 15: no nan in a report; the kurtosis of a monodisperse sample is 0/0.
  const std::string beta2 =
      std::isnan(kurtosis) ? std::string("undefined (monodisperse: zero variance)") : fmt::format("{:.6g}", kurtosis);
  s += fmt::format("M^c_k (k = 2..5) {:.6g} {:.6g} {:.6g} {:.6g}  kurtosis beta2 {}\n", central[2], central[3],
                   central[4], central[5], beta2);
  s += fmt::format("D10 {:.6g}  D20 {:.6g}  D32 {:.6g}  D43 {:.6g}\n", diameter(1, 0), diameter(2, 0), diameter(3, 2),
                   diameter(4, 3));
  s += fmt::format("O1 {:.6g}  O2 {:.6g}  delta {:.6g}  A {:.6g}", o1, o2, delta, a);
  return s;
}

Moments momentsFromRaw(const std::array<double, 6>& raw, const std::array<double, 6>* central) {
  for (std::size_t k = 0; k < 6; ++k) {
    if (!std::isfinite(raw[k])) throw ConfigError(fmt::format("moment <a^{}> must be finite, got {}", k, raw[k]));
  }
  if (!(raw[0] > 0.0)) throw ConfigError(fmt::format("moment <a^0> (normalisation) must be > 0, got {}", raw[0]));
  if (!(raw[1] > 0.0)) throw ConfigError(fmt::format("mean radius <a> must be > 0, got {}", raw[1] / raw[0]));
  Moments m;
  for (std::size_t k = 0; k < 6; ++k) m.raw[k] = raw[k] / raw[0];
  const double mean = m.raw[1];
  for (std::size_t k = 0; k < 6; ++k) m.scaled[k] = m.raw[k] / std::pow(mean, static_cast<double>(k));
  m.scaled[0] = 1.0;
  m.scaled[1] = 1.0;
  if (central != nullptr) {
    m.central = *central;
  } else {
    // M^c_k = sum_j C(k, j) M_j (-1)^(k-j), in the scaled variable x = a/<a> (so the mean is 1).
    for (int k = 0; k < 6; ++k) {
      long double sum = 0.0L;
      for (int j = 0; j <= k; ++j) {
        sum += ((k - j) % 2 ? -1.0L : 1.0L) * binomial(k, j) *
               static_cast<long double>(m.scaled[static_cast<std::size_t>(j)]);
      }
      m.central[static_cast<std::size_t>(k)] = static_cast<double>(sum);
    }
    m.central[2] = std::max(m.central[2], 0.0);  // round-off of a monodisperse input
    m.central[4] = std::max(m.central[4], 0.0);
  }
  m.central[0] = 1.0;
  m.central[1] = 0.0;
  m.o1 = m.raw[1] * m.raw[2] / m.raw[3];
  m.o2 = m.raw[2] * m.raw[2] * m.raw[2] / (m.raw[3] * m.raw[3]);
  m.delta = std::sqrt(m.central[2]);
  m.a = 1.0 / (m.central[2] + 1.0);
  // Monodisperse (delta below round-off): the kurtosis 0/0 is undefined.
  m.kurtosis =
      m.monodisperse() ? std::numeric_limits<double>::quiet_NaN() : m.central[4] / (m.central[2] * m.central[2]);
  return m;
}

Moments momentsOf(const SizeDistribution& distribution) {
  std::array<double, 6> raw{};
  for (int k = 0; k < 6; ++k) raw[static_cast<std::size_t>(k)] = distribution.moment(k);
  return momentsFromRaw(raw);
}

Moments momentsOfSample(std::span<const double> radii) {
  if (radii.empty()) throw ConfigError("moments of an empty sample of radii: give at least one radius");
  std::array<CompensatedSum, 6> sums;
  std::array<double, Moments::kMaxDistinct> distinct{};
  int distinctCount = 0;
  for (std::size_t i = 0; i < radii.size(); ++i) {
    const double r = radii[i];
    if (!(r > 0.0) || !std::isfinite(r)) {
      throw ConfigError(fmt::format("radius {} of the sample must be positive and finite, got {}", i, r));
    }
    if (distinctCount < Moments::kMaxDistinct &&
        std::find(distinct.begin(), distinct.begin() + distinctCount, r) == distinct.begin() + distinctCount) {
      distinct[static_cast<std::size_t>(distinctCount++)] = r;
    }
    double term = 1.0;
    for (auto& s : sums) {
      s.add(term);
      term *= r;
    }
  }
  std::array<double, 6> raw{};
  for (std::size_t k = 0; k < 6; ++k) raw[k] = sums[k].value();
  // Second pass: central moments around the sample mean, in units of the mean.
  const double mean = raw[1] / raw[0];
  std::array<CompensatedSum, 6> centralSums;
  for (double r : radii) {
    const double y = r / mean - 1.0;
    double term = 1.0;
    for (auto& s : centralSums) {
      s.add(term);
      term *= y;
    }
  }
  std::array<double, 6> central{};
  for (std::size_t k = 0; k < 6; ++k) central[k] = centralSums[k].value() / raw[0];
  Moments m = momentsFromRaw(raw, &central);
  m.distinctRadii = distinctCount;
  return m;
}

}  // namespace polydem
