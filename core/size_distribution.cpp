// Particle size distributions: analytic CDF, quantile and partial moments, and systematic sampling.
//
// Families and their moments follow V. Ogarko's dissertation (University of Twente; "Ogarko's thesis"):
//   truncated power law f(r) = C r^alpha on [rmin, rmax], 1/C = int r^alpha dr   (Ogarko's thesis §2.2.4,
//     eqs. 2.37-2.38; Krijgsman, Ogarko & Luding, Comp. Part. Mech. 1 (2014) 357)
//     alpha = 0 is "uniform size" (US), alpha = -3 "uniform volume" (UV) (Ogarko's thesis §2.2.4 and Fig. 2.8;
//     §3.3.2, eq. 3.43)
//   log-normal f(a) = exp(-ln^2(a/a0) / (2 sigma^2)) / (sigma sqrt(2 pi) a)      (Ogarko's thesis §3.3.2, eq. 3.46)
//     <a^k> = a0^k exp(k^2 sigma^2 / 2)                                           (Ogarko's thesis §3.3.2, eq. 3.51)
//   (§3.3 is the supplementary material of Ogarko & Luding, Soft Matter 9 (2013) 9530)
//   systematic sampling guarantees the rare largest sizes are present  (Ogarko's thesis §2.1.3 and Fig. 2.3;
//     §3.1.3; Ogarko & Luding, Comput. Phys. Commun. 183 (2012) 931; J. Chem. Phys. 136 (2012) 124508)
// The seed does not print the systematic-sampling formula; we use the standard one (one offset u for all
// strata): r_i = F^-1((i + u) / N).
//
// Numerics: power-law CDFs, quantiles and moments are written with expm1/log1p in the variable
// x = ln(r / rmin), so alpha + k + 1 = 0 (logarithmic case) and values close to it need no special care
// beyond one exact-zero branch, and nothing overflows for steep exponents. Log-normal tails use erfc on
// whichever side is small, so truncation far out in a tail keeps its relative accuracy.
#include "core/size_distribution.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "core/errors.hpp"

