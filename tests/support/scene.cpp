#include "tests/support/scene.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include "broadphase/registry.hpp"
#include "core/size_distribution.hpp"

namespace polydem::test {

Scene makeScene(const SceneSpec& spec) {
  DistributionSpec d;
  d.kind = spec.distribution;
  d.rmin = 1.0;
  d.omega = spec.sizeRatio;
  if (spec.distribution == "bi") d.largeFraction = 0.5;
  if (spec.distribution == "log-normal") {
    d.median = 1.0;
    d.sigma = std::log(spec.sizeRatio) / 4.0 + 1e-3;
    d.rmin = 0.0;
    d.omega = 0.0;
  }
  const auto dist = makeDistribution(d);
  std::vector<double> radii = dist->sample(spec.count, Sampling::Systematic, spec.seed);
  std::mt19937_64 rng(spec.seed * 7919 + 17);
  std::shuffle(radii.begin(), radii.end(), rng);

  double volume = 0.0, rmax = 0.0;
  for (double r : radii) {
    volume += 4.0 / 3.0 * kPi * r * r * r;
    rmax = std::max(rmax, r);
  }
  double edge = spec.count > 0 ? std::cbrt(volume / spec.packing) : 10.0;
  if (spec.periodic) edge = std::max(edge, 2.0 * (2.0 * rmax + 1.0) * 1.01);
  Scene scene;
  scene.box = Box::cubic(edge, spec.periodic ? Boundary::Periodic : Boundary::Wall);
  scene.centre.resize(3, spec.count);
  scene.radius.resize(spec.count);
  std::uniform_real_distribution<double> u(0.0, edge);
  for (Index i = 0; i < spec.count; ++i) {
    scene.radius[i] = radii[static_cast<std::size_t>(i)];
    for (int k = 0; k < 3; ++k) scene.centre(k, i) = u(rng);
  }
  return scene;
}

std::vector<broadphase::Pair> pairsFrom(std::string_view backend, const Scene& scene, double skin) {
  auto bp = broadphase::makeBroadPhase(backend);
  bp->build(scene.spheres(), scene.box, skin);
  std::vector<broadphase::Pair> pairs;
  bp->findPairs(scene.spheres(), pairs);
  broadphase::sortPairs(pairs);
  return pairs;
}

std::uint64_t checksum(const std::vector<broadphase::Pair>& pairs) {
  std::uint64_t sum = 0;
  for (const auto& p : pairs) {
    std::uint64_t h = (static_cast<std::uint64_t>(p.i) << 32) ^ static_cast<std::uint64_t>(p.j);
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdULL;
    h ^= h >> 33;
    sum += h;
  }
  return sum;
}

Moments analyticMoments(const std::string& kind, double omega, double sigma) {
  DistributionSpec spec;
  spec.kind = kind;
  spec.omega = omega;
  spec.sigma = sigma;
  return momentsOf(*makeDistribution(spec));
}

}  // namespace polydem::test
