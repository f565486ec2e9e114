// polydem example: the built-in demonstration scene. Generates a polydisperse packing, runs every
// broad phase on it, checks they agree, and prints the timings side by side.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <limits>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/common.hpp"
#include "apps/polydem/pair_report.hpp"
#include "apps/polydem/validators.hpp"
#include "broadphase/registry.hpp"
#include "core/errors.hpp"
#include "core/initial_configuration.hpp"
#include "core/types.hpp"

namespace polydem::app {

namespace {
struct ExampleOptions {
  Index count = 20000;
  double omega = 10.0;
  double packing = 0.3;
  int repeat = 3;
};

/// The example scene: uniform-volume spheres by random sequential addition (walls when too few spheres
/// for a periodic box of two cut-offs, as `polydem bench` does); prints what it made.
Configuration makeExampleScene(const ExampleOptions& opt, double skin) {
  DistributionSpec spec;
  spec.kind = "uniform-volume";
  spec.rmin = 1.0;
  spec.omega = opt.omega;
  const auto dist = makeDistribution(spec);
  Stopwatch clock;
  PackingRequest request;
  request.radii = dist->sample(opt.count, Sampling::Systematic, 1);
  request.packingFraction = opt.packing;
  request.boundaries = {Boundary::Periodic, Boundary::Periodic, Boundary::Periodic};
  request.seed = 1;
  // A handful of spheres (N = 1, 2) fills a box narrower than two cut-offs, which periodic broad phases
  // cannot image: use walls then.
  double volume = 0.0;
  for (double r : request.radii) volume += 4.0 / 3.0 * kPi * r * r * r;
  const double rmax = *std::max_element(request.radii.begin(), request.radii.end());
  if (std::cbrt(volume / opt.packing) < 2.0 * (2.0 * rmax + skin)) {
    request.boundaries = {Boundary::Wall, Boundary::Wall, Boundary::Wall};
  }
  Configuration config = randomSequentialAddition(request);
  fmt::print("example scene: {} spheres, {}, packing fraction {}, {}\n", opt.count, dist->describe(), opt.packing,
             config.box.describe());
  fmt::print("placed by random sequential addition in {:.3f} s\n\n", clock.seconds());
  return config;
}

/// Every backend (brute force only up to 50000 spheres) and auto, measured on the scene.
std::vector<PairReport> measureBackends(const ExampleOptions& opt, const Configuration& config, double skin) {
  const SphereView spheres{config.position, config.radius};
  std::vector<std::string> names = broadphase::backendNames();
  names.push_back("auto");
  std::vector<PairReport> reports;
  for (const std::string& name : names) {
    if (name == "brute" && opt.count > 50000) continue;  // O(N^2): minutes
    reports.push_back(measurePairs(name, spheres, config.box, skin, opt.repeat));
  }
  return reports;
}

/// The comparison table; true when every backend found the same pairs.
bool reportBackends(const ExampleOptions& opt, const std::vector<PairReport>& reports, double skin) {
  fmt::print("{:<14} {:>12} {:>12} {:>14} {:>12}  {}\n", "backend", "pairs", "overlaps", "us/particle", "bytes/part",
             "configuration");
  bool agree = true;
  for (const PairReport& r : reports) {
    fmt::print("{:<14} {:>12} {:>12} {:>14.4f} {:>12.1f}  {}\n", r.backend, r.candidatePairs, r.overlappingPairs,
               1e6 * (r.buildSeconds + r.findSeconds) / opt.count, static_cast<double>(r.memoryBytes) / opt.count,
               r.description);
    agree = agree && r.pairs == reports.front().pairs;
  }
  fmt::print("\nall backends report the same {} pairs (skin {}): {}\n", reports.front().candidatePairs, skin,
             agree ? "yes" : "NO");
  return agree;
}

/// `polydem example`: make the scene, measure every backend, report; exit 1 if the backends disagree.
int runExample(const ExampleOptions& opt) {
  const double skin = 0.1;  // 0.1 r_min
  const Configuration config = makeExampleScene(opt, skin);
  return reportBackends(opt, measureBackends(opt, config, skin), skin) ? 0 : 1;
}
}  // namespace

Runner addExample(CLI::App& app) {
  auto opt = std::make_shared<ExampleOptions>();
  CLI::App* cmd = app.add_subcommand(
      "example", "built-in example: uniform-volume spheres by random sequential addition, every broad phase compared");
  cmd->add_option("-n,--count", opt->count, "number of particles (>= 1)")
      ->check(CLI::Range(Index(1), std::numeric_limits<Index>::max()))
      ->capture_default_str();
  cmd->add_option("--omega", opt->omega, "size ratio (>= 1)")
      ->check(finiteIn(1.0, std::numeric_limits<double>::infinity()))
      ->capture_default_str();
  cmd->add_option("--phi", opt->packing, "packing fraction in (0, 1)")
      ->check(finiteOpen(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--repeat", opt->repeat, "timed repetitions per backend")
      ->check(CLI::Range(1, 1000000))
      ->capture_default_str();
  return [opt]() { return runExample(*opt); };
}

}  // namespace polydem::app
