// Moments of size distributions: closed forms of Ogarko's thesis (eqs. 3.23-3.25, 3.37, 3.44), sample moments
// against a rigorous systematic-sampling bound, bounds O1^2 <= O2 <= O1, and bad input
// (thesis §3.1.2, §3.2).
#include "core/moments.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "core/errors.hpp"
#include "tests/support/scene.hpp"

namespace polydem {
namespace {

TEST(Moments, UniformSizeClosedForms) {
  for (double omega : {1.2, 2.0, 5.0, 50.0}) {
    SCOPED_TRACE(omega);
    const double w0 = (omega - 1) / (omega + 1);
    const Moments m = test::analyticMoments("uniform-radius", omega);
    // eq. 3.23
    EXPECT_NEAR(m.o1, 1 - 2.0 / 3.0 * w0 * w0 / (1 + w0 * w0), 1e-13);
    EXPECT_NEAR(m.o2, std::pow(3 + w0 * w0, 3) / (27 * std::pow(1 + w0 * w0, 2)), 1e-13);
    // eq. 3.37: M^c_2 = w0^2/3, M^c_3 = 0, M^c_4 = w0^4/5, M^c_5 = 0, beta2 = 9/5
    EXPECT_NEAR(m.central[2], w0 * w0 / 3, 1e-13);
    EXPECT_NEAR(m.central[3], 0.0, 1e-13);
    EXPECT_NEAR(m.central[4], std::pow(w0, 4) / 5, 1e-13);
    EXPECT_NEAR(m.central[5], 0.0, 1e-13);
    EXPECT_NEAR(m.kurtosis, 1.8, 1e-9);
    EXPECT_NEAR(m.delta, w0 / std::sqrt(3.0), 1e-13);
    EXPECT_NEAR(m.a, 1 / (m.delta * m.delta + 1), 1e-15);
    EXPECT_NEAR(m.a, m.o1 * m.o1 / m.o2, 1e-13);
    EXPECT_NEAR(m.delta, std::sqrt(m.o2 / (m.o1 * m.o1) - 1), 1e-7);
  }
}

TEST(Moments, UniformVolumeClosedForms) {
  for (double omega : {1.5, 4.0, 10.0, 100.0}) {
    SCOPED_TRACE(omega);
    const double w0 = (omega - 1) / (omega + 1), l = std::log(omega);
    const Moments m = test::analyticMoments("uniform-volume", omega);
    EXPECT_NEAR(m.o1, 2 * omega * l / (omega * omega - 1), 1e-13);  // eq. 3.24
    EXPECT_NEAR(m.o2, 2 * omega * omega * l * l * l / (std::pow(omega - 1, 3) * (omega + 1)), 1e-13);
    // eq. 3.44
    EXPECT_NEAR(m.scaled[2], l / (2 * w0), 1e-12 * m.scaled[2]);
    EXPECT_NEAR(m.scaled[3], std::pow(1 + omega, 2) / (4 * omega), 1e-12 * m.scaled[3]);
    EXPECT_NEAR(m.scaled[4], std::pow(1 + omega, 4) / (16 * omega * omega), 1e-12 * m.scaled[4]);
    EXPECT_NEAR(m.scaled[5], std::pow(1 + omega, 4) * (1 + omega + omega * omega) / (48 * std::pow(omega, 3)),
                1e-12 * m.scaled[5]);
  }
}

TEST(Moments, LogNormalClosedFormsAndDiameters) {
  for (double sigma : {0.1, 0.5, 1.0}) {
    SCOPED_TRACE(sigma);
    const Moments m = test::analyticMoments("log-normal", 0.0, sigma);
    const double s2 = sigma * sigma;
    EXPECT_NEAR(m.o1, std::exp(-2 * s2), 1e-13);  // eq. 3.25
    EXPECT_NEAR(m.o2, std::exp(-3 * s2), 1e-13);
    // eq. 3.47-3.48: a0 = 1/2 (D32 D43)^(1/2) (D32/D43)^3, sigma = sqrt(ln(D43/D32)); median is 1 here
    const double d32 = m.diameter(3, 2), d43 = m.diameter(4, 3);
    EXPECT_NEAR(0.5 * std::sqrt(d32 * d43) * std::pow(d32 / d43, 3), 1.0, 1e-12);
    EXPECT_NEAR(std::sqrt(std::log(d43 / d32)), sigma, 1e-12);
    EXPECT_NEAR(m.diameter(1, 0), 2 * std::exp(s2 / 2), 1e-12);
    EXPECT_NEAR(m.o1, m.diameter(1, 0) / d32, 1e-13);               // O1 = D10/D32
    EXPECT_NEAR(m.o2, std::pow(m.diameter(2, 0) / d32, 2), 1e-13);  // O2 = (D20/D32)^2
  }
}

TEST(Moments, BoundsHoldForEveryFamily) {
  std::vector<Moments> all = {test::analyticMoments("uniform-radius", 3), test::analyticMoments("uniform-volume", 30),
                              test::analyticMoments("log-normal", 0, 0.7), test::analyticMoments("bi", 10),
                              test::analyticMoments("power-law", 7)};
  for (const Moments& m : all) {
    EXPECT_GT(m.o1, 0.0);
    EXPECT_LT(m.o1, 1.0);
    EXPECT_LT(m.o1 * m.o1, m.o2);
    EXPECT_LT(m.o2, m.o1);
    EXPECT_GE(m.kurtosis, 1.0);
  }
  const Moments mono = test::analyticMoments("mono", 1);
  EXPECT_DOUBLE_EQ(mono.o1, 1.0);
  EXPECT_DOUBLE_EQ(mono.o2, 1.0);
  EXPECT_TRUE(mono.monodisperse());
  EXPECT_TRUE(std::isnan(mono.kurtosis));
}

// Systematic sampling: r_i = F^-1((i + u)/N) lies in stratum i, and r^k is monotone, so the sample mean of
// r^k differs from <r^k> by at most (rmax^k - rmin^k)/N.
TEST(Moments, SampleMatchesAnalyticWithinTheStratificationBound) {
  const Index n = 100000;
  for (const char* kind : {"uniform-radius", "uniform-volume"}) {
    DistributionSpec spec;
    spec.kind = kind;
    spec.omega = 10;
    const auto dist = makeDistribution(spec);
    const std::vector<double> radii = dist->sample(n, Sampling::Systematic, 3);
    const Moments s = momentsOfSample(radii);
    const Moments a = momentsOf(*dist);
    for (int k = 1; k <= 5; ++k) {
      const double bound = (std::pow(dist->maxRadius(), k) - std::pow(dist->minRadius(), k)) / n;
      EXPECT_LE(std::abs(s.raw[static_cast<std::size_t>(k)] - a.raw[static_cast<std::size_t>(k)]), bound)
          << kind << " k = " << k;
    }
    EXPECT_NEAR(s.o1, a.o1, 1e-3);
    EXPECT_NEAR(s.o2, a.o2, 1e-3);
    EXPECT_NEAR(s.kurtosis, a.kurtosis, 1e-2 * a.kurtosis);
    EXPECT_EQ(s.distinctRadii, Moments::kMaxDistinct);
  }
}

TEST(Moments, SampleCentralMomentsAreDirect) {
  // Narrow sample: central moments summed around the mean keep their relative accuracy.
  const std::vector<double> radii = {1.0 - 1e-6, 1.0, 1.0 + 1e-6};
  const Moments m = momentsOfSample(radii);
  EXPECT_NEAR(m.central[2], 2e-12 / 3, 1e-20);
  EXPECT_NEAR(m.kurtosis, 1.5, 1e-6);
  EXPECT_EQ(m.distinctRadii, 3);
  const Moments mono = momentsOfSample(std::vector<double>(7, 0.3));
  EXPECT_TRUE(mono.monodisperse());
  EXPECT_TRUE(std::isnan(mono.kurtosis));
  EXPECT_NEAR(mono.o1, 1.0, 1e-15);
  EXPECT_EQ(mono.distinctRadii, 1);
}

TEST(Moments, BadInputIsAnError) {
  EXPECT_THROW(momentsOfSample(std::vector<double>{}), ConfigError);
  EXPECT_THROW(momentsOfSample(std::vector<double>{1.0, 0.0}), ConfigError);
  EXPECT_THROW(momentsOfSample(std::vector<double>{1.0, -2.0}), ConfigError);
  EXPECT_THROW(momentsOfSample(std::vector<double>{std::numeric_limits<double>::quiet_NaN()}), ConfigError);
  EXPECT_THROW(momentsOfSample(std::vector<double>{std::numeric_limits<double>::infinity()}), ConfigError);
  EXPECT_THROW(momentsFromRaw({0, 1, 1, 1, 1, 1}), ConfigError);
  EXPECT_THROW(momentsFromRaw({1, 0, 1, 1, 1, 1}), ConfigError);
  const Moments m = test::analyticMoments("uniform-radius", 2);
  EXPECT_THROW(m.diameter(3, 3), ConfigError);
  EXPECT_THROW(m.diameter(6, 1), ConfigError);
  try {
    momentsOfSample(std::vector<double>{1.0, 2.0, -3.0});
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("radius 2"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace polydem
