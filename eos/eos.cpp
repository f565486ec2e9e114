// Fluid equations of state and jamming-density fits; formulas and seed lines in eos.hpp.
#include "eos/eos.hpp"

#include <fmt/format.h>

#include <cmath>
#include <limits>

#include "core/errors.hpp"

namespace polydem::eos {

namespace {

double cube(double x) { return x * x * x; }

}  // namespace

void validate(double nu, MomentRatios r) {
  if (!(nu >= 0.0 && nu < 1.0)) throw ConfigError(fmt::format("packing fraction nu must be in [0, 1), got {}", nu));
  constexpr double kSlack = 1e-12;
  if (!(r.o1 > 0.0 && r.o1 <= 1.0 + kSlack)) throw ConfigError(fmt::format("O1 must be in (0, 1], got {}", r.o1));
  if (!(r.o2 >= r.o1 * r.o1 * (1.0 - kSlack) && r.o2 <= r.o1 * (1.0 + kSlack))) {
    throw ConfigError(fmt::format("O2 must satisfy O1^2 <= O2 <= O1, got O1 = {}, O2 = {}", r.o1, r.o2));
  }
}

double gEffective(double nu, MomentRatios r) {
  validate(nu, r);
  const double v = 1.0 - nu;
  return (v * v + 3.0 * r.o1 * v + r.o2 * (3.0 - nu) * nu) / (4.0 * cube(v));
}

double zBMCSL(double nu, MomentRatios r) {
  validate(nu, r);
  const double v = 1.0 - nu;
  return 1.0 / v + r.o1 * 3.0 * nu / (v * v) + r.o2 * nu * nu * (3.0 - nu) / cube(v);
}

double zSCS(double nu, MomentRatios r) { return zBMCSL(nu, r) + (r.o1 - r.o2) * cube(nu) / cube(1.0 - nu); }

double zSCSK(double nu, MomentRatios r) {
  return zSCS(nu, r) + (r.o1 + r.o2) * cube(nu) * (1.0 - 2.0 * nu) / (6.0 * cube(1.0 - nu));
}

double zBCSK(double nu, MomentRatios r) {
  return zBMCSL(nu, r) + r.o2 * cube(nu) * (1.0 - 2.0 * nu) / (3.0 * cube(1.0 - nu));
}

double zOL(double nu, MomentRatios r) { return 0.5 * (zSCS(nu, r) + zBCSK(nu, r)); }

double zCarnahanStarling(double nu) {
  validate(nu, {});
  return (1.0 + nu + nu * nu - cube(nu)) / cube(1.0 - nu);
}

double zCSK(double nu) {
  validate(nu, {});
  return (1.0 + nu + nu * nu - 2.0 * cube(nu) * (1.0 + nu) / 3.0) / cube(1.0 - nu);
}

std::string_view formName(Form form) {
  switch (form) {
    case Form::BMCSL:
      return "BMCSL";
    case Form::SCS:
      return "SCS";
    case Form::CSK:
      return "CSK";
    case Form::SCSK:
      return "SCSK";
    case Form::BCSK:
      return "BCSK";
    case Form::OL:
      return "OL";
    case Form::CS:
      return "CS";
  }
  return "?";
}

double z(Form form, double nu, MomentRatios r) {
  switch (form) {
    case Form::BMCSL:
      return zBMCSL(nu, r);
    case Form::SCS:
      return zSCS(nu, r);
    case Form::CSK:
      return zCSK(nu);
    case Form::SCSK:
      return zSCSK(nu, r);
    case Form::BCSK:
      return zBCSK(nu, r);
    case Form::OL:
      return zOL(nu, r);
    case Form::CS:
      return zCarnahanStarling(nu);
  }
  return std::numeric_limits<double>::quiet_NaN();
}

double zFreeVolume(double nu, double phiJ, int dimension) {
  if (!(phiJ > 0.0 && phiJ <= 1.0)) throw ConfigError(fmt::format("jamming density must be in (0, 1], got {}", phiJ));
  if (!(nu >= 0.0 && nu < phiJ)) {
    throw ConfigError(fmt::format("free-volume law needs 0 <= nu < phi_J = {}, got nu = {}", phiJ, nu));
  }
  if (dimension < 1) throw ConfigError(fmt::format("dimension must be >= 1, got {}", dimension));
  return dimension / (1.0 - nu / phiJ);
}

double jammingFromPressure(double nu, double z, int dimension) {
  return z > dimension ? nu / (1.0 - dimension / z) : std::numeric_limits<double>::quiet_NaN();
}

double jammingFromShape(double f, double nuInf, double phiRcp) { return nuInf - (nuInf - phiRcp) * f; }

namespace {
void requireOmega(double omega) {
  if (!(omega >= 1.0) || !std::isfinite(omega)) throw ConfigError(fmt::format("omega must be >= 1, got {}", omega));
}
void requireSigma(double sigma) {
  if (!(sigma >= 0.0) || !std::isfinite(sigma)) throw ConfigError(fmt::format("sigma must be >= 0, got {}", sigma));
}
}  // namespace

double jammingUniformSize(double omega, double nuInf, double phiRcp) {
  requireOmega(omega);
  const double w = 1.0 / omega;
  return jammingFromShape(3.0 * w * w - 2.0 * w * w * w, nuInf, phiRcp);
}

double jammingUniformVolume(double omega, double nuInf, double phiRcp) {
  requireOmega(omega);
  const double w = 1.0 / omega;
  // (1 - ln omega^-2) = 1 + 2 ln omega: the natural log is the only reading with zero slope at omega = 1.
  return jammingFromShape((w - w * w + w * w * w) * (1.0 + 2.0 * std::log(omega)), nuInf, phiRcp);
}

double jammingLogNormal(double sigma, double nuInf, double phiRcp) {
  requireSigma(sigma);
  return jammingFromShape(std::exp(-2.0 * sigma * sigma), nuInf, phiRcp);
}

double jammingLogNormalAlt(double sigma) {
  requireSigma(sigma);
  return 0.8583 - 0.3516 * std::exp(-sigma * sigma) + 0.1332 * std::exp(-sigma * sigma * sigma);
}

std::vector<JammingPrediction> predictJamming(const DistributionSpec& spec, const Moments& moments) {
  std::vector<JammingPrediction> out;
  const std::string& kind = spec.kind;
  const bool us = kind == "uniform-radius" || kind == "us" || (kind == "power-law" && spec.alpha == 0.0);
  const bool uv = kind == "uniform-volume" || kind == "uv" || (kind == "power-law" && spec.alpha == -3.0);
  const bool ln = (kind == "log-normal" || kind == "ln") && spec.omega == 0.0;
  if (kind == "mono") {
    out.push_back({"eq. 3.15 at omega = 1 (phi_RCP of the US fit)", 0.65, "the seed's assumed phi_RCP"});
    out.push_back({"eq. 3.16 at omega = 1 (phi_RCP of the UV fit)", 0.647, "fitted"});
    out.push_back({"eq. 3.52 at sigma = 0 (fast compression, Gamma = 16e-3)", 0.6373, "measured by the seed"});
  }
  if (us) {
    out.push_back({"eq. 3.15 (US fit)", jammingUniformSize(spec.omega),
                   spec.omega >= 1.2 ? "fit within +-0.5% of the seed's data for omega >= 1.2"
                                     : "omega < 1.2: the seed's US systems partially crystallise here"});
  }
  if (uv) {
    out.push_back({"eq. 3.16 (UV fit)", jammingUniformVolume(spec.omega),
                   spec.omega >= 1.2 && spec.omega <= 10.0 ? "fit within +-1% for 1.2 <= omega <= 10"
                                                           : "outside the fitted range 1.2 <= omega <= 10"});
  }
  if (ln) {
    const char* range = spec.sigma <= 1.0 ? "within the fitted range 0 <= sigma <= 1" : "outside 0 <= sigma <= 1";
    out.push_back({"eq. 3.52 (log-normal fit, +-0.7%)", jammingLogNormal(spec.sigma), range});
    out.push_back({"eq. 3.55 (log-normal alternative, +-0.4%)", jammingLogNormalAlt(spec.sigma), range});
  }
  const double f = std::pow(moments.diameter(3, 2) / moments.diameter(4, 3), 2.0);
  out.push_back({"eq. 3.53 with F = (D32/D43)^2 and the log-normal nu_inf, phi_RCP",
                 jammingFromShape(f, 0.7990, 0.6373),
                 ln ? "identical to eq. 3.52 for log-normal" : "the seed's conjecture; not fitted to this family"});
  return out;
}

}  // namespace polydem::eos
