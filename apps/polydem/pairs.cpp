// polydem pairs: run one broad-phase backend on a particle file and report pairs and timing.
#include <fmt/format.h>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/common.hpp"
#include "apps/polydem/pair_report.hpp"
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
};
}  // namespace

Runner addPairs(CLI::App& app) {
  auto opt = std::make_shared<PairsOptions>();
  CLI::App* cmd = app.add_subcommand("pairs", "find candidate and overlapping pairs in a particle file");
  cmd->add_option("file", opt->file, "particle file (plain text or .h5)")->required();
  cmd->add_option("--broadphase", opt->backend,
                  "backend: brute, linked-cell, hgrid-td, hgrid-bu, delaunay, sap, cgal-box, auto")
      ->capture_default_str();
  cmd->add_option("--skin", opt->skin, "pairs count when the gap between surfaces is <= skin")->capture_default_str();
  cmd->add_option("--repeat", opt->repeat, "timed repetitions (the median is reported)")->capture_default_str();
  cmd->add_option("--boundary", opt->boundaries,
                  "boundaries for text files without a '# boundaries:' line: periodic, walls, or per axis")
      ->capture_default_str();
  return [opt]() {
    if (opt->repeat < 1) throw ConfigError(fmt::format("--repeat must be >= 1, got {}", opt->repeat));
    const io::ParticleData data = io::readParticles(opt->file, parseBoundaries(opt->boundaries));
    fmt::print("file: {} ({} particles, box {})\n", opt->file, data.count(), data.box.describe());
    const SphereView spheres{data.position, data.radius};
    const PairReport r = measurePairs(opt->backend, spheres, data.box, opt->skin, opt->repeat);
    printPairReport(r, data.count());
    return 0;
  };
}

}  // namespace polydem::app
