// Equivalent bi- and tridisperse mixtures: Tables 3.1, 3.3, 3.4 of Ogarko's thesis (Ogarko & Luding,
// J. Chem. Phys. 136 (2012) 124508; Soft Matter 9 (2013) 9530), the US 5:8:5 rule (eqs. 3.39-3.40), the kurtosis family
// (eqs. 3.41-3.42), conditioning at UV omega = 100 and log-normal sigma = 1, samples, degenerate inputs and integer
// realisation.
#include "core/equivalent_mixture.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <vector>

#include "core/errors.hpp"
#include "tests/support/scene.hpp"

namespace polydem {
namespace {

/// <a^k> of a mixture.
double mixtureMoment(const Mixture& m, int k) {
  double s = 0.0;
  for (std::size_t i = 0; i < m.size(); ++i) s += m.numberFraction[i] * std::pow(m.radius[i], k);
  return s;
}

/// One unit in the 4th significant digit of `value`.
double fourthDigit(double value) { return std::pow(10.0, std::floor(std::log10(std::abs(value))) - 3); }

struct Table31Row {
  const char* kind;
  double omega, o1, o2, rbi, n1, delta;
};

// Table 3.1 as printed: O1, O2 to 3 decimals, R_bi to 2 decimals (UV 100: 17.83), n1 to 3
// decimals, delta to 2 decimals. n1 < 0 marks "not printed / 1/2 by symmetry".
constexpr Table31Row kTable31[] = {
    {"uniform-radius", 1.2, 0.995, 0.992, 1.11, 0.5, 0.05},   {"uniform-radius", 1.4, 0.982, 0.973, 1.21, 0.5, 0.10},
    {"uniform-radius", 2, 0.933, 0.903, 1.48, 0.5, 0.19},     {"uniform-radius", 4, 0.824, 0.760, 2.06, 0.5, 0.35},
    {"uniform-radius", 5, 0.795, 0.725, 2.25, 0.5, 0.38},     {"uniform-radius", 10, 0.733, 0.657, 2.79, 0.5, 0.47},
    {"uniform-radius", 20, 0.700, 0.624, 3.19, 0.5, 0.52},    {"uniform-radius", 50, 0.680, 0.605, 3.49, 0.5, 0.55},
    {"uniform-radius", 100, 0.673, 0.599, 3.61, 0.5, 0.57},   {"uniform-volume", 1.2, 0.994, 0.992, 1.11, 0.453, 0.05},
    {"uniform-volume", 1.4, 0.981, 0.972, 1.21, 0.413, 0.10}, {"uniform-volume", 2, 0.924, 0.888, 1.49, 0.327, 0.20},
    {"uniform-volume", 4, 0.739, 0.632, 2.24, 0.190, 0.39},   {"uniform-volume", 5, 0.671, 0.543, 2.56, 0.156, 0.46},
    {"uniform-volume", 7, 0.568, 0.418, 3.13, 0.114, 0.55},   {"uniform-volume", 8, 0.528, 0.373, 3.40, 0.100, 0.58},
    {"uniform-volume", 10, 0.465, 0.304, 3.90, 0.080, 0.64},  {"uniform-volume", 100, 0.092, 0.020, 17.83, 0.006, 1.16},
};

TEST(EquivalentMixture, Table31Bidisperse) {
  for (const Table31Row& row : kTable31) {
    SCOPED_TRACE(::testing::Message() << row.kind << " omega " << row.omega);
    const Moments m = test::analyticMoments(row.kind, row.omega);
    EXPECT_NEAR(m.o1, row.o1, 0.0005 + 1e-12);
    EXPECT_NEAR(m.o2, row.o2, 0.0005 + 1e-12);
    EXPECT_NEAR(m.delta, row.delta, 0.005 + 1e-12);
    const Mixture bi = equivalentBidisperse(m);
    ASSERT_EQ(bi.size(), 2u);
    EXPECT_NEAR(bi.radius[0] / bi.radius[1], row.rbi, 0.005 + 1e-12);
    EXPECT_NEAR(bi.numberFraction[0], row.n1, 0.0005 + 1e-12);
    // The closed form (eqs. 3.20-3.21) gives the same mixture.
    const BidisperseRatios closed = bidisperseFromRatios(m.o1, m.o2);
    EXPECT_NEAR(closed.sizeRatio, bi.radius[0] / bi.radius[1], 1e-8 * closed.sizeRatio);
    EXPECT_NEAR(closed.largeNumberFraction, bi.numberFraction[0], 1e-8);
    // <a>, <a^2>, <a^3> matched, so O1 and O2 too.
    for (int k = 0; k <= 3; ++k) {
      EXPECT_NEAR(mixtureMoment(bi, k), m.raw[static_cast<std::size_t>(k)], 1e-11 * m.raw[static_cast<std::size_t>(k)]);
    }
  }
}

TEST(EquivalentMixture, Table31Limits) {
  // US omega -> inf: O1 -> 2/3, O2 -> 16/27, R_bi -> 2 + sqrt(3), delta -> sqrt(3)/3; UV: O1, O2 -> 0.
  const Moments us = test::analyticMoments("uniform-radius", 1e9);
  EXPECT_NEAR(us.o1, 2.0 / 3.0, 1e-8);
  EXPECT_NEAR(us.o2, 16.0 / 27.0, 1e-8);
  EXPECT_NEAR(us.delta, std::sqrt(3.0) / 3.0, 1e-8);
  const Mixture bi = equivalentBidisperse(us);
  EXPECT_NEAR(bi.radius[0] / bi.radius[1], 2 + std::sqrt(3.0), 1e-6);
  EXPECT_NEAR(bi.numberFraction[0], 0.5, 1e-9);
  const Moments uv = test::analyticMoments("uniform-volume", 1e9);
  EXPECT_LT(uv.o1, 1e-7);
  EXPECT_LT(uv.o2, 1e-13);  // 2 ln^3(omega)/omega^2 = 1.8e-14
  // omega = 1: a single species.
  EXPECT_EQ(equivalentBidisperse(test::analyticMoments("uniform-radius", 1.0)).size(), 1u);
  EXPECT_EQ(equivalentTridisperse(test::analyticMoments("uniform-volume", 1.0)).size(), 1u);
  EXPECT_THROW(bidisperseFromRatios(1.0, 1.0), ConfigError);
}

struct TriRow {
  double param, n1, n2, d1, d2;
};

// Table 3.3 (UV) and Table 3.4 (log-normal); delta_i = n_i a_i/<a>.
constexpr TriRow kTable33[] = {
    {2, 0.1427, 0.4054, 0.1988, 0.4337},    {3, 0.08923, 0.3544, 0.1593, 0.4181}, {4, 0.06189, 0.3118, 0.1345, 0.4034},
    {5, 0.04582, 0.2777, 0.1173, 0.3902},   {6, 0.03548, 0.2502, 0.1044, 0.3785}, {8, 0.02331, 0.2086, 0.08630, 0.3584},
    {10, 0.01661, 0.1789, 0.07400, 0.3419},
};
constexpr TriRow kTable34[] = {
    {0.05, 0.1330, 0.6620, 0.1457, 0.6653},        {0.1, 0.1040, 0.6480, 0.1263, 0.6611},
    {0.15, 0.07972, 0.6255, 0.1083, 0.6543},       {0.2, 0.05980, 0.5952, 0.09197, 0.6448},
    {0.25, 0.04384, 0.5585, 0.07722, 0.6329},      {0.3, 0.03138, 0.5167, 0.06405, 0.6186},
    {0.35, 0.02190, 0.4713, 0.05245, 0.6021},      {0.4, 0.01488, 0.4238, 0.04236, 0.5836},
    {0.45, 0.009833, 0.3758, 0.03371, 0.5634},     {0.5, 0.006306, 0.3285, 0.02639, 0.5416},
    {0.55, 0.003918, 0.2832, 0.02032, 0.5186},     {0.6, 0.002355, 0.2407, 0.01535, 0.4945},
    {0.65, 0.001367, 0.2017, 0.01137, 0.4695},     {0.7, 0.0007643, 0.1666, 0.008247, 0.4440},
    {0.75, 0.0004110, 0.1357, 0.005847, 0.4180},   {0.8, 0.0002121, 0.1090, 0.004046, 0.3920},
    {0.85, 0.0001048, 0.08627, 0.002729, 0.3659},  {0.9, 0.00004951, 0.06731, 0.001792, 0.3401},
    {0.95, 0.00002231, 0.05177, 0.001143, 0.3147}, {1.0, 0.000009572, 0.03923, 0.0007078, 0.2899},
};

void expectTriRow(const Moments& m, const TriRow& row) {
  const Mixture tri = equivalentTridisperse(m);
  ASSERT_EQ(tri.size(), 3u);
  const double mean = m.mean();
  EXPECT_NEAR(tri.numberFraction[0], row.n1, fourthDigit(row.n1));
  EXPECT_NEAR(tri.numberFraction[1], row.n2, fourthDigit(row.n2));
  EXPECT_NEAR(tri.numberFraction[0] * tri.radius[0] / mean, row.d1, fourthDigit(row.d1));
  EXPECT_NEAR(tri.numberFraction[1] * tri.radius[1] / mean, row.d2, fourthDigit(row.d2));
  for (int k = 0; k <= 5; ++k) {
    const double ref = m.raw[static_cast<std::size_t>(k)];
    EXPECT_NEAR(mixtureMoment(tri, k), ref, 1e-10 * ref) << "k = " << k;
  }
}

TEST(EquivalentMixture, Table33UniformVolumeTridisperse) {
  for (const TriRow& row : kTable33) {
    SCOPED_TRACE(::testing::Message() << "UV omega " << row.param);
    expectTriRow(test::analyticMoments("uniform-volume", row.param), row);
  }
}

TEST(EquivalentMixture, Table34LogNormalTridisperse) {
  for (const TriRow& row : kTable34) {
    SCOPED_TRACE(::testing::Message() << "log-normal sigma " << row.param);
    expectTriRow(test::analyticMoments("log-normal", 0.0, row.param), row);
  }
}

TEST(EquivalentMixture, UniformSizeIsGaussLegendre585) {
  for (double omega : {1.2, 3.0, 10.0, 100.0}) {
    SCOPED_TRACE(omega);
    const Moments m = test::analyticMoments("uniform-radius", omega);
    const Mixture tri = equivalentTridisperse(m);
    const Mixture closed = uniformSizeTridisperse(omega, m.mean());
    ASSERT_EQ(tri.size(), 3u);
    const double w0 = (omega - 1) / (omega + 1);
    for (std::size_t i = 0; i < 3; ++i) {
      EXPECT_NEAR(tri.radius[i], closed.radius[i], 1e-10 * m.mean());
      // 1e-9: the analytic central moments come from raw ones by cancellation (M^c_4 ~ 1e-5 at omega = 1.2).
      EXPECT_NEAR(tri.numberFraction[i], closed.numberFraction[i], 1e-9);
    }
    EXPECT_NEAR(closed.numberFraction[0], 5.0 / 18, 1e-15);
    EXPECT_NEAR(closed.numberFraction[1], 8.0 / 18, 1e-15);
    EXPECT_NEAR(closed.radius[0], m.mean() * (1 + std::sqrt(0.6) * w0), 1e-12 * m.mean());
    EXPECT_NEAR(closed.radius[1], m.mean(), 1e-12 * m.mean());
    // Bidisperse: Gauss-Legendre, <a>(1 +- w0/sqrt(3)), one half each.
    const Mixture bi = equivalentBidisperse(m);
    EXPECT_NEAR(bi.radius[0], m.mean() * (1 + w0 / std::sqrt(3.0)), 1e-10 * m.mean());
    EXPECT_NEAR(bi.numberFraction[0], 0.5, 1e-10);
  }
}

TEST(EquivalentMixture, KurtosisFamily) {
  const double omega = 3.0;
  const Moments us = test::analyticMoments("uniform-radius", omega);
  for (double beta2 : {1.05, 1.5, 1.8, 4.0, 8.0, 11.5}) {
    SCOPED_TRACE(beta2);
    const Mixture mix = kurtosisTridisperse(beta2, omega, us.mean());
    ASSERT_EQ(mix.size(), 3u);
    // eqs. 3.41-3.42 as printed for omega = 3
    EXPECT_NEAR(mix.numberFraction[0], 1 / (2 * beta2), 1e-14);
    EXPECT_NEAR(mix.numberFraction[1], (beta2 - 1) / beta2, 1e-14);
    EXPECT_NEAR(mix.numberFraction[0] * mix.radius[0] / us.mean(), (6 + std::sqrt(3 * beta2)) / (12 * beta2), 1e-14);
    EXPECT_NEAR(mix.numberFraction[1] * mix.radius[1] / us.mean(), (beta2 - 1) / beta2, 1e-14);
    // Matched: the central moments M^c_2, M^c_3, M^c_5 of US omega = 3 (the seed's "scaled moments k = 2, 3, 5",
    // thesis §3.2: the raw M_4, M_5 contain M^c_4 and so cannot stay fixed); M^c_4 gives the requested kurtosis.
    std::array<double, 6> raw{};
    for (int k = 0; k < 6; ++k) raw[static_cast<std::size_t>(k)] = mixtureMoment(mix, k);
    const Moments mm = momentsFromRaw(raw);
    EXPECT_NEAR(mm.mean(), us.mean(), 1e-14);
    for (int k : {2, 3, 5}) {
      EXPECT_NEAR(mm.central[static_cast<std::size_t>(k)], us.central[static_cast<std::size_t>(k)], 1e-12);
    }
    EXPECT_NEAR(mm.kurtosis, beta2, 1e-9 * beta2);
  }
  // beta2 = 1.8 is the maximally equivalent (5:8:5) member.
  const Mixture max = kurtosisTridisperse(1.8, omega, us.mean());
  const Mixture gauss = uniformSizeTridisperse(omega, us.mean());
  for (std::size_t i = 0; i < 3; ++i) EXPECT_NEAR(max.radius[i], gauss.radius[i], 1e-14);
  EXPECT_THROW(kurtosisTridisperse(1.0, omega, 1.0), ConfigError);   // middle species vanishes
  EXPECT_THROW(kurtosisTridisperse(12.0, omega, 1.0), ConfigError);  // smallest radius reaches 0
}

TEST(EquivalentMixture, WideDistributionsStayAccurate) {
  // UV omega = 100 and log-normal sigma = 1: the rule reproduces all six moments, positive nodes and weights.
  for (const Moments& m : {test::analyticMoments("uniform-volume", 100), test::analyticMoments("uniform-volume", 1000),
                           test::analyticMoments("log-normal", 0, 1.0), test::analyticMoments("log-normal", 0, 1.5),
                           test::analyticMoments("power-law", 100)}) {
    const Mixture tri = equivalentTridisperse(m);
    ASSERT_EQ(tri.size(), 3u);
    for (int k = 0; k <= 5; ++k) {
      const double ref = m.raw[static_cast<std::size_t>(k)];
      EXPECT_NEAR(mixtureMoment(tri, k), ref, 1e-9 * ref) << "k = " << k;
    }
    const Mixture bi = equivalentBidisperse(m);
    const BidisperseRatios closed = bidisperseFromRatios(m.o1, m.o2);
    EXPECT_NEAR(bi.radius[0] / bi.radius[1], closed.sizeRatio, 1e-7 * closed.sizeRatio);
    EXPECT_NEAR(bi.numberFraction[0], closed.largeNumberFraction, 1e-7 * closed.largeNumberFraction);
  }
}

TEST(EquivalentMixture, SampleEquivalentsApproachTheDistributionOnes) {
  DistributionSpec spec;
  spec.kind = "uniform-volume";
  spec.omega = 4;
  const auto dist = makeDistribution(spec);
  const Moments exact = momentsOf(*dist);
  const Mixture triExact = equivalentTridisperse(exact);
  const Mixture biExact = equivalentBidisperse(exact);
  // Systematic sample of 10^6: moments within (rmax^k - rmin^k)/N (see moments_test), so the nodes within ~1e-5.
  const Moments sample = momentsOfSample(dist->sample(1000000, Sampling::Systematic, 5));
  const Mixture tri = equivalentTridisperse(sample);
  const Mixture bi = equivalentBidisperse(sample);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_NEAR(tri.radius[i], triExact.radius[i], 1e-5 * triExact.radius[i]);
    EXPECT_NEAR(tri.numberFraction[i], triExact.numberFraction[i], 1e-5);
  }
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_NEAR(bi.radius[i], biExact.radius[i], 1e-5 * biExact.radius[i]);
    EXPECT_NEAR(bi.numberFraction[i], biExact.numberFraction[i], 1e-5);
  }
}

