// polydem pairs: run one broad-phase backend on a particle file and report pairs and timing.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/common.hpp"
#include "apps/polydem/pair_report.hpp"
#include "apps/polydem/summary.hpp"
#include "apps/polydem/validators.hpp"
#include "broadphase/auto_select.hpp"
#include "broadphase/hgrid.hpp"
#include "broadphase/hgrid_cost_model.hpp"
#include "broadphase/registry.hpp"
#include "core/errors.hpp"
#include "core/io/particle_file.hpp"

namespace polydem::app {

namespace {
struct PairsOptions {
  std::string file;
  std::string backend = "auto";
  double skin = 0.0;
  int repeat = 5;
  std::string boundaries = "periodic";
  int levels = 0;
  std::vector<double> cellSizes;
  bool boundaryGiven = false;  ///< --boundary was on the command line (not only its default)
};

/// hgrid-td / hgrid-bu with hand-set levels: --cell-sizes as given, or --levels alone with the cost
/// model's optimal sizes for that L.
std::unique_ptr<broadphase::BroadPhase> makeBackend(const PairsOptions& opt, const SphereView& spheres,
                                                    const Box& box) {
  auto bp = broadphase::makeBroadPhase(opt.backend);
  if (opt.levels == 0 && opt.cellSizes.empty()) return bp;
  const bool topDown = opt.backend == "hgrid-td";
  if (!topDown && opt.backend != "hgrid-bu") {
    throw ConfigError(fmt::format("--levels and --cell-sizes apply to hgrid-td and hgrid-bu, not '{}'", opt.backend));
  }
  broadphase::HGridConfig config;
  config.mode = topDown ? broadphase::CrossLevel::TopDown : broadphase::CrossLevel::BottomUp;
  if (!opt.cellSizes.empty()) {
    if (opt.levels != 0 && opt.levels != static_cast<int>(opt.cellSizes.size())) {
      throw ConfigError(fmt::format("--levels {} but --cell-sizes lists {} sizes", opt.levels, opt.cellSizes.size()));
    }
    config.cellSizes = opt.cellSizes;
    config.origin = "set by hand (--cell-sizes)";
  } else {
    if (opt.levels < 1) throw ConfigError(fmt::format("--levels must be >= 1, got {}", opt.levels));
    std::vector<double> radii(spheres.radius.data(), spheres.radius.data() + spheres.count());
    const auto psd = broadphase::CostModelPsd::sample(radii, box.volume(), opt.skin);
    const double K = broadphase::modelCostRatio();
    config.cellSizes = broadphase::optimalCellSizes(psd, opt.levels, config.mode, K);
    // Collapsed sizes (equal, or out of order by a rounding error when the radii span no range, e.g. two
    // equal spheres) are empty levels: keep only sizes strictly above the previous one.
    std::vector<double> increasing;
    for (double size : config.cellSizes) {
      if (increasing.empty() || size > increasing.back()) increasing.push_back(size);
    }
    config.cellSizes = std::move(increasing);
    config.origin = fmt::format("--levels {}: optimal sizes of the cost model (K = {:.3g}), predicted T/N = {:.3g}",
                                opt.levels, K, broadphase::costPerParticle(psd, config.cellSizes, config.mode, K));
  }
  if (topDown) {
    auto grid = std::make_unique<broadphase::HGridTopDown>();
    grid->setConfig(config);
    return grid;
  }
  auto grid = std::make_unique<broadphase::HGridBottomUp>();
  grid->setConfig(config);
  return grid;
}

/// The particle file, its boundaries checked against an explicit --boundary.
io::ParticleData loadPairsInput(const PairsOptions& opt) {
  const std::array<Boundary, 3> boundaries = parseBoundaries(opt.boundaries);
  io::ParticleData data = io::readParticles(opt.file, boundaries);
  // --boundary is the default for text files without their own: never silently overridden by the file.
  const bool differ = data.box.boundary(0) != boundaries[0] || data.box.boundary(1) != boundaries[1] ||
                      data.box.boundary(2) != boundaries[2];
  if (opt.boundaryGiven && differ) {
    throw ConfigError(
        fmt::format("--boundary {} conflicts with the boundaries stored in {} ({}): drop --boundary "
                    "or edit the file",
                    opt.boundaries, opt.file, data.box.describe()));
  }
  return data;
}

/// `polydem pairs`: load the file, measure the backend on it, report.
int runPairs(const PairsOptions& opt) {
  if (opt.repeat < 1) throw ConfigError(fmt::format("--repeat must be >= 1, got {}", opt.repeat));
  const io::ParticleData data = loadPairsInput(opt);
  fmt::print("file: {} ({} particles, box {})\n", opt.file, data.count(), data.box.describe());
  const SphereView spheres{data.position, data.radius};
  auto backend = makeBackend(opt, spheres, data.box);
  const PairReport r = measurePairs(*backend, spheres, data.box, opt.skin, opt.repeat);
  printPairReport(r, data.count());
  SummaryJson& s = summary();
  s.put("input.file", opt.file);
  s.put("input.particles", static_cast<std::int64_t>(data.count()));
  s.put("input.box", data.box.describe());
  s.put("broad_phase.description", r.description);
  s.put("pairs.candidate", static_cast<std::int64_t>(r.candidatePairs));
  s.put("pairs.overlapping", static_cast<std::int64_t>(r.overlappingPairs));
  s.put("pairs.checksum", std::to_string(r.checksum));
  s.put("time.repeats", opt.repeat);
  s.put("time.build_seconds_median", r.buildSeconds);
  s.put("time.find_seconds_median", r.findSeconds);
  s.put("memory.bytes", static_cast<std::int64_t>(r.memoryBytes));
  return 0;
}
}  // namespace

Runner addPairs(CLI::App& app) {
  auto opt = std::make_shared<PairsOptions>();
  CLI::App* cmd = app.add_subcommand("pairs", "find candidate and overlapping pairs in a particle file");
  cmd->add_option("file", opt->file, "particle file (plain text or .h5)")->required();
  cmd->add_option("--broadphase", opt->backend,
                  "backend: brute, linked-cell, hgrid-td, hgrid-bu, delaunay, sap, cgal-box, auto")
      ->capture_default_str();
  cmd->add_option("--skin", opt->skin, "pairs count when the gap between surfaces is <= skin")
      ->check(finiteNonNegative())
      ->capture_default_str();
  cmd->add_option("--repeat", opt->repeat, "timed repetitions (the median is reported)")
      ->check(CLI::Range(1, 1000000))
      ->capture_default_str();
  cmd->add_option("--boundary", opt->boundaries,
                  "boundaries for text files without a '# boundaries:' line: periodic, walls, or per axis")
      ->check(boundaryNames())
      ->capture_default_str();
  cmd->add_option("--levels", opt->levels, "hgrid-td/-bu: number of levels (sizes from the cost model unless given)")
      ->check(CLI::Range(1, 64));
  cmd->add_option("--cell-sizes", opt->cellSizes, "hgrid-td/-bu: cell edges s_1 < ... < s_L, comma-separated")
      ->delimiter(',')
      ->check(finitePositive());
  return [opt, cmd]() {
    opt->boundaryGiven = cmd->count("--boundary") > 0;
    return runPairs(*opt);
  };
}

}  // namespace polydem::app
