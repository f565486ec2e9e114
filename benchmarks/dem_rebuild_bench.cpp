// DEM runs for counting what the rebuild work and the re-sorting cost and save (issue 18), to be run
// under `perf stat -e cache-misses,instructions` or `valgrind --tool=callgrind` rather than timed on a
// shared machine: a hot gas (whose storage order decays) or a dense packing (whose order does not), the
// broad phase, thread count and re-sort rule given on the command line. Prints the counts that explain
// the figures: steps, rebuilds, re-sorts, the final order decay, candidate pairs, memory, and the
// phase split of the loop's wall time (for orientation only).
//
//   polydem_dem_rebuild_bench --count 200000 --steps 2000 --packing 0.2 --resort-interval 200
//   polydem_dem_rebuild_bench --count 200000 --steps 2000 --packing 0.2 --resort-interval 0   # never
//   polydem_dem_rebuild_bench --count 50000 --steps 50 --unsorted       # random order: locality fully lost
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "integrators/dem_simulation.hpp"
#include "integrators/initial_velocities.hpp"
#include "tests/integrators/dem_scenes.hpp"

int main(int argc, char** argv) {
  using namespace polydem;
  CLI::App app("DEM run with counts of rebuilds and re-sorts (run under perf stat or callgrind)");
  Index count = 100000;
  int steps = 1000;
  double packing = 0.2;
  double overlap = 0.2;
  double skin = 0.1;
  double ratio = 2.0;
  std::string backend = "linked-cell";
  int threads = 1;
  integrators::ResortRule resort;
  bool unsorted = false;
  app.add_option("--count", count, "spheres (radii 1 and --ratio, alternating)")
      ->check(CLI::Range(Index(2), Index(1) << 30))
      ->capture_default_str();
  app.add_option("--steps", steps, "DEM steps")->check(CLI::Range(0, 1 << 30))->capture_default_str();
  app.add_option("--packing", packing, "packing fraction of the jittered-lattice start")
      ->check(CLI::Range(0.01, 0.5))
      ->capture_default_str();
  app.add_option("--overlap", overlap, "impact velocities: head-on overlap of two small spheres / radius")
      ->check(CLI::Range(1e-6, 0.5))
      ->capture_default_str();
  app.add_option("--skin", skin, "Verlet skin (m; radii are 1 m)")->check(CLI::Range(0.0, 10.0))->capture_default_str();
  app.add_option("--ratio", ratio, "size ratio of the two kinds of spheres")
      ->check(CLI::Range(1.0, 100.0))
      ->capture_default_str();
  app.add_option("--broadphase", backend, "backend name (broadphase/registry.cpp) or auto")->capture_default_str();
  app.add_option("--threads", threads, "OpenMP threads")->check(CLI::Range(1, 1024))->capture_default_str();
  app.add_option("--resort-interval", resort.interval, "steps between order-decay measurements (0 = never re-sort)")
      ->check(CLI::Range(std::int64_t{0}, std::int64_t{1} << 40))
      ->capture_default_str();
  app.add_option("--resort-threshold", resort.threshold, "re-sort above this order decay")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  app.add_flag("--unsorted", unsorted,
               "keep the start's random storage order (spatial_sort off: no initial sort, no re-sorts), the state a "
               "fully decayed order reaches");
  CLI11_PARSE(app, argc, argv);

  try {
    std::vector<double> radii;
    for (Index i = 0; i < count; ++i) radii.push_back(i % 2 ? ratio : 1.0);
    Box box;
    ParticleStore p = test::latticeGas(radii, packing, box, 3);
    integrators::DemSettings settings;
    settings.contact.stiffness = 1e4;
    settings.contact.restitution = 0.9;
    settings.broadPhase = backend;
    settings.skin = skin;
    settings.threads = threads;
    settings.resort = resort;
    settings.spatialSort = !unsorted;
    settings.stability.checkInterval = 0;
    integrators::assignImpactVelocities(contact::ContactModel(settings.contact), p, overlap, 1);
    integrators::DemSimulation sim(std::move(p), box, settings);
    const std::int64_t builds0 = sim.rebuilds();
    sim.advance(steps);
    const integrators::PhaseTimes& t = sim.times();
    const double loop = t.broadPhase + t.force + t.integration + t.check;
    fmt::print(
        "N = {}, {} steps, {} threads, {}: {} rebuilds, {} re-sorts, final order decay {:.3f}, {:.2f} candidate "
        "pairs per particle, {:.0f} bytes per particle; loop wall-time split (orientation only): broad phase {:.0f}%, "
        "force {:.0f}%, integration {:.0f}%\n",
        count, steps, threads, sim.neighbours().backend().describe(), sim.rebuilds() - builds0, sim.resorts(),
        sim.orderDecay(), static_cast<double>(sim.neighbours().list().pairCount()) / count,
        static_cast<double>(sim.memoryBytes()) / count, 100 * t.broadPhase / loop, 100 * t.force / loop,
        100 * t.integration / loop);
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return 2;
  }
  return 0;
}
