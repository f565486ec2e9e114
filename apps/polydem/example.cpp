// polydem example: the built-in demonstration scene. Generates a polydisperse packing, runs every
// broad phase on it, checks they agree, and prints the timings side by side.
#include <fmt/format.h>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/common.hpp"
#include "apps/polydem/pair_report.hpp"
#include "broadphase/registry.hpp"
#include "core/errors.hpp"
#include "core/initial_configuration.hpp"

namespace polydem::app {

namespace {
struct ExampleOptions {
  Index count = 20000;
  double omega = 10.0;
  double packing = 0.3;
  int repeat = 3;
};
}  // namespace

Runner addExample(CLI::App& app) {
  auto opt = std::make_shared<ExampleOptions>();
  CLI::App* cmd = app.add_subcommand(
      "example", "built-in example: uniform-volume spheres by random sequential addition, every broad phase compared");
  cmd->add_option("-n,--count", opt->count, "number of particles")->capture_default_str();
  cmd->add_option("--omega", opt->omega, "size ratio")->capture_default_str();
  cmd->add_option("--phi", opt->packing, "packing fraction")->capture_default_str();
  cmd->add_option("--repeat", opt->repeat, "timed repetitions per backend")->capture_default_str();
  return [opt]() {
    DistributionSpec spec;
    spec.kind = "uniform-volume";
    spec.rmin = 1.0;
    spec.omega = opt->omega;
    const auto dist = makeDistribution(spec);
    Stopwatch clock;
    PackingRequest request;
    request.radii = dist->sample(opt->count, Sampling::Systematic, 1);
    request.packingFraction = opt->packing;
    request.boundaries = {Boundary::Periodic, Boundary::Periodic, Boundary::Periodic};
    request.seed = 1;
    const Configuration config = randomSequentialAddition(request);
    fmt::print("example scene: {} spheres, {}, packing fraction {}, {}\n", opt->count, dist->describe(), opt->packing,
               config.box.describe());
    fmt::print("placed by random sequential addition in {:.3f} s\n\n", clock.seconds());

    const SphereView spheres{config.position, config.radius};
    const double skin = 0.1 * spec.rmin;
    std::vector<std::string> names = broadphase::backendNames();
    names.push_back("auto");
    std::vector<PairReport> reports;
    for (const std::string& name : names) {
      if (name == "brute" && opt->count > 50000) continue;  // O(N^2): minutes
      reports.push_back(measurePairs(name, spheres, config.box, skin, opt->repeat));
    }
    fmt::print("{:<14} {:>12} {:>12} {:>14} {:>12}  {}\n", "backend", "pairs", "overlaps", "us/particle",
               "bytes/part", "configuration");
    bool agree = true;
    for (const PairReport& r : reports) {
      fmt::print("{:<14} {:>12} {:>12} {:>14.4f} {:>12.1f}  {}\n", r.backend, r.candidatePairs, r.overlappingPairs,
                 1e6 * (r.buildSeconds + r.findSeconds) / opt->count,
                 static_cast<double>(r.memoryBytes) / opt->count, r.description);
      agree = agree && r.pairs == reports.front().pairs;
    }
    fmt::print("\nall backends report the same {} pairs (skin {}): {}\n", reports.front().candidatePairs, skin,
               agree ? "yes" : "NO");
    return agree ? 0 : 1;
  };
}

}  // namespace polydem::app