namespace polydem {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kSqrt2 = 1.41421356237309504880;
constexpr double kSqrt2Pi = 2.50662827463100050242;

/// Phi(z), the standard normal CDF; accurate relative to its value in the lower tail.
double normalCdf(double z) { return 0.5 * std::erfc(-z / kSqrt2); }
/// 1 - Phi(z), accurate relative to its value in the upper tail.
double normalUpper(double z) { return 0.5 * std::erfc(z / kSqrt2); }

/// Phi(z2) - Phi(z1) for z1 <= z2, computed on the side where both terms are small.
double normalMass(double z1, double z2) {
  if (z1 >= 0.0) return normalUpper(z1) - normalUpper(z2);
  return normalCdf(z2) - normalCdf(z1);
}

/// Uniform double in [0, 1) from the top 53 bits of one mt19937_64 draw (portable, unlike
/// std::uniform_real_distribution whose algorithm is implementation-defined).
double uniform01(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

/// log of int_{exp(xa)}^{exp(xb)} t^(e - 1) dt for xa < xb, without overflow; e == 0 is the logarithmic case.
double logPowerIntegral(double e, double xa, double xb) {
  const double span = xb - xa;
  if (e == 0.0) return std::log(span);
  if (e > 0.0) return e * xb + std::log(-std::expm1(-e * span)) - std::log(e);
  return e * xa + std::log(-std::expm1(e * span)) - std::log(-e);
}

void requirePositive(const char* key, double value) {
  if (!(value > 0.0)) throw ConfigError(fmt::format("{} must be > 0, got {}", key, value));  // also NaN
  if (!std::isfinite(value)) throw ConfigError(fmt::format("{} must be finite, got {}", key, value));
}

void requireOmega(double omega) {
  if (!(omega >= 1.0)) throw ConfigError(fmt::format("omega must be >= 1, got {} (size ratio rmax / rmin)", omega));
  if (!std::isfinite(omega)) throw ConfigError(fmt::format("omega must be finite, got {}", omega));
}

// ---------------------------------------------------------------------------------------------------------

class Mono final : public SizeDistribution {
 public:
  explicit Mono(double radius) : r0_(radius) {}
  std::string describe() const override { return fmt::format("mono r={:g}", r0_); }
  double minRadius() const override { return r0_; }
  double maxRadius() const override { return r0_; }
  double cdf(double r) const override { return r >= r0_ ? 1.0 : 0.0; }
  double quantile(double) const override { return r0_; }
  double partialMoment(int k, double a, double b) const override {
    return (a < r0_ && r0_ <= b) ? std::pow(r0_, k) : 0.0;
  }

 protected:
  void sampleSystematic(Index count, double, std::vector<double>& out) const override {
    out.assign(static_cast<std::size_t>(count), r0_);
  }

 private:
  double r0_;
};

// Two radii r_s and r_b = omega r_s; nLarge_ is the number fraction of r_b.
class Bi final : public SizeDistribution {
 public:
  Bi(double rs, double omega, double largeFraction, FractionKind kind)
      : rs_(rs), rb_(omega * rs), omega_(omega), largeFraction_(largeFraction), kind_(kind) {
    if (kind == FractionKind::Number) {
      nLarge_ = largeFraction;
    } else {
      // Volume fraction phi_L of the large species: n_L = (phi_L / omega^3) / (phi_L / omega^3 + 1 - phi_L).
      const double large = largeFraction / (omega * omega * omega);
      nLarge_ = large / (large + (1.0 - largeFraction));
    }
  }
  std::string describe() const override {
    return fmt::format("bi rmin={:g} omega={:g} large {} fraction={:g} (number fraction {:.6g})", rs_, omega_,
                       kind_ == FractionKind::Volume ? "volume" : "number", largeFraction_, nLarge_);
  }
  double minRadius() const override { return nLarge_ < 1.0 ? rs_ : rb_; }
  double maxRadius() const override { return nLarge_ > 0.0 ? rb_ : rs_; }
  double cdf(double r) const override {
    if (r >= rb_) return 1.0;
    if (r >= rs_) return 1.0 - nLarge_;
    return 0.0;
  }
  double quantile(double q) const override { return q <= 1.0 - nLarge_ ? rs_ : rb_; }
  std::int64_t smallestRepresentativeCount() const override {
    // sampleSystematic gives llround(N n_L) spheres to the large species and the rest to the small one:
    // each species of positive fraction needs at least one. Start from the estimate N n >= 1/2 and step
    // to the exact boundary of the rounding (a few steps at most).
    const auto represents = [this](double n) {
      const double large = std::round(n * nLarge_);
      return (nLarge_ == 0.0 || large >= 1.0) && (nLarge_ == 1.0 || n - large >= 1.0);
    };
    const double rare = std::min(nLarge_ > 0.0 ? nLarge_ : 1.0, nLarge_ < 1.0 ? 1.0 - nLarge_ : 1.0);
    double n = std::max(1.0, std::ceil(0.5 / rare));
    if (n > 9.0e18) return std::numeric_limits<std::int64_t>::max();
    while (n > 1.0 && represents(n - 1.0)) n -= 1.0;
    while (!represents(n)) n += 1.0;
    return static_cast<std::int64_t>(n);
  }
  double partialMoment(int k, double a, double b) const override {
    double sum = 0.0;
    if (a < rs_ && rs_ <= b) sum += (1.0 - nLarge_) * std::pow(rs_, k);
    if (a < rb_ && rb_ <= b) sum += nLarge_ * std::pow(rb_, k);
    return sum;
  }

 protected:
  // Exactly round(N n_L) large particles (the quantile rule would give floor or ceil depending on u).
  void sampleSystematic(Index count, double, std::vector<double>& out) const override {
    const auto n = static_cast<std::size_t>(count);
    const auto large = std::min(n, static_cast<std::size_t>(std::llround(static_cast<double>(count) * nLarge_)));
    out.assign(n - large, rs_);
    out.insert(out.end(), large, rb_);
  }

 private:
  double rs_, rb_, omega_, largeFraction_;
  FractionKind kind_;
  double nLarge_ = 0.0;
};

// f(r) = C r^alpha on [rmin, omega rmin]; uniform-radius (alpha = 0) and uniform-volume (alpha = -3) too.
class PowerLaw final : public SizeDistribution {
 public:
  PowerLaw(std::string name, double rmin, double omega, double alpha)
      : name_(std::move(name)),
        rmin_(rmin),
        omega_(omega),
        alpha_(alpha),
        e_(alpha + 1.0),
        logOmega_(std::log(omega)) {}

  std::string describe() const override {
    if (name_ == "power-law") return fmt::format("power-law rmin={:g} omega={:g} alpha={:g}", rmin_, omega_, alpha_);
    return fmt::format("{} rmin={:g} omega={:g}", name_, rmin_, omega_);
  }
  double minRadius() const override { return rmin_; }
  double maxRadius() const override { return rmin_ * omega_; }

  double cdf(double r) const override {
    if (degenerate()) return r >= rmin_ ? 1.0 : 0.0;
    if (!(r > rmin_)) return 0.0;
    if (r >= maxRadius()) return 1.0;
    const double x = std::log(r / rmin_);
    double f;
    if (e_ == 0.0) {
      f = x / logOmega_;
    } else if (e_ > 0.0) {
      f = std::exp(e_ * (x - logOmega_)) * std::expm1(-e_ * x) / std::expm1(-e_ * logOmega_);
    } else {
      f = std::expm1(e_ * x) / std::expm1(e_ * logOmega_);
    }
    return std::clamp(f, 0.0, 1.0);
  }

  double quantile(double q) const override {
    if (degenerate() || !(q > 0.0)) return rmin_;
    if (q >= 1.0) return maxRadius();
    double x;
    if (e_ == 0.0) {
      x = q * logOmega_;
    } else if (e_ > 0.0) {
      x = logOmega_ + std::log1p(std::expm1(-e_ * logOmega_) * (1.0 - q)) / e_;
    } else {
      x = std::log1p(q * std::expm1(e_ * logOmega_)) / e_;
    }
    return std::clamp(rmin_ * std::exp(x), rmin_, maxRadius());
  }

  double partialMoment(int k, double a, double b) const override {
    if (degenerate()) return (a < rmin_ && rmin_ <= b) ? std::pow(rmin_, k) : 0.0;
    const double lo = std::max(a, rmin_);
    const double hi = std::min(b, maxRadius());
    if (!(lo < hi)) return 0.0;
    // In units of rmin: C int t^(alpha + k) dt over [lo, hi] / rmin, times rmin^k.
    const double xa = lo == rmin_ ? 0.0 : std::log(lo / rmin_);
    const double xb = hi == maxRadius() ? logOmega_ : std::log(hi / rmin_);
    const double logRatio = logPowerIntegral(e_ + k, xa, xb) - logPowerIntegral(e_, 0.0, logOmega_);
    return std::pow(rmin_, k) * std::exp(logRatio);
  }

 private:
  bool degenerate() const { return omega_ == 1.0; }

  std::string name_;
  double rmin_, omega_, alpha_;
  double e_;         // alpha + 1
  double logOmega_;  // ln(omega)
};

// Log-normal in ln r with median a0 and width sigma, optionally truncated to [rmin, rmax].
class LogNormal final : public SizeDistribution {
 public:
  LogNormal(double median, double sigma, double rmin, double rmax)
      : median_(median),
        mu_(std::log(median)),
        sigma_(sigma),
        rmin_(rmin),
        rmax_(rmax),
        truncated_(rmax < kInf),
        zmin_(z(rmin)),
        zmax_(z(rmax)),
        mass_(normalMass(zmin_, zmax_)),
        lowerTail_(normalCdf(zmin_)),
        upperTail_(normalUpper(zmax_)) {
    if (!(mass_ > 0.0)) {
      throw ConfigError(
          fmt::format("log-normal truncation [rmin, rmax] = [{}, {}] holds no probability for median {} "
                      "and sigma {}: move rmin/omega towards the median",
                      rmin, rmax, median, sigma));
    }
  }

  std::string describe() const override {
    if (!truncated_) return fmt::format("log-normal median={:g} sigma={:g}", median_, sigma_);
    return fmt::format("log-normal median={:g} sigma={:g} truncated to [{:g}, {:g}]", median_, sigma_, rmin_, rmax_);
  }
  double minRadius() const override { return rmin_; }
  double maxRadius() const override { return rmax_; }

  double cdf(double r) const override {
    if (!(r > rmin_)) return 0.0;
    if (r >= rmax_) return 1.0;
    return std::clamp(normalMass(zmin_, z(r)) / mass_, 0.0, 1.0);
  }

  double quantile(double q) const override {
    if (!(q > 0.0)) return rmin_;
    if (q >= 1.0) return rmax_;
    // Phi(z) = Phi(zmin) + q mass, or equivalently 1 - Phi(z) = (1 - Phi(zmax)) + (1 - q) mass: invert
    // whichever is smaller so the tails keep their relative accuracy.
    const double lower = lowerTail_ + q * mass_;
    const double upper = upperTail_ + (1.0 - q) * mass_;
    const double zq = lower <= upper ? standardNormalQuantile(lower) : -standardNormalQuantile(upper);
    return std::clamp(std::exp(mu_ + sigma_ * zq), rmin_, rmax_);
  }

  double partialMoment(int k, double a, double b) const override {
    const double lo = std::max(a, rmin_);
    const double hi = std::min(b, rmax_);
    if (!(lo < hi)) return 0.0;
    // r^k f(r) is a0^k exp(k^2 sigma^2 / 2) times the log-normal density shifted by k sigma in z.
    const double shift = k * sigma_;
    const double scale = std::exp(k * mu_ + 0.5 * shift * shift);
    return scale * normalMass(z(lo) - shift, z(hi) - shift) / mass_;
  }

 private:
  double z(double r) const { return r > 0.0 ? (std::log(r) - mu_) / sigma_ : -kInf; }

  double median_, mu_, sigma_, rmin_, rmax_;
  bool truncated_;
  double zmin_, zmax_, mass_;
  double lowerTail_, upperTail_;  // Phi(zmin), 1 - Phi(zmax)
};

}  // namespace

// ---------------------------------------------------------------------------------------------------------

double standardNormalQuantile(double p) {
  if (!(p > 0.0)) return p == 0.0 ? -kInf : std::numeric_limits<double>::quiet_NaN();
  if (!(p < 1.0)) return p == 1.0 ? kInf : std::numeric_limits<double>::quiet_NaN();
  // P. J. Acklam's rational approximation (relative error < 1.15e-9), then one Halley step on
  // Phi(x) - p. Working with the smaller tail keeps the residual relative to a small number.
  static constexpr double a[] = {-3.969683028665376e+01, 2.209460984245205e+02,  -2.759285104469687e+02,
                                 1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
  static constexpr double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                                 6.680131188771972e+01, -1.328068155288572e+01};
  static constexpr double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                                 -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
  static constexpr double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                                 3.754408661907416e+00};
  constexpr double pLow = 0.02425;
  const bool upper = p > 0.5;
  const double tail = upper ? 1.0 - p : p;  // exact for p > 0.5 (Sterbenz)
  double x;
  if (tail < pLow) {
    const double q = std::sqrt(-2.0 * std::log(tail));
    x = (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
        ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0);
  } else {
    const double q = tail - 0.5;
    const double r = q * q;
    x = (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
        (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0);
  }
  // Here x <= 0 solves Phi(x) = tail. Halley: e = Phi(x) - tail, u = e / phi(x).
  if (0.5 * x * x < 708.0) {  // exp(x^2 / 2) stays finite: every normal p >= DBL_MIN is refined
    const double e = normalCdf(x) - tail;
    const double u = e * kSqrt2Pi * std::exp(0.5 * x * x);
    x -= u / (1.0 + 0.5 * x * u);
  }
  return upper ? -x : x;
}

double SizeDistribution::moment(int k) const { return partialMoment(k, 0.0, kInf); }

void SizeDistribution::sampleSystematic(Index count, double u, std::vector<double>& out) const {
  out.resize(static_cast<std::size_t>(count));
  const double n = static_cast<double>(count);
  // Keep q inside (0, 1) so unbounded distributions (log-normal) give finite positive radii.
  constexpr double kLowest = std::numeric_limits<double>::denorm_min();
  constexpr double kHighest = 1.0 - 0x1.0p-53;
  for (Index i = 0; i < count; ++i) {
    const double q = std::clamp((static_cast<double>(i) + u) / n, kLowest, kHighest);
    out[static_cast<std::size_t>(i)] = quantile(q);
  }
}

std::vector<double> SizeDistribution::sample(Index count, Sampling sampling, std::uint64_t seed) const {
  if (count < 0) throw ConfigError(fmt::format("sample count must be >= 0, got {}", count));
  const std::int64_t smallest = smallestRepresentativeCount();
  if (count > 0 && count < smallest) {
    if (smallest > std::numeric_limits<Index>::max()) {
      throw ConfigError(
          fmt::format("{}: no particle count up to {} can represent it (a species would get no sphere): "
                      "lower the size ratio or raise the fraction of the rare species",
                      describe(), std::numeric_limits<Index>::max()));
    }
    throw ConfigError(
        fmt::format("{}: {} particles cannot represent it (a species would get no sphere); the "
                    "smallest count that works is N = {}",
                    describe(), count, smallest));
  }
  // Both modes draw from std::mt19937_64(seed), one uniform per draw from its top 53 bits: Systematic
  // uses the first draw as the common offset u, Random uses draw i for radius i.
  std::mt19937_64 rng(seed);
  std::vector<double> radii;
  if (sampling == Sampling::Systematic) {
    sampleSystematic(count, uniform01(rng), radii);
    return radii;
  }
  constexpr double kLowest = std::numeric_limits<double>::denorm_min();
  radii.resize(static_cast<std::size_t>(count));
  for (double& r : radii) r = quantile(std::max(uniform01(rng), kLowest));
  if (count > 0 && smallest > 0) {
    // Discrete: every species of positive fraction must appear (a random draw may miss a rare one).
    const double lo = minRadius(), hi = maxRadius();
    const bool hasLo = std::find(radii.begin(), radii.end(), lo) != radii.end();
    const bool hasHi = std::find(radii.begin(), radii.end(), hi) != radii.end();
    if (!hasLo || !hasHi) {
      throw ConfigError(
          fmt::format("{}: the random draw of {} particles (seed {}) holds no sphere of radius {:g}; "
                      "use systematic sampling (exact counts from N = {}) or more particles",
                      describe(), count, seed, hasLo ? hi : lo, smallest));
    }
  }
  return radii;
}

std::unique_ptr<SizeDistribution> makeDistribution(const DistributionSpec& spec) {
  const std::string& kind = spec.kind;
  if (kind == "mono") {
    requirePositive("rmin", spec.rmin);
    return std::make_unique<Mono>(spec.rmin);
  }
  if (kind == "bi") {
    requirePositive("rmin", spec.rmin);
    requireOmega(spec.omega);
    if (!(spec.largeFraction >= 0.0 && spec.largeFraction <= 1.0)) {
      throw ConfigError(
          fmt::format("largeFraction must be in [0, 1], got {} (fraction of the large species)", spec.largeFraction));
    }
    return std::make_unique<Bi>(spec.rmin, spec.omega, spec.largeFraction, spec.fractionKind);
  }
  if (kind == "uniform-radius" || kind == "us" || kind == "uniform-volume" || kind == "uv" || kind == "power-law") {
    requirePositive("rmin", spec.rmin);
    requireOmega(spec.omega);
    if (!std::isfinite(spec.rmin * spec.omega)) {
      throw ConfigError(fmt::format("rmax = rmin * omega must be finite, got {} * {}", spec.rmin, spec.omega));
    }
    if (kind == "power-law") {
      if (!std::isfinite(spec.alpha)) throw ConfigError(fmt::format("alpha must be finite, got {}", spec.alpha));
      return std::make_unique<PowerLaw>("power-law", spec.rmin, spec.omega, spec.alpha);
    }
    if (kind == "uniform-radius" || kind == "us") {
      return std::make_unique<PowerLaw>("uniform-radius", spec.rmin, spec.omega, 0.0);
    }
    return std::make_unique<PowerLaw>("uniform-volume", spec.rmin, spec.omega, -3.0);
  }
  if (kind == "log-normal" || kind == "ln") {
    requirePositive("median", spec.median);
    requirePositive("sigma", spec.sigma);
    if (spec.omega == 0.0) return std::make_unique<LogNormal>(spec.median, spec.sigma, 0.0, kInf);
    if (!(spec.omega > 1.0 && std::isfinite(spec.omega))) {
      throw ConfigError(fmt::format(
          "omega must be 0 (untruncated) or > 1 (truncated to [rmin, omega rmin]) for log-normal, got {}", spec.omega));
    }
    requirePositive("rmin", spec.rmin);
    return std::make_unique<LogNormal>(spec.median, spec.sigma, spec.rmin, spec.rmin * spec.omega);
  }
  throw ConfigError(
      fmt::format("unknown size distribution kind '{}'; valid kinds: mono, bi, uniform-radius (us), "
                  "uniform-volume (uv), power-law, log-normal (ln)",
                  kind));
}

std::array<double, 6> sampleMoments(std::span<const double> radii) {
  // Neumaier-compensated sums: the k = 5 terms of a wide sample span many orders of magnitude.
  std::array<double, 6> sum{}, compensation{};
  for (double r : radii) {
    double term = 1.0;
    for (std::size_t k = 0; k < 6; ++k) {
      const double t = sum[k] + term;
      compensation[k] += std::abs(sum[k]) >= std::abs(term) ? (sum[k] - t) + term : (term - t) + sum[k];
      sum[k] = t;
      term *= r;
    }
  }
  std::array<double, 6> moments{};
  if (radii.empty()) return moments;  // no sample, no moments: all zero
  const double n = static_cast<double>(radii.size());
  for (std::size_t k = 0; k < 6; ++k) moments[k] = (sum[k] + compensation[k]) / n;
  return moments;
}

}  // namespace polydem
