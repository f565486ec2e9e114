// polydem jam: Lubachevsky-Stillinger compression of hard spheres to jamming (or to a target packing
// fraction) with the event-driven engine of edmd/, then the contact network and rattlers of the result.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/common.hpp"
#include "apps/polydem/equivalent_option.hpp"
#include "core/errors.hpp"
#include "core/initial_configuration.hpp"
#include "core/io/particle_file.hpp"
#include "edmd/compression.hpp"
#include "edmd/contact_network.hpp"
#include "edmd/hard_sphere_system.hpp"

namespace polydem::app {

namespace {

struct JamOptions {
  DistributionSpec dist;
  std::string fractionKind = "volume";
  Index count = 1000;
  double initialPhi = 0.3;
  std::string boundaries = "periodic";
  std::string sampling = "systematic";
  std::uint64_t seed = 1;
  std::string input;
  double reopen = 0.0;
  std::string schedule = edmd::formatSchedule(edmd::CompressionOptions{}.schedule);
  double targetPressure = 1e12;
  double targetPhi = 0.0;
  double maxCollisions = 1e7;
  double block = 0.0;
  std::string broadPhase = "hgrid-td";
  double neighbourhoodScale = 1.4;
  double skinCap = 4.0;
  double contactGap = 0.0;
  double runCollisions = 0.0;
  std::string output;
  bool writeVelocities = false;
  double progressSeconds = 2.0;
  std::string equivalent = "none";
  std::string eosCsv;
};

std::string fmtPressure(double p) { return std::isfinite(p) ? fmt::format("{:.4g}", p) : std::string("-"); }

}  // namespace

Runner addJam(CLI::App& app) {
  auto opt = std::make_shared<JamOptions>();
  CLI::App* cmd = app.add_subcommand(
      "jam", "Lubachevsky-Stillinger compression of hard spheres to jamming (event-driven), with contact statistics");
  addDistributionOptions(*cmd, opt->dist, opt->fractionKind);
  cmd->add_option("-n,--count", opt->count, "number of particles (random sequential addition start)")
      ->capture_default_str();
  cmd->add_option("--phi0", opt->initialPhi, "packing fraction of the random sequential addition start")
      ->capture_default_str();
  cmd->add_option("--boundary", opt->boundaries, "periodic, walls, or per axis e.g. periodic,periodic,wall")
      ->capture_default_str();
  cmd->add_option("--sampling", opt->sampling, "systematic or random radii")
      ->check(CLI::IsMember({"systematic", "random"}))
      ->capture_default_str();
  cmd->add_option("--seed", opt->seed, "random seed (radii, centres, velocities)")->capture_default_str();
  cmd->add_option("-i,--input", opt->input, "start from this particle file instead of random sequential addition");
  cmd->add_option("--reopen", opt->reopen,
                  "with --input, a jammed packing: shrink the radii so that the reduced pressure falls to about this "
                  "(free volume: factor (1 - 3/P)^(1/3)) and compress again with --schedule, e.g. a slower final stage")
      ->check(CLI::Range(10.0, 1e300));
  cmd->add_option("--schedule", opt->schedule,
                  "growth stages rate:until-pressure,...; rate = growth speed of the largest radius over the thermal "
                  "speed (the last stage has no end)")
      ->capture_default_str();
  cmd->add_option("--target-pressure", opt->targetPressure, "stop at this reduced pressure p = PV/(N kT)")
      ->capture_default_str();
  cmd->add_option("--target-phi", opt->targetPhi,
                  "stop at this packing fraction instead (an equilibrated or glassy state, e.g. a DEM start)");
  cmd->add_option("--max-collisions", opt->maxCollisions, "collision budget per particle")->capture_default_str();
  cmd->add_option("--block", opt->block,
                  "collisions per particle between thermostat/pressure readings (0 = 0.01/rate within [10, 1000])")
      ->capture_default_str();
  cmd->add_option("--broad-phase", opt->broadPhase, "broad phase for the neighbour lists (hgrid-td, hgrid-bu, ...)")
      ->capture_default_str();
  cmd->add_option("--neighbourhood-scale", opt->neighbourhoodScale,
                  "bounding neighbourhood radius / sphere radius (skin capped for large spheres)")
      ->capture_default_str();
  cmd->add_option("--skin-cap", opt->skinCap, "largest skin in units of the smallest radius x (scale - 1)")
      ->capture_default_str();
  cmd->add_option("--contact-gap", opt->contactGap,
                  "contact when gap <= this x (r_i + r_j); 0 = max(100/p, sqrt(1e-3/p)), at most 1e-3")
      ->capture_default_str();
  cmd->add_option("--run-collisions", opt->runCollisions,
                  "afterwards run this many collisions per particle at fixed density (pressure-leak test, timing)")
      ->capture_default_str();
  cmd->add_option("-o,--output", opt->output, "write the packing: .h5/.hdf5 for HDF5 (+ .xmf), else plain text");
  cmd->add_flag("--velocities", opt->writeVelocities, "store velocities in the output");
  cmd->add_option("--progress", opt->progressSeconds, "seconds between progress lines (0 = every block)")
      ->capture_default_str();
  addEquivalentOption(*cmd, opt->equivalent);
  cmd->add_option("--eos-csv", opt->eosCsv,
                  "write one line per block: phi, reduced pressure Z, growth rate, collisions per particle, time");

  return [opt]() {
    finishDistributionSpec(opt->dist, opt->fractionKind);
    edmd::CompressionOptions copt;
    copt.schedule = edmd::parseSchedule(opt->schedule);
    copt.targetPressure = opt->targetPressure;
    copt.targetPackingFraction = opt->targetPhi;
    copt.maxCollisionsPerParticle = opt->maxCollisions;
    copt.blockCollisionsPerParticle = opt->block;
    if (opt->reopen > 0.0 && opt->input.empty()) throw ConfigError("--reopen needs --input (a jammed packing)");
    if (!opt->input.empty() && opt->equivalent != "none") {
      throw ConfigError("--equivalent applies to the random start (--dist); it cannot be combined with --input");
    }

    io::ParticleData start;
    std::string origin;
    if (!opt->input.empty()) {
      start = io::readParticles(opt->input);
      origin = opt->input;
      if (opt->reopen > 0.0) {
        // Near jamming p ~ 3 / (1 - phi / phi_J) (seed 001 eq. 9.1): at phi_J (the input) x (1 - 3/P) the
        // pressure is about P. The input must be jammed well beyond P for that to hold.
        const auto it = start.attributes.find("reduced_pressure");
        if (it != start.attributes.end() && !(std::stod(it->second) > 10.0 * opt->reopen)) {
          throw ConfigError(fmt::format("--reopen {}: the input {} has reduced pressure {}, not well above it",
                                        opt->reopen, opt->input, it->second));
        }
        const double factor = std::cbrt(1.0 - 3.0 / opt->reopen);
        start.radius *= factor;
        origin += fmt::format(", radii x {:.12g} (reopened to p ~ {:g})", factor, opt->reopen);
      }
    } else {
      if (opt->count <= 0) throw ConfigError(fmt::format("--count must be > 0, got {}", opt->count));
      const auto dist = makeDistribution(opt->dist);
      const Sampling sampling = opt->sampling == "random" ? Sampling::Random : Sampling::Systematic;
      std::string equivalentDescription;
      std::vector<double> radii = opt->equivalent == "none"
                                      ? dist->sample(opt->count, sampling, opt->seed)
                                      : equivalentRadii(*dist, opt->equivalent, opt->count, equivalentDescription);
      std::mt19937_64 rng(opt->seed ^ 0x9e3779b97f4a7c15ULL);
      std::shuffle(radii.begin(), radii.end(), rng);
      PackingRequest request;
      request.radii = radii;
      request.packingFraction = opt->initialPhi;
      request.boundaries = parseBoundaries(opt->boundaries);
      request.seed = opt->seed;
      Stopwatch rsaClock;
      const Configuration config = randomSequentialAddition(request);
      start.box = config.box;
      start.position = config.position;
      start.radius = config.radius;
      start.id.resize(static_cast<std::size_t>(opt->count));
      for (Index i = 0; i < opt->count; ++i) start.id[static_cast<std::size_t>(i)] = i;
      start.attributes["distribution"] = dist->describe();
      if (opt->equivalent != "none") start.attributes["equivalent_mixture"] = equivalentDescription;
      origin = fmt::format("random sequential addition of {} spheres ({}) at phi {} in {:.2f} s", opt->count,
                           opt->equivalent == "none" ? dist->describe() : equivalentDescription, opt->initialPhi,
                           rsaClock.seconds());
    }
    const Index n = start.count();
    edmd::SystemOptions sopt;
    sopt.broadPhase = opt->broadPhase;
    sopt.neighbourhoodScale = opt->neighbourhoodScale;
    sopt.skinCap = opt->skinCap;
    edmd::HardSphereSystem system(start.box, start.position, start.radius,
                                  edmd::maxwellBoltzmannVelocities(start.radius, opt->seed),
                                  sopt);
    fmt::print("start: {}\n", origin);
    fmt::print("box {}, {} spheres, size ratio {:.4g}, phi {:.6f}; neighbour lists: {} ({:.1f} per sphere)\n",
               start.box.describe(), n, system.largestRadius() / system.smallestRadius(), system.packingFraction(),
               system.describeBroadPhase(), system.meanNeighbours());
    fmt::print("schedule {} -> {}\n", edmd::formatSchedule(copt.schedule),
               opt->targetPhi > 0 ? fmt::format("phi {}", opt->targetPhi) : fmt::format("p {:g}", opt->targetPressure));

    std::ofstream eosCsv;
    if (!opt->eosCsv.empty()) {
      eosCsv.open(opt->eosCsv);
      if (!eosCsv) throw ConfigError(fmt::format("--eos-csv: cannot write '{}'", opt->eosCsv));
      eosCsv << "# polydem jam EOS: one line per block; Z = reduced pressure PV/(N kT) of the block\n"
             << "phi,Z,rate,collisions_per_particle,time,wall_seconds\n";
    }
    Stopwatch clock;
    double lastPrint = -1e300;
    auto line = [&](const edmd::Progress& p) {
      fmt::print(
          "phi {:.6f}  p {:>10}  phiJ~ {:>8}  rate {:.0e}  coll/particle {:>9.0f}  events/s {:.3g}  "
          "coll/s {:.3g}  nb {:.1f} exits/coll {:.3f}  wall {:.1f} s\n",
          p.packingFraction, fmtPressure(p.pressure),
          // phi / (1 - 3/p) is undefined while p <= 3 (a dilute gas): a dash, not "nan".
          std::isfinite(p.jammingEstimate) ? fmt::format("{:.6f}", p.jammingEstimate) : std::string("-"), p.rate, p.collisionsPerParticle,
          p.eventsPerSecond, p.collisionsPerSecond, p.meanNeighbours, p.exitsPerCollision, p.wallSeconds);
      std::fflush(stdout);
    };
    edmd::Progress lastShown;
    const edmd::CompressionResult result = edmd::compress(system, copt, [&](const edmd::Progress& p) {
      if (eosCsv.is_open()) {
        eosCsv << fmt::format("{:.17g},{:.8g},{:.3g},{:.2f},{:.8g},{:.2f}\n", p.packingFraction, p.pressure, p.rate,
                              p.collisionsPerParticle, p.time, p.wallSeconds);
      }
      if (p.wallSeconds - lastPrint >= opt->progressSeconds) {
        line(p);
        lastPrint = p.wallSeconds;
        lastShown = p;
      }
    });
    if (lastShown.blocks != result.last.blocks) line(result.last);
    const double compressSeconds = clock.seconds();

    double pressure = result.last.pressure;
    edmd::EquilibriumRun eq;
    if (opt->runCollisions > 0.0) {
      eq = edmd::runAtFixedDensity(system, opt->runCollisions);
      fmt::print(
          "fixed density: {} collisions per particle, p {} (compression ended at {}), {:.3g} collisions/s, "
          "{:.3g} events/s, {:.2f} s; {:.1f} neighbours per sphere, {:.3f} exits per collision\n",
          opt->runCollisions, fmtPressure(eq.pressure), fmtPressure(pressure), eq.collisionsPerSecond,
          eq.eventsPerSecond, eq.wallSeconds, system.meanNeighbours(),
          static_cast<double>(eq.counts.exits) / static_cast<double>(std::max<std::int64_t>(1, eq.counts.collisions)));
      pressure = eq.pressure;
    }

    const Eigen::Matrix3Xd x = system.positions();
    const Eigen::VectorXd r = system.radii();
    edmd::ContactOptions contactOptions;
    contactOptions.relativeGap = opt->contactGap > 0.0 ? opt->contactGap : edmd::defaultContactGap(pressure);
    contactOptions.broadPhase = opt->broadPhase;
    const edmd::ContactNetwork net = edmd::analyseContacts(SphereView{x, r}, system.box(), contactOptions);
    const double phi = system.packingFraction();
    const double phiJ = edmd::jammingDensityEstimate(phi, pressure);
    const edmd::EventCounts& c = result.counts;

    fmt::print("\nstopped on {} after {} blocks\n", result.stopReason, result.last.blocks);
    fmt::print("packing fraction        {:.8f}\n", phi);
    fmt::print("reduced pressure        {}\n", fmtPressure(pressure));
    fmt::print("phi_J estimate          {:.8f}  (phi / (1 - 3/p))\n", phiJ);
    fmt::print("collisions              {} ({:.0f} per particle), {} events; {} exits, {} rebuilds\n", c.collisions,
               static_cast<double>(c.collisions) / n, c.events(), c.exits, c.rebuilds);
    fmt::print("wall time               {:.2f} s ({:.3g} collisions/s, {:.3g} events/s)\n", compressSeconds,
               c.collisions / std::max(compressSeconds, 1e-9), c.events() / std::max(compressSeconds, 1e-9));
    fmt::print("contacts (gap <= {:.1e}) {}  z = {:.4f}\n", contactOptions.relativeGap, net.contacts.size(),
               net.meanCoordination());
    fmt::print("rattlers (< {} contacts)  {} ({:.2f}%)\n", contactOptions.minContacts, n - net.backbone,
               100.0 * net.rattlerFraction());
    fmt::print("backbone                {} spheres, {} contacts, z = {:.4f}, contacts - (3N' {:+d}) = {}\n",
               net.backbone, net.backboneContacts, net.backboneCoordination(), 1 - net.periodicAxes,
               net.isostaticExcess());
    fmt::print("largest overlap         {:.3g} (relative; at collisions {:.3g})\n", net.maxOverlap,
               system.maxOverlapSeen());
    if (net.isostaticExcess() < 0 && pressure >= 1e9) {
      // A hypostatic backbone at high pressure: floppy modes left by too fast a late stage (seed 001
      // :11228-11244; docs/edmd.md, pressure-leak test against the final growth rate).
      fmt::print(
          "note: the backbone is hypostatic: the late stages ran too fast for it to find its contacts; in our runs "
          "packings passed `polydem analyze --leak-test` when four decades of pressure beyond p ~ 1e4 ran at 3e-5 or slower, and "
          "`polydem jam -i {} --reopen 1e8 --schedule 3e-5` compresses this one again that way\n",
          opt->output.empty() ? std::string("PACKING") : opt->output);
    }

    if (!opt->output.empty()) {
      io::ParticleData out;
      out.box = system.box();
      out.position = x;
      out.radius = r;
      if (opt->writeVelocities) out.velocity = system.velocities();
      out.id = start.id.size() == static_cast<std::size_t>(n) ? start.id : std::vector<Index>{};
      if (out.id.empty()) {
        out.id.resize(static_cast<std::size_t>(n));
        for (Index i = 0; i < n; ++i) out.id[static_cast<std::size_t>(i)] = i;
      }
      out.time = system.time();
      out.attributes = start.attributes;
      out.attributes["generator"] = "polydem jam";
      out.attributes["schedule"] = edmd::formatSchedule(copt.schedule);
      out.attributes["stop_reason"] = result.stopReason;
      out.attributes["packing_fraction"] = fmt::format("{:.17g}", phi);
      out.attributes["reduced_pressure"] = fmt::format("{:.17g}", pressure);
      out.attributes["phi_j_estimate"] = fmt::format("{:.17g}", phiJ);
      out.attributes["contacts"] = std::to_string(net.contacts.size());
      out.attributes["contact_gap"] = fmt::format("{:.3g}", contactOptions.relativeGap);
      out.attributes["z"] = fmt::format("{:.6f}", net.meanCoordination());
      out.attributes["z_backbone"] = fmt::format("{:.6f}", net.backboneCoordination());
      out.attributes["rattler_fraction"] = fmt::format("{:.6f}", net.rattlerFraction());
      out.attributes["collisions"] = std::to_string(c.collisions);
      io::writeParticles(opt->output, out);
      fmt::print("wrote {}\n", opt->output);
    }
    return 0;
  };
}

}  // namespace polydem::app
