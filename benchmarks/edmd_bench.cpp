// Event-driven hard spheres at fixed density: collisions per CPU second and the event mix (events,
// neighbourhood exits and checks per collision, neighbour-list length) of the issue-6 targets,
// monodisperse N = 10,000 and uniform volume omega = 50 (N = 20,000) at packing fraction 0.5.
// The start is made as `polydem jam` makes it (systematic radii, shuffled, random sequential addition at
// phi 0.3, Maxwell-Boltzmann velocities, compression at rate 1e-2 to phi 0.5), once per case and cached;
// the timed loop runs `perIteration` collisions per particle with a synchronisation after each block, as
// edmd::runAtFixedDensity does. Uniform-volume cases first run 10 collisions per particle untimed (the
// skin adaptation settles). Counters: coll/s per CPU second, events/exits/checks per collision, nb (mean
// list length), f (skin floor), p (reduced pressure: two codes that claim the same trajectory must print
// the same p and counts). Results: docs/edmd-results.md.
// Run (Release): build/benchmarks/polydem_edmd_bench --benchmark_filter='mono10k/|uv10_10k/|uv50_20k/'
// (omega = 50 compresses for minutes; POLYDEM_EDMD_BENCH_START_2=FILE reads a start written by
// `polydem jam -n 20000 --dist uniform-volume --omega 50 --schedule 1e-2 --target-phi 0.5 -o FILE
// --velocities`).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <random>
#include <stdexcept>
#include <string>

#include "core/initial_configuration.hpp"
#include "core/io/particle_file.hpp"
#include "core/size_distribution.hpp"
#include "edmd/compression.hpp"
#include "edmd/hard_sphere_system.hpp"

namespace {

using namespace polydem;

struct Case {
  const char* distribution;
  double omega;
  Index count;
};
constexpr Case kCases[] = {{"mono", 1.0, 10000},
                           {"uniform-volume", 10.0, 10000},
                           {"uniform-volume", 50.0, 20000},
                           {"uniform-volume", 50.0, 20000}};  // 3: at the RSA start, phi 0.3 (no compression)

struct Start {
  Box box;
  Eigen::Matrix3Xd position, velocity;
  Eigen::VectorXd radius;
};

const Start& startAtHalf(int which) {
  static std::map<int, Start> cache;
  const int key = which;
  auto found = cache.find(key);
  if (found != cache.end()) return found->second;
  const Case& c = kCases[which];
  // A start written by `polydem jam ... --target-phi 0.5 -o FILE --velocities` (uniform volume omega = 50
  // takes minutes to compress): POLYDEM_EDMD_BENCH_START_<case>=FILE.
  const std::string variable = "POLYDEM_EDMD_BENCH_START_" + std::to_string(which);
  if (const char* file = std::getenv(variable.c_str())) {
    io::ParticleData data = io::readParticles(file);
    if (!data.velocity) throw std::runtime_error(std::string(file) + ": no velocities (write with --velocities)");
    Start s{data.box, data.position, *data.velocity, data.radius};
    return cache.emplace(key, std::move(s)).first->second;
  }
  DistributionSpec spec;
  spec.kind = c.distribution;
  spec.omega = c.omega;
  const std::uint64_t seed = 1;
  std::vector<double> radii = makeDistribution(spec)->sample(c.count, Sampling::Systematic, seed);
  std::mt19937_64 rng(seed ^ 0x9e3779b97f4a7c15ULL);
  std::shuffle(radii.begin(), radii.end(), rng);
  PackingRequest request;
  request.radii = radii;
  request.packingFraction = 0.3;
  request.seed = seed;
  const Configuration rsa = randomSequentialAddition(request);
  if (which == 3) {
    Start s{rsa.box, rsa.position, edmd::maxwellBoltzmannVelocities(rsa.radius, seed), rsa.radius};
    return cache.emplace(key, std::move(s)).first->second;
  }
  edmd::HardSphereSystem system(rsa.box, rsa.position, rsa.radius, edmd::maxwellBoltzmannVelocities(rsa.radius, seed));
  edmd::CompressionOptions options;
  options.schedule = {{1e-2, edmd::HardSphereSystem::kInfinity}};
  options.targetPackingFraction = 0.5;
  edmd::compress(system, options);
  Start s{system.box(), system.positions(), system.velocities(), system.radii()};
  return cache.emplace(key, std::move(s)).first->second;
}

void benchFixedDensity(benchmark::State& state) {
  const int which = static_cast<int>(state.range(0));
  const double perIteration = static_cast<double>(state.range(1));
  const Start& start = startAtHalf(which);
  edmd::SystemOptions options;
  if (state.range(2) > 0) options.neighbourhoodScale = 1.0 + 0.01 * static_cast<double>(state.range(2));
  if (state.range(4) > 0) options.exitWork = static_cast<double>(state.range(4));
  if (state.range(3) >= 2) options.adaptiveSkin = false;
  if (state.range(3) >= 3) options.skinFloor = static_cast<double>(state.range(3)) / 2.0;
  edmd::HardSphereSystem system(start.box, start.position, start.radius, start.velocity, options);
  const Index n = system.count();
  const std::int64_t block = static_cast<std::int64_t>(perIteration * n);
  // Warm-up (not timed): the skin adaptation settles (a fresh system starts at the skin floor).
  if (state.range(0) != 0) {
    for (int k = 0; k < 5; ++k) {
      system.run(2 * static_cast<std::int64_t>(n));
      system.synchronise();
    }
  }
  const edmd::EventCounts before = system.counts();
  system.resetPressureWindow();
  for (auto _ : state) {
    system.run(block);
    system.synchronise();
  }
  const edmd::EventCounts& after = system.counts();
  const double collisions = static_cast<double>(after.collisions - before.collisions);
  const double events = static_cast<double>(after.events() - before.events());
  state.counters["coll/s"] = benchmark::Counter(collisions, benchmark::Counter::kIsRate);
  state.counters["events/coll"] = events / collisions;
  state.counters["exits/coll"] = static_cast<double>(after.exits - before.exits) / collisions;
  state.counters["checks/coll"] = static_cast<double>(after.checks - before.checks) / collisions;
  state.counters["nb"] = system.meanNeighbours();
  state.counters["rebuilds"] = static_cast<double>(after.rebuilds - before.rebuilds);
  state.counters["f"] = system.skinFloor();
  state.counters["p"] = system.pressureWindow().reducedPressure();  // checks a fast wrong answer
}

}  // namespace

