// polydem generate: sample a size distribution, place the spheres, write a particle file.
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include <fmt/format.h>

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

  return [opt]() {
    finishDistributionSpec(opt->dist, opt->fractionKind);
    if (opt->count < 1) throw ConfigError(fmt::format("--count must be >= 1, got {}", opt->count));
    io::checkOutputPath(opt->output, "--output");
    if (io::isHdf5Path(opt->output)) io::checkOutputPath(io::xdmfPath(opt->output), "--output (its XDMF sidecar)");
    const auto dist = makeDistribution(opt->dist);
    Stopwatch clock;
    const Sampling sampling = opt->sampling == "random" ? Sampling::Random : Sampling::Systematic;
    std::string equivalentDescription;
    std::vector<double> radii = opt->equivalent == "none"
                                    ? dist->sample(opt->count, sampling, opt->seed)
                                    : equivalentRadii(*dist, opt->equivalent, opt->count, equivalentDescription);
    std::mt19937_64 rng(opt->seed ^ 0x9e3779b97f4a7c15ULL);
    std::shuffle(radii.begin(), radii.end(), rng);

    PackingRequest request;
    request.radii = radii;
    request.packingFraction = opt->packing;
    request.aspect = Eigen::Vector3d(opt->aspect[0], opt->aspect[1], opt->aspect[2]);
    request.boundaries = parseBoundaries(opt->boundaries);
    request.seed = opt->seed;
    const Configuration config =
        opt->placement == "rsa" ? randomSequentialAddition(request) : randomOverlapping(request);
    const double seconds = clock.seconds();

    io::ParticleData data;
    data.box = config.box;
    data.position = config.position;
    data.radius = config.radius;
    data.id.resize(static_cast<std::size_t>(opt->count));
    for (Index i = 0; i < opt->count; ++i) data.id[i] = i;
    data.attributes["distribution"] = dist->describe();
    data.attributes["sampling"] = opt->sampling;
    if (opt->equivalent != "none") data.attributes["equivalent_mixture"] = equivalentDescription;
    data.attributes["placement"] = opt->placement;
    data.attributes["seed"] = std::to_string(opt->seed);
    data.attributes["packing_fraction"] = fmt::format("{:.17g}", opt->packing);
    io::writeParticles(opt->output, data);

    const auto sample = sampleMoments(radii);
    fmt::print("generated {} particles: {}\n", opt->count, dist->describe());
    if (opt->equivalent != "none") fmt::print("radii: {}\n", equivalentDescription);
    fmt::print("box: {}  packing fraction {:.6f}  placement {} ({} sampling)\n", config.box.describe(), opt->packing,
               opt->placement, opt->sampling);
    if (opt->count > 0) {
      fmt::print("radii: min {:.6g}  max {:.6g}  realised size ratio {:.6g}\n", config.radius.minCoeff(),
                 config.radius.maxCoeff(), config.radius.maxCoeff() / config.radius.minCoeff());
      fmt::print("moments <r^k>   k:   analytic        sample\n");
      for (int k = 1; k <= 5; ++k) {
        fmt::print("               {}:  {:13.6g}  {:13.6g}\n", k, dist->moment(k), sample[k] / sample[0]);
      }
    }
    fmt::print("wrote {} in {:.3f} s\n", opt->output, seconds);
    return 0;
  };
}

}  // namespace polydem::app