TEST(EquivalentMixture, FewerDistinctRadiiThanNodes) {
  const std::vector<double> mono(100, 2.5);
  const Mixture m1 = equivalentTridisperse(momentsOfSample(mono));
  ASSERT_EQ(m1.size(), 1u);
  EXPECT_DOUBLE_EQ(m1.radius[0], 2.5);
  std::vector<double> two(30, 1.0);
  two.insert(two.end(), 10, 7.0);
  const Mixture m2 = equivalentTridisperse(momentsOfSample(two));
  ASSERT_EQ(m2.size(), 2u);
  EXPECT_NEAR(m2.radius[0], 7.0, 1e-12);
  EXPECT_NEAR(m2.radius[1], 1.0, 1e-12);
  EXPECT_NEAR(m2.numberFraction[0], 0.25, 1e-12);
  // The analytic bidisperse distribution (no sample count): the vanishing recurrence coefficient ends the rule.
  DistributionSpec bi;
  bi.kind = "bi";
  bi.omega = 20;
  const Mixture m3 = equivalentTridisperse(momentsOf(*makeDistribution(bi)));
  ASSERT_EQ(m3.size(), 2u);
  EXPECT_NEAR(m3.radius[0] / m3.radius[1], 20.0, 1e-8);
  EXPECT_NEAR(m3.volumeFraction[0], 0.5, 1e-8);  // equal-volume default
  const Mixture three = equivalentTridisperse(momentsOfSample(std::vector<double>{1, 2, 3}));
  ASSERT_EQ(three.size(), 3u);
  EXPECT_NEAR(three.radius[0], 3.0, 1e-12);
  EXPECT_NEAR(three.radius[2], 1.0, 1e-12);
}

