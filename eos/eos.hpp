#pragma once
// Equations of state of polydisperse hard-sphere fluids and the jamming-density laws of V. Ogarko's
// dissertation (University of Twente), ch. 3: Ogarko & Luding, J. Chem. Phys. 136 (2012) 124508 (§3.1)
// and Soft Matter 9 (2013) 9530 (§3.2-3.3).
//
// Fluid EOS, Z = pV/(N k_B T) at packing fraction nu, depending on the size distribution only through
// O1 = <a><a^2>/<a^3> and O2 = <a^2>^3/<a^3>^2 (eq. 3.6):
//   g_eff = [(1-nu)^2 + 3 O1 (1-nu) + O2 (3-nu) nu] / (4 (1-nu)^3),  Z = 1 + 4 nu g_eff   (eqs. 3.7-3.8, §3.1.2)
//   Z_BMCSL = 1/(1-nu) + O1 3nu/(1-nu)^2 + O2 nu^2 (3-nu)/(1-nu)^3            (eq. 3.9, §3.1.2; = eq. 3.8)
//   Z_SCS   = Z_BMCSL + (O1 - O2) nu^3/(1-nu)^3                               (eq. 3.10, §3.1.2)
//   Z_CSK   = [1 + nu + nu^2 - 2 nu^3 (1+nu)/3]/(1-nu)^3  (monodisperse)      (§3.1.2)
//   Z_SCSK  = Z_SCS + (O1 + O2) nu^3 (1 - 2nu)/(6 (1-nu)^3)                   (eq. 3.11, §3.1.2)
//   Z_BCSK  = Z_BMCSL + O2 nu^3 (1 - 2nu)/(3 (1-nu)^3)                        (eq. 3.12, §3.1.2)
//   Z_OL    = (Z_SCS + Z_BCSK)/2                                               (eq. 3.13, §3.1.3)
//   Z_CS    = (1 + nu + nu^2 - nu^3)/(1-nu)^3 (monodisperse Carnahan-Starling; = Z_BMCSL at O1 = O2 = 1)
// Near jamming, the free-volume (Salsburg-Wood) law Z = d/(1 - nu/phi_J) and its inversion, the estimator
// phi_J = nu/(1 - d/Z) (eq. 3.14, §3.1.3).
// Jamming-density fits nu_max = nu_inf - (nu_inf - phi_RCP) F (natural logarithms, the reading
// that gives eq. 3.16 its zero slope at omega = 1; eq. 3.55's second exponent read as sigma^3):
//   US  eq. 3.15 (§3.1.3): F = 3 omega^-2 - 2 omega^-3,                         nu_inf 0.6828, phi_RCP 0.65
//   UV  eq. 3.16 (§3.1.3): F = (omega^-1 - omega^-2 + omega^-3)(1 + 2 ln omega), nu_inf 0.859,  phi_RCP 0.647
//   LN  eq. 3.52 (§3.3.2): F = exp(-2 sigma^2) = (D32/D43)^2 (eq. 3.54),         nu_inf 0.7990, phi_RCP 0.6373
//   LN  eq. 3.55 (§3.3.2): nu_max = nu_inf + c1 exp(-sigma^2) + c2 exp(-sigma^3), 0.8583, -0.3516, 0.1332
// The fits describe the seed's own compressions (N = 4096..16384, Gamma 8e-6..16e-3), not a universal law.
#include <string>
#include <string_view>
#include <vector>

#include "core/moments.hpp"
#include "core/size_distribution.hpp"

namespace polydem::eos {

/// The two moment ratios the fluid EOS depend on; (1, 1) is monodisperse.
struct MomentRatios {
  double o1 = 1.0;
  double o2 = 1.0;
};
inline MomentRatios ratiosOf(const Moments& m) { return {m.o1, m.o2}; }

/// Throws ConfigError unless 0 <= nu < 1 (packing fraction) and 0 < O1 <= 1, O1^2 <= O2 <= O1 (1e-12 slack).
void validate(double nu, MomentRatios r);

/// Effective contact value g_eff(nu) of eq. 3.7.
double gEffective(double nu, MomentRatios r);
double zBMCSL(double nu, MomentRatios r);
double zSCS(double nu, MomentRatios r);
double zSCSK(double nu, MomentRatios r);
double zBCSK(double nu, MomentRatios r);
double zOL(double nu, MomentRatios r);
/// Monodisperse Carnahan-Starling, 1 + 4 nu g_CS with g_CS = (1 - nu/2)/(1 - nu)^3.
double zCarnahanStarling(double nu);
/// Monodisperse Carnahan-Starling-Kolafa.
double zCSK(double nu);

enum class Form { BMCSL, SCS, CSK, SCSK, BCSK, OL, CS };
inline constexpr Form kAllForms[] = {Form::BMCSL, Form::SCS, Form::CSK, Form::SCSK, Form::BCSK, Form::OL, Form::CS};
/// "BMCSL", "SCS", ... (CS and CSK ignore O1, O2: they are the monodisperse forms).
std::string_view formName(Form form);
double z(Form form, double nu, MomentRatios r);

/// Free-volume law Z = d / (1 - nu/phiJ) for 0 <= nu < phiJ (eq. 3.14). Throws ConfigError otherwise.
double zFreeVolume(double nu, double phiJ, int dimension = 3);
/// Its inverse, the jamming-density estimator phi_J = nu / (1 - d/Z); NaN for Z <= d.
double jammingFromPressure(double nu, double z, int dimension = 3);

/// Eq. 3.53: nu_max = nuInf - (nuInf - phiRcp) F.
double jammingFromShape(double f, double nuInf, double phiRcp);
/// Eq. 3.15, uniform size with size ratio omega >= 1 (fit quality +-0.5% for omega >= 1.2).
double jammingUniformSize(double omega, double nuInf = 0.6828, double phiRcp = 0.65);
/// Eq. 3.16, uniform volume, natural log (+-1% for 1.2 <= omega <= 10).
double jammingUniformVolume(double omega, double nuInf = 0.859, double phiRcp = 0.647);
/// Eq. 3.52, log-normal width sigma >= 0 (+-0.7% for sigma <= 1).
double jammingLogNormal(double sigma, double nuInf = 0.7990, double phiRcp = 0.6373);
/// Eq. 3.55, log-normal alternative (+-0.4% for sigma <= 1; exponent sigma^3 as extracted, unverified).
double jammingLogNormalAlt(double sigma);

/// One applicable prediction.
struct JammingPrediction {
  std::string equation;  ///< e.g. "eq. 3.15 (US fit)"
  double value = 0.0;
  std::string note;  ///< range of validity, whether this input is inside it
};
/// The fits that apply to this distribution family: US -> 3.15, UV -> 3.16, untruncated log-normal ->
/// 3.52 and 3.55, mono -> the phi_RCP of each fit; always also eq. 3.53 with F = (D32/D43)^2 and the
/// log-normal parameters (the seed's conjecture that F is a moment function; speculative for other
/// families). Power law with alpha = 0 / -3 counts as US / UV.
std::vector<JammingPrediction> predictJamming(const DistributionSpec& spec, const Moments& moments);

}  // namespace polydem::eos
