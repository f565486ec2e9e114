// Fluid equations of state, free-volume law and jamming-density fits of Ogarko's thesis ch. 3 (Ogarko &
// Luding, J. Chem. Phys. 136 (2012) 124508: §3.1.2 check values, eqs. 3.15-3.16; eqs. 3.52, 3.55).
#include "eos/eos.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "core/equivalent_mixture.hpp"
#include "core/errors.hpp"
#include "tests/support/scene.hpp"

namespace polydem::eos {
namespace {

TEST(Eos, MonodisperseHalfIsThirteenForEveryForm) {
  for (Form f : kAllForms) EXPECT_NEAR(z(f, 0.5, {}), 13.0, 1e-12) << formName(f);
}

TEST(Eos, MonodisperseFormsCoincide) {
  for (double nu : {0.05, 0.2, 0.35, 0.55}) {
    EXPECT_NEAR(zBMCSL(nu, {}), zCarnahanStarling(nu), 1e-12);
    EXPECT_NEAR(zSCS(nu, {}), zCarnahanStarling(nu), 1e-12);
    EXPECT_NEAR(zSCSK(nu, {}), zCSK(nu), 1e-12);
    EXPECT_NEAR(zBCSK(nu, {}), zCSK(nu), 1e-12);
    EXPECT_NEAR(1 + 4 * nu * gEffective(nu, {}), zCarnahanStarling(nu), 1e-12);
    EXPECT_NEAR(gEffective(nu, {}), (1 - nu / 2) / std::pow(1 - nu, 3), 1e-12);  // g_CS
  }
  EXPECT_DOUBLE_EQ(zBMCSL(0.0, {}), 1.0);
}

TEST(Eos, CheckValues) {
  // monodisperse nu = 0.3: BMCSL 3.9738, CSK 3.9843, OL 3.9790 (printed to 4 decimals)
  EXPECT_NEAR(zBMCSL(0.3, {}), 3.9738, 5e-5);
  EXPECT_NEAR(zCSK(0.3), 3.9843, 5e-5);
  EXPECT_NEAR(zOL(0.3, {}), 3.9790, 5e-5);
  // US omega = 5 (O1 = 0.7949, O2 = 0.7254) at nu = 0.5: BMCSL 10.396, SCS 10.466, OL 10.431
  const MomentRatios us5 = ratiosOf(test::analyticMoments("uniform-radius", 5));
  EXPECT_NEAR(us5.o1, 0.7949, 5e-5);
  EXPECT_NEAR(us5.o2, 0.7254, 5e-5);
  EXPECT_NEAR(zBMCSL(0.5, us5), 10.396, 5e-4);
  EXPECT_NEAR(zSCS(0.5, us5), 10.466, 5e-4);
  EXPECT_NEAR(zOL(0.5, us5), 10.431, 5e-4);
}

TEST(Eos, PolydisperseIdentities) {
  const Moments uv = test::analyticMoments("uniform-volume", 10);
  const MomentRatios r = ratiosOf(uv);
  for (double nu : {0.1, 0.4, 0.6}) {
    EXPECT_NEAR(1 + 4 * nu * gEffective(nu, r), zBMCSL(nu, r), 1e-12 * zBMCSL(nu, r));  // eq. 3.8 = 3.9
    EXPECT_NEAR(zOL(nu, r), 0.5 * (zSCS(nu, r) + zBCSK(nu, r)), 1e-12);
    // Polydispersity lowers the pressure at fixed nu (O1, O2 < 1).
    EXPECT_LT(zBMCSL(nu, r), zBMCSL(nu, {}));
    // The equivalent bidisperse mixture has the same O1, O2, hence the same fluid Z (thesis §3.1 appendix).
    const Mixture bi = equivalentBidisperse(uv);
    std::array<double, 6> raw{};
    for (int k = 0; k < 6; ++k) {
      for (std::size_t i = 0; i < bi.size(); ++i)
        raw[static_cast<std::size_t>(k)] += bi.numberFraction[i] * std::pow(bi.radius[i], k);
    }
    const MomentRatios rb = ratiosOf(momentsFromRaw(raw));
    for (Form f : kAllForms) EXPECT_NEAR(z(f, nu, rb), z(f, nu, r), 1e-9 * z(f, nu, r)) << formName(f);
  }
}

TEST(Eos, FreeVolumeRoundTrip) {
  for (double phiJ : {0.64, 0.70, 0.85}) {
    for (double nu : {0.3, 0.6, phiJ * (1 - 1e-9)}) {
      if (nu >= phiJ) continue;
      const double zfv = zFreeVolume(nu, phiJ);
      EXPECT_NEAR(zfv * (1 - nu / phiJ), 3.0, 1e-12 * zfv);
      EXPECT_NEAR(jammingFromPressure(nu, zfv), phiJ, 1e-12);
    }
  }
  EXPECT_NEAR(zFreeVolume(0.5, 0.75, 2), 6.0, 1e-12);
  EXPECT_TRUE(std::isnan(jammingFromPressure(0.5, 3.0)));
  EXPECT_THROW(zFreeVolume(0.7, 0.65), ConfigError);
  EXPECT_THROW(zFreeVolume(0.5, 1.5), ConfigError);
}

TEST(Eos, JammingFitTables) {
  // Digest §6.6 tables (arithmetic of eqs. 3.15, 3.16, 3.52, 3.55), printed to 4 decimals.
  const double us[][2] = {{1.2, 0.6524}, {1.5, 0.6585}, {2, 0.6664},  {3, 0.6743},
                          {4, 0.6777},   {5, 0.6794},   {10, 0.6819}, {100, 0.6828}};
  for (const auto& [omega, v] : us) EXPECT_NEAR(jammingUniformSize(omega), v, 5e-5) << "US " << omega;
  const double uv[][2] = {{1.2, 0.6514}, {2, 0.6693}, {3, 0.6833}, {4, 0.6965}, {5, 0.7087}, {8, 0.7372}, {10, 0.7509}};
  for (const auto& [omega, v] : uv) EXPECT_NEAR(jammingUniformVolume(omega), v, 5e-5) << "UV " << omega;
  const double ln[][3] = {{0, 0.6373, 0.6399},
                          {0.25, 0.6563, 0.6591},
                          {0.5, 0.7009, 0.7020},
                          {0.75, 0.7465, 0.7453},
                          {1.0, 0.7771, 0.7780}};
  for (const auto& [sigma, v52, v55] : ln) {
    EXPECT_NEAR(jammingLogNormal(sigma), v52, 5e-5) << "LN 3.52 " << sigma;
    EXPECT_NEAR(jammingLogNormalAlt(sigma), v55, 5e-5) << "LN 3.55 " << sigma;
  }
  // Limits and zero slope at omega = 1 (enforced by the seed's fits).
  EXPECT_DOUBLE_EQ(jammingUniformSize(1.0), 0.65);
  EXPECT_DOUBLE_EQ(jammingUniformVolume(1.0), 0.647);
  const double h = 1e-5;
  EXPECT_NEAR((jammingUniformSize(1 + h) - jammingUniformSize(1.0)) / h, 0.0, 1e-3);
  EXPECT_NEAR((jammingUniformVolume(1 + h) - jammingUniformVolume(1.0)) / h, 0.0, 1e-3);
  EXPECT_NEAR(jammingUniformSize(1e9), 0.6828, 1e-8);
}

TEST(Eos, PredictionsPickTheFamilyFit) {
  DistributionSpec us;
  us.kind = "uniform-radius";
  us.omega = 4;
  const auto p = predictJamming(us, momentsOf(*makeDistribution(us)));
  ASSERT_GE(p.size(), 2u);
  EXPECT_NE(p[0].equation.find("3.15"), std::string::npos);
  EXPECT_NEAR(p[0].value, 0.6777, 5e-5);
  DistributionSpec ln;
  ln.kind = "log-normal";
  ln.omega = 0;
  ln.sigma = 0.5;
  const auto q = predictJamming(ln, momentsOf(*makeDistribution(ln)));
  ASSERT_EQ(q.size(), 3u);
  EXPECT_NEAR(q[0].value, 0.7009, 5e-5);
  EXPECT_NEAR(q[2].value, q[0].value, 1e-12);  // eq. 3.53 with (D32/D43)^2 is eq. 3.52 for log-normal
}

TEST(Eos, BadInputIsAnError) {
  EXPECT_THROW(zBMCSL(1.0, {}), ConfigError);
  EXPECT_THROW(zBMCSL(-0.1, {}), ConfigError);
  EXPECT_THROW(zOL(0.5, {0.9, 0.95}), ConfigError);  // O2 > O1
  EXPECT_THROW(zOL(0.5, {0.9, 0.5}), ConfigError);   // O2 < O1^2
  EXPECT_THROW(zSCS(0.5, {0.0, 0.0}), ConfigError);
  EXPECT_THROW(jammingUniformSize(0.5), ConfigError);
  EXPECT_THROW(jammingLogNormal(-1), ConfigError);
}

}  // namespace
}  // namespace polydem::eos
