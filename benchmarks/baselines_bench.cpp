// Baseline broad phases (sweep and prune, CGAL box intersection, CGAL regular triangulation) against
// linked cell and the other registry backends: build + findPairs per particle on random overlapping
// scenes, plus the cost of an update after small moves (SAP insertion sort, Delaunay move()).
// Cases: 0 mono, 1 uniform-volume omega 10, 2 uniform-volume omega 50 (random overlapping centres),
// 3 = case 1 without overlaps (random sequential addition; update benchmarks only).
// Run (Release): build/benchmarks/polydem_baselines_bench --benchmark_min_time=0.1
#include <benchmark/benchmark.h>

#include <map>
#include <random>
#include <string>
#include <tuple>

#include "broadphase/registry.hpp"
#include "core/initial_configuration.hpp"
#include "core/size_distribution.hpp"
#include "polydem/config.hpp"
#include "tests/support/scene.hpp"

#if POLYDEM_WITH_CGAL
#include "broadphase/delaunay.hpp"
#endif

namespace {

using namespace polydem;

struct Case {
  const char* distribution;
  double omega;
  bool overlapping;  // random centres (test::makeScene) or random sequential addition (no overlaps)
};
constexpr Case kCases[] = {{"mono", 1.0, true},
                           {"uniform-volume", 10.0, true},
                           {"uniform-volume", 50.0, true},
                           {"uniform-volume", 10.0, false}};

// Case 3: the same radii as case 1 without overlaps, as in a DEM packing (no hidden points for the
// regular triangulation, so its incremental update applies).
test::Scene nonOverlappingScene(Index count, const Case& c, double packing) {
  const auto dist = makeDistribution({.kind = c.distribution, .rmin = 1.0, .omega = c.omega});
  PackingRequest request;
  request.radii = dist->sample(count, Sampling::Systematic, 7);
  request.packingFraction = packing;
  request.seed = 7;
  const Configuration conf = randomSequentialAddition(request);
  return {.box = conf.box, .centre = conf.position, .radius = conf.radius};
}

const test::Scene& cachedScene(Index count, int c, int packingPercent) {
  static std::map<std::tuple<Index, int, int>, test::Scene> cache;
  const auto key = std::make_tuple(count, c, packingPercent);
  auto it = cache.find(key);
  if (it == cache.end()) {
    const Case& spec = kCases[c];
    it = cache
             .emplace(key, spec.overlapping ? test::makeScene({.count = count,
                                                               .distribution = spec.distribution,
                                                               .sizeRatio = spec.omega,
                                                               .packing = packingPercent / 100.0,
                                                               .seed = 7})
                                            : nonOverlappingScene(count, spec, packingPercent / 100.0))
             .first;
  }
  return it->second;
}

// args: n, case, packing in percent
void benchBuildFindPairs(benchmark::State& state, std::string backendName) {
  const Index count = static_cast<Index>(state.range(0));
  const test::Scene& scene = cachedScene(count, static_cast<int>(state.range(1)), static_cast<int>(state.range(2)));
  auto backend = broadphase::makeBroadPhase(backendName);
  std::vector<broadphase::Pair> pairs;
  for (auto _ : state) {
    // A fresh backend each time: measures a cold build (no order kept from the previous iteration).
    backend = broadphase::makeBroadPhase(backendName);
    backend->build(scene.spheres(), scene.box, 0.1 * scene.minRadius());
    backend->findPairs(scene.spheres(), pairs);
    benchmark::DoNotOptimize(pairs.data());
  }
  state.SetItemsProcessed(state.iterations() * count);
  state.counters["ns_per_particle"] = benchmark::Counter(static_cast<double>(state.iterations() * count),
                                                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["pairs"] = static_cast<double>(pairs.size());
  state.counters["bytes_per_particle"] = static_cast<double>(backend->memoryBytes()) / count;
  state.counters["checksum"] = static_cast<double>(test::checksum(pairs) % 1'000'000);
}

// Steady state between steps: every `stride`-th particle moves by +-0.02 r_min (alternating, so the
// scene does not drift), then update() + findPairs(). Time per moved particle and per particle.
// args: n, case, packing in percent, stride
void benchUpdate(benchmark::State& state, std::string backendName) {
  const Index count = static_cast<Index>(state.range(0));
  test::Scene scene = cachedScene(count, static_cast<int>(state.range(1)), static_cast<int>(state.range(2)));
  const Index stride = static_cast<Index>(state.range(3));
  const double skin = 0.1 * scene.minRadius();
  const bool forceMove = backendName == "delaunay-move";
  auto backend = broadphase::makeBroadPhase(forceMove ? "delaunay" : backendName);
#if POLYDEM_WITH_CGAL
  if (forceMove) static_cast<broadphase::Delaunay&>(*backend).setMaxMovedFraction(1.0);  // move() even for all
#endif
  backend->build(scene.spheres(), scene.box, skin);
  std::vector<Index> moved;
  for (Index i = 0; i < count; i += stride) moved.push_back(i);
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Matrix3Xd step(3, moved.size());
  for (Eigen::Index k = 0; k < step.cols(); ++k) {
    step.col(k) = 0.02 * scene.minRadius() * Eigen::Vector3d(u(rng), u(rng), u(rng));
  }
  std::vector<broadphase::Pair> pairs;
  double sign = 1.0;
  for (auto _ : state) {
    state.PauseTiming();
    for (std::size_t k = 0; k < moved.size(); ++k) {
      const Index i = moved[k];
      scene.centre.col(i) = scene.box.wrap(scene.centre.col(i) + sign * step.col(static_cast<Eigen::Index>(k)));
    }
    sign = -sign;
    state.ResumeTiming();
    backend->update(scene.spheres(), moved);
    backend->findPairs(scene.spheres(), pairs);
    benchmark::DoNotOptimize(pairs.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(moved.size()));
  state.counters["ns_per_moved"] = benchmark::Counter(static_cast<double>(state.iterations() * moved.size()),
                                                      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["ns_per_particle"] = benchmark::Counter(static_cast<double>(state.iterations() * count),
                                                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["pairs"] = static_cast<double>(pairs.size());
  state.SetLabel(backend->describe());
}

}  // namespace

int main(int argc, char** argv) {
  for (const std::string& name : broadphase::backendNames()) {
    if (name == "brute") continue;
    benchmark::RegisterBenchmark(("buildFindPairs/" + name).c_str(), benchBuildFindPairs, name)
        ->ArgsProduct({{1 << 14}, {0, 1, 2}, {10, 40}})
        ->ArgNames({"n", "case", "nu%"})
        ->Unit(benchmark::kMillisecond);
  }
  std::vector<std::string> updated = {"linked-cell", "sap"};
  updated.insert(updated.end(),
                 {"lbvh", "aabb-tree", "hgrid-dynamic"});  // refit / incremental trees (issue 23), grid of runs
#if POLYDEM_WITH_CGAL
  updated.insert(updated.end(), {"delaunay", "delaunay-move"});  // default (rebuild above 25% moved) vs move()
#endif
  for (const std::string& name : updated) {
    benchmark::RegisterBenchmark(("update/" + name).c_str(), benchUpdate, name)
        ->ArgsProduct({{1 << 14}, {0, 1, 3}, {30}, {1, 10, 100}})
        ->ArgNames({"n", "case", "nu%", "stride"})
        ->Unit(benchmark::kMillisecond);
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