int main(int argc, char** argv) {
  // Args: case (0 mono 10k, 1 UV omega 10 10k, 2 UV omega 50 20k), collisions per particle per iteration,
  // neighbourhood scale mu as 100 (mu - 1) (0: the default), skin rule: 0 the default, 2 = no skin
  // adaptation, k >= 3: no adaptation with skin floor f = k / 2; SystemOptions::exitWork (0: the default).
  // The earlier skin rules (modes 1 and 10) were removed with their SystemOptions switches; see
  // docs/edmd-results.md.
  benchmark::RegisterBenchmark("edmdFixedDensity/mono10k", benchFixedDensity)
      ->Args({0, 20, 0, 0, 0})
      ->Iterations(5)
      ->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("edmdFixedDensity/mono10k_mu", benchFixedDensity)
      ->ArgsProduct({{0}, {20}, {30, 60}, {0}, {0}})
      ->Iterations(5)
      ->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("edmdFixedDensity/uv10_10k", benchFixedDensity)
      ->ArgsProduct({{1}, {10}, {0}, {0}, {0}})
      ->Iterations(5)
      ->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("edmdFixedDensity/uv50_20k", benchFixedDensity)
      ->ArgsProduct({{2}, {4}, {0}, {0}, {0}})
      ->Iterations(5)
      ->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("edmdFixedDensity/uv50_20k_phi03", benchFixedDensity)
      ->ArgsProduct({{3}, {2}, {0}, {0, 2, 6, 12}, {0}})
      ->Iterations(3)
      ->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("edmdFixedDensity/uv50_20k_exitwork", benchFixedDensity)
      ->ArgsProduct({{2}, {4}, {0}, {0}, {10, 30, 60, 300}})
      ->Iterations(5)
      ->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("edmdFixedDensity/uv10_10k_exitwork", benchFixedDensity)
      ->ArgsProduct({{1}, {10}, {0}, {0}, {30, 60}})
      ->Iterations(5)
      ->Unit(benchmark::kMillisecond);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
