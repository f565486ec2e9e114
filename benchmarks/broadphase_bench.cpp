// Broad-phase benchmarks: build + findPairs per particle for every backend in the registry, on
// monodisperse and wide distributions. Run: build/benchmarks/polydem_broadphase_bench
//   --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <map>
#include <string>

#include "broadphase/registry.hpp"
#include "tests/support/scene.hpp"

namespace {

using namespace polydem;

const char* kDistributions[] = {"mono", "bi", "uniform-radius", "uniform-volume"};

const test::Scene& cachedScene(Index count, int dist, double ratio) {
  static std::map<std::tuple<Index, int, double>, test::Scene> cache;
  auto key = std::make_tuple(count, dist, ratio);
  auto it = cache.find(key);
  if (it == cache.end()) {
    it = cache
             .emplace(key, test::makeScene({.count = count,
                                            .distribution = kDistributions[dist],
                                            .sizeRatio = dist == 0 ? 1.0 : ratio,
                                            .packing = 0.3,
                                            .seed = 7}))
             .first;
  }
  return it->second;
}

void benchFindPairs(benchmark::State& state, std::string backendName) {
  const Index count = static_cast<Index>(state.range(0));
  const test::Scene& scene = cachedScene(count, static_cast<int>(state.range(1)), static_cast<double>(state.range(2)));
  auto backend = broadphase::makeBroadPhase(backendName);
  std::vector<broadphase::Pair> pairs;
  for (auto _ : state) {
    backend->build(scene.spheres(), scene.box, 0.1 * scene.minRadius());
    backend->findPairs(scene.spheres(), pairs);
    benchmark::DoNotOptimize(pairs.data());
  }
  state.SetItemsProcessed(state.iterations() * count);
  state.counters["pairs"] = static_cast<double>(pairs.size());
  state.counters["bytes_per_particle"] = static_cast<double>(backend->memoryBytes()) / count;
  state.counters["checksum"] = static_cast<double>(test::checksum(pairs) % 1'000'000);
}

}  // namespace

int main(int argc, char** argv) {
  for (const std::string& name : broadphase::backendNames()) {
    auto* b = benchmark::RegisterBenchmark(("findPairs/" + name).c_str(), benchFindPairs, name);
    if (name == "brute") {
      b->ArgsProduct({{1 << 12}, {0, 3}, {10}});
    } else {
      b->ArgsProduct({{1 << 14, 1 << 17}, {0, 1, 2, 3}, {10, 50}});
    }
    b->ArgNames({"n", "dist", "ratio"})->Unit(benchmark::kMillisecond);
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