TEST(EquivalentMixture, IntegerRealisationUsesLargestRemainders) {
  const Mixture m = makeMixture({1.0, 2.0, 3.0}, {5.0 / 18, 8.0 / 18, 5.0 / 18});
  // 10 particles: exact 2.78, 4.44, 2.78 -> floors 2, 4, 2; two more to the largest remainders (3 and 1).
  const std::vector<double> r = mixtureRadii(m, 10);
  ASSERT_EQ(r.size(), 10u);
  EXPECT_EQ(std::count(r.begin(), r.end(), 3.0), 3);
  EXPECT_EQ(std::count(r.begin(), r.end(), 2.0), 4);
  EXPECT_EQ(std::count(r.begin(), r.end(), 1.0), 3);
  EXPECT_TRUE(mixtureRadii(m, 0).empty());
  // Equal remainders: the tie goes to the larger radius.
  const Mixture half = makeMixture({1.0, 2.0}, {0.5, 0.5});
  const std::vector<double> one = mixtureRadii(half, 1);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one[0], 2.0);
  // Large N: realised fractions within 1/N.
  const Mixture tri =
      equivalentTridisperse(momentsOf(*makeDistribution({.kind = "log-normal", .omega = 0, .sigma = 0.5})));
  const std::vector<double> big = mixtureRadii(tri, 4096);
  ASSERT_EQ(big.size(), 4096u);
  for (std::size_t i = 0; i < tri.size(); ++i) {
    const double realised = std::count(big.begin(), big.end(), tri.radius[i]) / 4096.0;
    EXPECT_LE(std::abs(realised - tri.numberFraction[i]), 1.0 / 4096);
  }
  EXPECT_THROW(mixtureRadii(m, -1), ConfigError);
}

TEST(EquivalentMixture, BadInputIsAnError) {
  const Moments m = test::analyticMoments("uniform-radius", 2);
  EXPECT_THROW(gaussMixture(m, 0), ConfigError);
  EXPECT_THROW(gaussMixture(m, 4), ConfigError);
  EXPECT_THROW(makeMixture({1.0}, {0.5, 0.5}), ConfigError);
  EXPECT_THROW(makeMixture({}, {}), ConfigError);
  EXPECT_THROW(makeMixture({-1.0}, {1.0}), ConfigError);
  EXPECT_THROW(makeMixture({1.0}, {-1.0}), ConfigError);
  EXPECT_THROW(bidisperseFromRatios(0.9, 0.95), ConfigError);  // O2 > O1
  EXPECT_THROW(uniformSizeTridisperse(0.5, 1.0), ConfigError);
  // Moments no distribution of positive radii has (M^c_2 < 0 is clamped; here M_3 too small for M_2).
  EXPECT_THROW(equivalentTridisperse(momentsFromRaw({1, 1, 4, 0.5, 1, 1})), ConfigError);
}

}  // namespace
}  // namespace polydem
