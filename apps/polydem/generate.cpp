// polydem generate: sample a size distribution, place the spheres, write a particle file.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <limits>
#include <span>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/common.hpp"
#include "apps/polydem/equivalent_option.hpp"
#include "apps/polydem/validators.hpp"
#include "core/errors.hpp"
#include "core/initial_configuration.hpp"
#include "core/io/hdf5_snapshot.hpp"
#include "core/io/particle_file.hpp"
#include "core/io/safe_output.hpp"

namespace polydem::app {

namespace {
struct GenerateOptions {
  DistributionSpec dist;
  std::string fractionKind = "volume";
  Index count = 1000;
  double packing = 0.3;
  std::string boundaries = "periodic";
  std::vector<double> aspect = {1.0, 1.0, 1.0};
  std::string sampling = "systematic";
  std::string placement = "rsa";
  std::uint64_t seed = 1;
  std::string output;
  std::string equivalent = "none";
};

/// The spheres made by `generate` and what the report needs about them.
struct Generated {
  io::ParticleData data;
  std::string distribution;           ///< the distribution's describe()
  std::string equivalentDescription;  ///< the equivalent mixture's radii ("" without --equivalent)
  double seconds = 0.0;               ///< sampling and placement
};

/// Check the options and the output paths before any work.
void checkGenerateOptions(GenerateOptions& opt) {
  finishDistributionSpec(opt.dist, opt.fractionKind);
  if (opt.count < 1) throw ConfigError(fmt::format("--count must be >= 1, got {}", opt.count));
  io::checkOutputPath(opt.output, "--output");
  if (io::isHdf5Path(opt.output)) io::checkOutputPath(io::xdmfPath(opt.output), "--output (its XDMF sidecar)");
}

/// Sample the radii, place the spheres, attach the attributes the file records.
Generated computeGenerate(const GenerateOptions& opt, const SizeDistribution& dist) {
  Generated g;
  Stopwatch clock;
  StartPackingRequest request;
  request.count = opt.count;
  request.sampling = opt.sampling == "random" ? Sampling::Random : Sampling::Systematic;
  if (opt.equivalent != "none")
    request.radii = equivalentRadii(dist, opt.equivalent, opt.count, g.equivalentDescription);
  request.packingFraction = opt.packing;
  request.aspect = Eigen::Vector3d(opt.aspect[0], opt.aspect[1], opt.aspect[2]);
  request.boundaries = parseBoundaries(opt.boundaries);
  request.seed = opt.seed;
  request.placement = opt.placement == "rsa" ? Placement::RandomSequentialAddition : Placement::RandomOverlapping;
  StartPacking start = makeStartPacking(dist, request);
  g.seconds = clock.seconds();
  g.distribution = start.distribution;
  g.data.box = start.configuration.box;
  g.data.position = std::move(start.configuration.position);
  g.data.radius = std::move(start.configuration.radius);
  g.data.id = std::move(start.id);
  g.data.attributes["distribution"] = start.distribution;
  g.data.attributes["sampling"] = opt.sampling;
  if (opt.equivalent != "none") g.data.attributes["equivalent_mixture"] = g.equivalentDescription;
  g.data.attributes["placement"] = opt.placement;
  g.data.attributes["seed"] = std::to_string(opt.seed);
  g.data.attributes["packing_fraction"] = fmt::format("{:.17g}", opt.packing);
  return g;
}

/// The summary on stdout: box, realised size ratio, sample moments against the analytic ones.
void reportGenerate(const GenerateOptions& opt, const SizeDistribution& dist, const Generated& g) {
  const Eigen::VectorXd& radius = g.data.radius;
  const auto sample = sampleMoments(std::span<const double>(radius.data(), static_cast<std::size_t>(radius.size())));
  fmt::print("generated {} particles: {}\n", opt.count, g.distribution);
  if (opt.equivalent != "none") fmt::print("radii: {}\n", g.equivalentDescription);
  fmt::print("box: {}  packing fraction {:.6f}  placement {} ({} sampling)\n", g.data.box.describe(), opt.packing,
             opt.placement, opt.sampling);
  if (opt.count > 0) {
    fmt::print("radii: min {:.6g}  max {:.6g}  realised size ratio {:.6g}\n", radius.minCoeff(), radius.maxCoeff(),
               radius.maxCoeff() / radius.minCoeff());
    fmt::print("moments <r^k>   k:   analytic        sample\n");
    for (int k = 1; k <= 5; ++k) {
      fmt::print("               {}:  {:13.6g}  {:13.6g}\n", k, dist.moment(k), sample[k] / sample[0]);
    }
  }
}

/// `polydem generate`: check, compute, write the file, report.
int runGenerate(GenerateOptions& opt) {
  checkGenerateOptions(opt);
  const auto dist = makeDistribution(opt.dist);
  const Generated g = computeGenerate(opt, *dist);
  io::writeParticles(opt.output, g.data);
  reportGenerate(opt, *dist, g);
  fmt::print("wrote {} in {:.3f} s\n", opt.output, g.seconds);
  return 0;
}

}  // namespace

Runner addGenerate(CLI::App& app) {
  auto opt = std::make_shared<GenerateOptions>();
  CLI::App* cmd = app.add_subcommand("generate", "sample a size distribution, place N spheres, write a particle file");
  addDistributionOptions(*cmd, opt->dist, opt->fractionKind);
  cmd->add_option("-n,--count", opt->count, "number of particles (>= 1: the box is sized from their volume)")
      ->check(CLI::Range(Index(1), std::numeric_limits<Index>::max()))
      ->capture_default_str();
  cmd->add_option("--phi", opt->packing, "packing fraction (sets the box volume)")
      ->check(finiteOpen(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--boundary", opt->boundaries, "periodic, walls, or per axis e.g. periodic,periodic,wall")
      ->check(boundaryNames())
      ->capture_default_str();
  cmd->add_option("--aspect", opt->aspect, "box edge ratios x,y,z")
      ->delimiter(',')
      ->expected(3)
      ->check(finitePositive())
      ->capture_default_str();
  cmd->add_option("--sampling", opt->sampling, "systematic (evenly spaced quantiles) or random")
      ->check(CLI::IsMember({"systematic", "random"}))
      ->capture_default_str();
  cmd->add_option("--placement", opt->placement,
                  "rsa: random sequential addition, no overlaps; random: independent uniform centres, overlaps "
                  "allowed (cost-model checks)")
      ->check(CLI::IsMember({"rsa", "random"}))
      ->capture_default_str();
  cmd->add_option("--seed", opt->seed, "random seed (non-negative integer)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  addEquivalentOption(*cmd, opt->equivalent);
  cmd->add_option("-o,--output", opt->output, "output file: .h5/.hdf5 for HDF5 (+ .xmf sidecar), else plain text")
      ->required();

  return [opt]() { return runGenerate(*opt); };
}

}  // namespace polydem::app
