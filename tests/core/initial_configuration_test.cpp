// Random sequential addition and random overlapping centres: no overlaps (brute force), exact packing
// fraction, spheres inside walls, order of the output, the stall error and bad requests.
#include "core/initial_configuration.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "core/errors.hpp"
#include "core/size_distribution.hpp"
#include "core/types.hpp"

namespace polydem {
namespace {

constexpr std::array<Boundary, 3> kPeriodic = {Boundary::Periodic, Boundary::Periodic, Boundary::Periodic};
constexpr std::array<Boundary, 3> kWalled = {Boundary::Wall, Boundary::Wall, Boundary::Wall};
constexpr std::array<Boundary, 3> kMixed = {Boundary::Wall, Boundary::Periodic, Boundary::Periodic};

std::vector<double> shuffledRadii(const DistributionSpec& spec, Index count, std::uint64_t seed) {
  std::vector<double> radii = makeDistribution(spec)->sample(count, Sampling::Systematic, seed);
  std::mt19937_64 rng(seed + 100);
  std::shuffle(radii.begin(), radii.end(), rng);
  return radii;
}

/// Pairs closer than contact, by brute force with the same minimum-image predicate as the broad phases.
int overlappingPairs(const Configuration& c) {
  int count = 0;
  for (Eigen::Index i = 0; i < c.radius.size(); ++i) {
    for (Eigen::Index j = i + 1; j < c.radius.size(); ++j) {
      const Eigen::Vector3d d = c.box.minimumImage(c.position.col(i) - c.position.col(j));
      const double contact = c.radius[i] + c.radius[j];
      if (d.squaredNorm() < contact * contact) ++count;
    }
  }
  return count;
}

double packingFraction(const Configuration& c) {
  return 4.0 / 3.0 * kPi * c.radius.array().cube().sum() / c.box.volume();
}

void expectInside(const Configuration& c) {
  for (Eigen::Index i = 0; i < c.radius.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      const double x = c.position(k, i), r = c.radius[i], length = c.box.length(k);
      if (c.box.periodic(k)) {
        ASSERT_TRUE(x >= 0.0 && x < length) << "sphere " << i << " axis " << k;
      } else {
        ASSERT_TRUE(x >= r && x <= length - r) << "sphere " << i << " axis " << k << " x " << x << " r " << r;
      }
    }
  }
}

struct RsaCase {
  std::string name;
  DistributionSpec spec;
  std::array<Boundary, 3> boundaries;
  double packing;
};

TEST(RandomSequentialAddition, PlacesWithoutOverlapAtTheRequestedPackingFraction) {
  const DistributionSpec mono{.kind = "mono", .rmin = 1.0};
  const DistributionSpec uv{.kind = "uniform-volume", .rmin = 0.5, .omega = 10.0};
  const DistributionSpec bi{.kind = "bi", .rmin = 1.0, .omega = 5.0, .largeFraction = 0.6};
  for (const RsaCase& c : {RsaCase{"mono periodic", mono, kPeriodic, 0.3}, RsaCase{"mono walled", mono, kWalled, 0.3},
                           RsaCase{"mono mixed", mono, kMixed, 0.3}, RsaCase{"UV 10 periodic", uv, kPeriodic, 0.3},
                           RsaCase{"UV 10 walled", uv, kWalled, 0.3}, RsaCase{"UV 10 mixed", uv, kMixed, 0.35},
                           RsaCase{"bi 5 periodic", bi, kPeriodic, 0.3}}) {
    SCOPED_TRACE(c.name);
    PackingRequest request;
    request.radii = shuffledRadii(c.spec, 2000, 5);
    request.packingFraction = c.packing;
    request.boundaries = c.boundaries;
    request.seed = 9;
    const Configuration config = randomSequentialAddition(request);
    ASSERT_EQ(config.position.cols(), 2000);
    ASSERT_EQ(config.radius.size(), 2000);
    for (std::size_t i = 0; i < request.radii.size(); ++i) {
      ASSERT_EQ(config.radius[static_cast<Eigen::Index>(i)], request.radii[i]);  // original order
    }
    EXPECT_EQ(overlappingPairs(config), 0);
    EXPECT_NEAR(packingFraction(config), c.packing, 1e-12 * c.packing);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(config.box.boundary(k), c.boundaries[k]);
    expectInside(config);
  }
}

TEST(RandomSequentialAddition, BoxFollowsAspectAndRunIsDeterministic) {
  PackingRequest request;
  request.radii = shuffledRadii({.kind = "us", .rmin = 1.0, .omega = 3.0}, 1000, 1);
  request.packingFraction = 0.25;
  request.aspect = {1.0, 2.0, 4.0};
  request.boundaries = kMixed;
  request.seed = 3;
  const Configuration a = randomSequentialAddition(request);
  EXPECT_NEAR(a.box.length(1) / a.box.length(0), 2.0, 1e-14);
  EXPECT_NEAR(a.box.length(2) / a.box.length(0), 4.0, 1e-14);
  EXPECT_NEAR(packingFraction(a), 0.25, 1e-12 * 0.25);
  EXPECT_EQ(overlappingPairs(a), 0);
  const Configuration b = randomSequentialAddition(request);
  EXPECT_EQ(a.position, b.position);
  request.seed = 4;
  EXPECT_NE(randomSequentialAddition(request).position, a.position);
}

TEST(RandomSequentialAddition, SingleSphereAndWideSizeRatio) {
  PackingRequest one;
  one.radii = {0.5};
  one.packingFraction = 0.1;
  one.boundaries = kWalled;
  const Configuration c = randomSequentialAddition(one);
  EXPECT_NEAR(packingFraction(c), 0.1, 1e-15);
  expectInside(c);

  // omega = 100: most spheres are tiny, a few are huge; levels span 7 factors of 2.
  PackingRequest wide;
  wide.radii = shuffledRadii({.kind = "uv", .rmin = 0.01, .omega = 100.0}, 3000, 2);
  wide.packingFraction = 0.2;
  const Configuration w = randomSequentialAddition(wide);
  EXPECT_EQ(overlappingPairs(w), 0);
}

TEST(RandomSequentialAddition, StallPointsToJam) {
  PackingRequest request;
  request.radii.assign(1000, 1.0);
  request.packingFraction = 0.45;  // above RSA saturation (about 0.38 for monodisperse spheres)
  try {
    randomSequentialAddition(request);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("random sequential addition stalled at packing fraction"), std::string::npos) << message;
    EXPECT_NE(message.find("polydem jam"), std::string::npos) << message;
    EXPECT_NE(message.find(" of 1000 spheres"), std::string::npos) << message;
  }
}

void expectRequestError(const PackingRequest& request, const std::string& fragment) {
  for (auto place : {&randomSequentialAddition, &randomOverlapping}) {
    try {
      place(request);
      ADD_FAILURE() << "no ConfigError, expected one mentioning '" << fragment << "'";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  }
}

TEST(RandomSequentialAddition, BadRequestsThrow) {
  PackingRequest request;
  request.radii.assign(10, 1.0);
  for (double phi : {0.0, 1.0, -0.1, std::nan("")}) {
    request.packingFraction = phi;
    expectRequestError(request, "packingFraction must be in (0, 1)");
  }
  request.packingFraction = 0.2;
  request.aspect = {1.0, -1.0, 1.0};
  expectRequestError(request, "aspect along y must be > 0");
  request.aspect = {1.0, 1.0, 1.0};
  request.radii[3] = 0.0;
  expectRequestError(request, "radius 3 must be > 0");
  request.radii.clear();
  expectRequestError(request, "radii must not be empty");
  request.radii = {1.0};  // one sphere at packing 0.6: edge (4 pi / 3 / 0.6)^(1/3) = 1.91 < its diameter
  request.packingFraction = 0.6;
  expectRequestError(request, "below the largest diameter");
  request.packingFraction = 0.2;
  request.maxAttemptsPerParticle = 0;
  EXPECT_THROW(randomSequentialAddition(request), ConfigError);
}

TEST(RandomOverlapping, SameBoxAsRsaAndCentresInside) {
  PackingRequest request;
  request.radii = shuffledRadii({.kind = "uv", .rmin = 1.0, .omega = 10.0}, 5000, 3);
  request.packingFraction = 0.6;  // far beyond RSA: overlaps are the point
  request.boundaries = kMixed;
  const Configuration c = randomOverlapping(request);
  EXPECT_NEAR(packingFraction(c), 0.6, 1e-12 * 0.6);
  expectInside(c);
  for (std::size_t i = 0; i < request.radii.size(); ++i) {
    ASSERT_EQ(c.radius[static_cast<Eigen::Index>(i)], request.radii[i]);
  }
  EXPECT_GT(overlappingPairs(c), 0);
}

/// The recipe makeStartPacking replaces in generate, jam and relax: sample, shuffle with the salted seed,
/// place. The shared function must give exactly this (bit for bit), so their files stay the same.
Configuration handMadeStart(std::vector<double> radii, double packing, std::uint64_t seed, bool rsa) {
  std::mt19937_64 rng(seed ^ 0x9e3779b97f4a7c15ULL);
  std::shuffle(radii.begin(), radii.end(), rng);
  PackingRequest request;
  request.radii = radii;
  request.packingFraction = packing;
  request.boundaries = kMixed;
  request.seed = seed;
  return rsa ? randomSequentialAddition(request) : randomOverlapping(request);
}

void expectSame(const Configuration& a, const Configuration& b) {
  ASSERT_EQ(a.radius.size(), b.radius.size());
  EXPECT_EQ(a.box.lengths(), b.box.lengths());
  EXPECT_TRUE((a.radius.array() == b.radius.array()).all());
  EXPECT_TRUE((a.position.array() == b.position.array()).all());
}

TEST(StartPacking, SampledShuffledAndPlacedLikeTheHandMadeRecipe) {
  const auto dist = makeDistribution({.kind = "uv", .rmin = 1.0, .omega = 8.0});
  StartPackingRequest request;
  request.count = 400;
  request.sampling = Sampling::Random;
  request.packingFraction = 0.2;
  request.boundaries = kMixed;
  request.seed = 7;
  const StartPacking start = makeStartPacking(*dist, request);
  expectSame(start.configuration, handMadeStart(dist->sample(400, Sampling::Random, 7), 0.2, 7, true));
  EXPECT_EQ(overlappingPairs(start.configuration), 0);
  ASSERT_EQ(start.id.size(), 400u);
  for (std::size_t i = 0; i < start.id.size(); ++i) ASSERT_EQ(start.id[i], static_cast<Index>(i));
  EXPECT_EQ(start.distribution, dist->describe());
  // The radii are shuffled, not left in the sample's sorted order.
  EXPECT_FALSE(std::is_sorted(start.configuration.radius.begin(), start.configuration.radius.end()));
}

TEST(StartPacking, GivenRadiiAndOverlappingPlacement) {
  const auto dist = makeDistribution({.kind = "mono", .rmin = 1.0});
  StartPackingRequest request;
  request.radii = {1.0, 2.0, 3.0, 1.5, 2.5, 0.5, 1.0, 2.0};  // e.g. an equivalent mixture
  request.packingFraction = 0.5;
  request.boundaries = kMixed;
  request.seed = 11;
  request.placement = Placement::RandomOverlapping;
  const StartPacking start = makeStartPacking(*dist, request);
  expectSame(start.configuration, handMadeStart(request.radii, 0.5, 11, false));
  EXPECT_EQ(start.id.size(), request.radii.size());
}

}  // namespace
}  // namespace polydem
