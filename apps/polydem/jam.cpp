// polydem jam: Lubachevsky-Stillinger compression of hard spheres to jamming (or to a target packing
// fraction) with the event-driven engine of edmd/, then the contact network and rattlers of the result.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/common.hpp"
#include "apps/polydem/equivalent_option.hpp"
#include "apps/polydem/exit_codes.hpp"
#include "apps/polydem/validators.hpp"
#include "core/errors.hpp"
#include "core/initial_configuration.hpp"
#include "core/interrupt.hpp"
#include "core/io/attributes.hpp"
#include "core/io/checkpoint.hpp"
#include "core/io/particle_file.hpp"
#include "core/io/safe_output.hpp"
#include "edmd/compression.hpp"
#include "jamming/contact_network.hpp"
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
  std::string checkpoint;
  double checkpointInterval = 600.0;
  std::string resume;
  std::int64_t stopAfterBlocks = 0;
};

// Options that do not touch the trajectory: the only ones --resume accepts (everything else comes from the
// checkpoint, so a resumed run is the run that was interrupted).
const std::set<std::string> kResumeOverrides = {"--resume", "--progress", "--checkpoint-interval",
                                                "--stop-after-blocks"};

/// A finite number in the open interval (0, 1).
CLI::Validator openUnitInterval() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        const auto value = io::parseFiniteDouble(text);
        if (!value) return fmt::format("'{}' is not a finite number", text);
        if (!(*value > 0.0 && *value < 1.0)) return fmt::format("{} is outside (0, 1)", text);
        return {};
      },
      "FINITE in (0, 1)");
}

// ---------------------------------------------------------------------------------------------------
// Checkpoint (io::Checkpoint of kind "jam"): the settings, the start record (ids, attributes), the
// compression state and the engine state (edmd::SystemState), each stored bit-exact.

constexpr std::int64_t kCheckpointFormat = 1;

std::vector<std::int64_t> countsVector(const edmd::EventCounts& c) {
  return {c.collisions, c.wallCollisions, c.checks, c.exits, c.rebuilds, c.relocatedLists, c.missed};
}

edmd::EventCounts countsFrom(const io::Checkpoint& c, const std::string& name) {
  const std::vector<std::int64_t>& v = c.integers(name);
  if (v.size() != 7)
    throw InputError(fmt::format("{}: checkpoint entry {}: expected 7 counts", c.source.string(), name));
  return {v[0], v[1], v[2], v[3], v[4], v[5], v[6]};
}

void putSettings(io::Checkpoint& c, const JamOptions& o) {
  c.text["schedule"] = o.schedule;
  c.text["broad_phase"] = o.broadPhase;
  c.text["output"] = o.output;
  c.text["eos_csv"] = o.eosCsv;
  c.text["checkpoint"] = o.checkpoint;
  c.text["input"] = o.input;
  c.putScalar("target_pressure", o.targetPressure);
  c.putScalar("target_phi", o.targetPhi);
  c.putScalar("max_collisions", o.maxCollisions);
  c.putScalar("block", o.block);
  c.putScalar("neighbourhood_scale", o.neighbourhoodScale);
  c.putScalar("skin_cap", o.skinCap);
  c.putScalar("contact_gap", o.contactGap);
  c.putScalar("run_collisions", o.runCollisions);
  c.putScalar("progress_seconds", o.progressSeconds);
  c.putScalar("checkpoint_interval", o.checkpointInterval);
  c.putInteger("write_velocities", o.writeVelocities ? 1 : 0);
}

void getSettings(const io::Checkpoint& c, JamOptions& o) {
  o.schedule = c.string("schedule");
  o.broadPhase = c.string("broad_phase");
  o.output = c.string("output");
  o.eosCsv = c.string("eos_csv");
  o.checkpoint = c.string("checkpoint");
  o.input = c.string("input");
  o.targetPressure = c.scalar("target_pressure");
  o.targetPhi = c.scalar("target_phi");
  o.maxCollisions = c.scalar("max_collisions");
  o.block = c.scalar("block");
  o.neighbourhoodScale = c.scalar("neighbourhood_scale");
  o.skinCap = c.scalar("skin_cap");
  o.contactGap = c.scalar("contact_gap");
  o.runCollisions = c.scalar("run_collisions");
  o.progressSeconds = c.scalar("progress_seconds");
  o.checkpointInterval = c.scalar("checkpoint_interval");
  o.writeVelocities = c.integerScalar("write_velocities") != 0;
}

void putEngine(io::Checkpoint& c, const edmd::SystemState& s) {
  c.real["engine.position"] = s.position;
  c.real["engine.velocity"] = s.velocity;
  c.real["engine.radius"] = s.radius;
  c.real["engine.mass"] = s.mass;
  c.integer["engine.external"] = s.external;
  c.real["engine.hood_centre"] = s.hoodCentre;
  c.real["engine.hood_radius"] = s.hoodRadius;
  c.real["engine.hood_skin"] = s.hoodSkin;
  c.integer["engine.hood_begin"] = s.hoodBegin;
  c.integer["engine.hood_size"] = s.hoodSize;
  c.integer["engine.hood_capacity"] = s.hoodCapacity;
  c.integer["engine.neighbours"] = s.neighbours;
  c.real["engine.scalars"] = {s.growth,          s.elapsed,           s.skinFloor,     s.sizeRatio,
                              s.kinetic,         s.maxOverlap,        s.window.virial, s.window.kineticIntegral,
                              s.window.duration, s.lastCollision.time};
  c.integer["engine.counters"] = {s.collisionsAtSort, s.collisionsAtRebuild, s.exitsAtRebuild,  s.pairsAtRebuild,
                                  s.pairWork,         s.window.collisions,   s.lastCollision.i, s.lastCollision.j};
  c.integer["engine.total"] = countsVector(s.total);
}

edmd::SystemState getEngine(const io::Checkpoint& c) {
  edmd::SystemState s;
  s.position = c.reals("engine.position");
  s.velocity = c.reals("engine.velocity");
  s.radius = c.reals("engine.radius");
  s.mass = c.reals("engine.mass");
  s.external = c.integers("engine.external");
  s.hoodCentre = c.reals("engine.hood_centre");
  s.hoodRadius = c.reals("engine.hood_radius");
  s.hoodSkin = c.reals("engine.hood_skin");
  s.hoodBegin = c.integers("engine.hood_begin");
  s.hoodSize = c.integers("engine.hood_size");
  s.hoodCapacity = c.integers("engine.hood_capacity");
  s.neighbours = c.integers("engine.neighbours");
  const std::vector<double>& r = c.reals("engine.scalars");
  const std::vector<std::int64_t>& k = c.integers("engine.counters");
  if (r.size() != 10 || k.size() != 8) {
    throw InputError(
        fmt::format("{}: checkpoint entries engine.scalars/engine.counters have the wrong length", c.source.string()));
  }
  s.growth = r[0];
  s.elapsed = r[1];
  s.skinFloor = r[2];
  s.sizeRatio = r[3];
  s.kinetic = r[4];
  s.maxOverlap = r[5];
  s.window.virial = r[6];
  s.window.kineticIntegral = r[7];
  s.window.duration = r[8];
  s.lastCollision.time = r[9];
  s.collisionsAtSort = k[0];
  s.collisionsAtRebuild = k[1];
  s.exitsAtRebuild = k[2];
  s.pairsAtRebuild = k[3];
  s.pairWork = k[4];
  s.window.collisions = k[5];
  s.lastCollision.i = static_cast<Index>(k[6]);
  s.lastCollision.j = static_cast<Index>(k[7]);
  s.total = countsFrom(c, "engine.total");
  return s;
}

std::string fmtPressure(double p) { return std::isfinite(p) ? fmt::format("{:.4g}", p) : std::string("-"); }

}  // namespace

Runner addJam(CLI::App& app) {
  auto opt = std::make_shared<JamOptions>();
  CLI::App* cmd = app.add_subcommand(
      "jam", "Lubachevsky-Stillinger compression of hard spheres to jamming (event-driven), with contact statistics");
  addDistributionOptions(*cmd, opt->dist, opt->fractionKind);
  cmd->add_option("-n,--count", opt->count, "number of particles (random sequential addition start; at least 2)")
      ->check(finiteIn(0.0, 1e9))
      ->capture_default_str();
  cmd->add_option("--phi0", opt->initialPhi, "packing fraction of the random sequential addition start, in (0, 1)")
      ->check(openUnitInterval())
      ->capture_default_str();
  cmd->add_option("--boundary", opt->boundaries,
                  "periodic, walls, or per axis e.g. periodic,periodic,wall; with --input it applies to a text file "
                  "without a '# boundaries:' line and must agree with the file's own boundaries otherwise")
      ->capture_default_str();
  cmd->add_option("--sampling", opt->sampling, "systematic or random radii")
      ->check(CLI::IsMember({"systematic", "random"}))
      ->capture_default_str();
  cmd->add_option("--seed", opt->seed, "random seed (radii, centres, velocities)")->capture_default_str();
  cmd->add_option("-i,--input", opt->input, "start from this particle file instead of random sequential addition");
  cmd->add_option("--reopen", opt->reopen,
                  "with --input, a jammed packing: shrink the radii so that the reduced pressure falls to about this "
                  "(free volume: factor (1 - 3/P)^(1/3)) and compress again with --schedule, e.g. a slower final stage")
      ->check(finiteIn(10.0, 1e300));
  cmd->add_option("--schedule", opt->schedule,
                  "growth stages rate:until-pressure,...; rate = growth speed of the largest radius over the thermal "
                  "speed, in [1e-9, 1] (the last stage has no end)")
      ->capture_default_str();
  cmd->add_option("--target-pressure", opt->targetPressure,
                  "stop at this reduced pressure p = PV/(N kT) (> 3, at most what double precision resolves; with "
                  "--target-phi: the pressure at which the run counts as jammed before its target)")
      ->check(finitePositive())
      ->capture_default_str();
  cmd->add_option("--target-phi", opt->targetPhi,
                  "stop at this packing fraction instead (an equilibrated or glassy state, e.g. a DEM start)")
      ->check(finiteIn(0.0, 1.0));
  cmd->add_option("--max-collisions", opt->maxCollisions, "collision budget per particle (exit 4 when it runs out)")
      ->check(finitePositive())
      ->capture_default_str();
  cmd->add_option("--block", opt->block,
                  "collisions per particle between thermostat/pressure readings (0 = 0.01/rate within [10, 1000]; "
                  "else 1 to 1e6)")
      ->check(finiteIn(0.0, 1e6))
      ->capture_default_str();
  cmd->add_option("--broad-phase", opt->broadPhase, "broad phase for the neighbour lists (hgrid-td, hgrid-bu, ...)")
      ->capture_default_str();
  cmd->add_option("--neighbourhood-scale", opt->neighbourhoodScale,
                  "bounding neighbourhood radius / sphere radius (skin capped for large spheres)")
      ->check(finiteIn(1.0, 100.0))
      ->capture_default_str();
  cmd->add_option("--skin-cap", opt->skinCap, "largest skin in units of the smallest radius x (scale - 1)")
      ->check(finitePositive())
      ->capture_default_str();
  cmd->add_option("--contact-gap", opt->contactGap,
                  "contact when gap <= this x (r_i + r_j); 0 = max(100/p, sqrt(1e-3/p)), at most 1e-3")
      ->check(finiteIn(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--run-collisions", opt->runCollisions,
                  "afterwards run this many collisions per particle at fixed density (pressure-leak test, timing)")
      ->check(finiteIn(0.0, 1e9))
      ->capture_default_str();
  cmd->add_option("-o,--output", opt->output, "write the packing: .h5/.hdf5 for HDF5 (+ .xmf), else plain text");
  cmd->add_flag("--velocities", opt->writeVelocities, "store velocities in the output");
  cmd->add_option("--progress", opt->progressSeconds, "seconds between progress lines (0 = every block)")
      ->check(finiteNonNegative())
      ->capture_default_str();
  addEquivalentOption(*cmd, opt->equivalent);
  cmd->add_option("--eos-csv", opt->eosCsv,
                  "write one line per block: phi, reduced pressure Z, growth rate, collisions per particle, time");
  cmd->add_option("--checkpoint", opt->checkpoint,
                  "write the complete state here (HDF5) every --checkpoint-interval seconds and on SIGINT/SIGTERM; "
                  "continue with `polydem jam --resume FILE`");
  cmd->add_option("--checkpoint-interval", opt->checkpointInterval, "wall-clock seconds between checkpoints")
      ->check(finitePositive())
      ->capture_default_str();
  cmd->add_option("--resume", opt->resume,
                  "continue the run of this checkpoint; it holds every setting, so only --progress, "
                  "--checkpoint-interval and --stop-after-blocks may be given with it");
  cmd->add_option("--stop-after-blocks", opt->stopAfterBlocks,
                  "(testing) after this many blocks in all, act as if interrupted: checkpoint, output, exit 130")
      ->check(finiteIn(1.0, 9e18));

  return [opt, cmd]() -> int {
    installInterruptHandlers();
    const bool resuming = !opt->resume.empty();
    io::Checkpoint saved;
    if (resuming) {
      for (const CLI::Option* o : cmd->get_options()) {
        if (o->count() > 0 && !kResumeOverrides.count(o->get_name())) {
          throw ConfigError(fmt::format(
              "{} cannot be combined with --resume: the checkpoint holds every setting of the run, so that the "
              "resumed run is the interrupted one (only --progress, --checkpoint-interval and --stop-after-blocks "
              "may be given)",
              o->get_name()));
        }
      }
      const JamOptions overrides = *opt;
      saved = io::readCheckpoint(opt->resume, "jam");
      if (saved.integerScalar("format") != kCheckpointFormat) {
        throw InputError(fmt::format("{}: jam checkpoint format {} (this polydem reads format {})", opt->resume,
                                     saved.integerScalar("format"), kCheckpointFormat));
      }
      getSettings(saved, *opt);
      opt->resume = overrides.resume;
      opt->checkpoint = opt->resume;  // a resumed run keeps checkpointing into the file it resumed from
      opt->stopAfterBlocks = overrides.stopAfterBlocks;
      if (cmd->count("--progress")) opt->progressSeconds = overrides.progressSeconds;
      if (cmd->count("--checkpoint-interval")) opt->checkpointInterval = overrides.checkpointInterval;
    } else {
      finishDistributionSpec(opt->dist, opt->fractionKind);
    }
    edmd::CompressionOptions copt;
    copt.schedule = edmd::parseSchedule(opt->schedule);
    copt.targetPressure = opt->targetPressure;
    copt.targetPackingFraction = opt->targetPhi;
    copt.maxCollisionsPerParticle = opt->maxCollisions;
    copt.blockCollisionsPerParticle = opt->block;
    if (!resuming) {
      if (opt->reopen > 0.0 && opt->input.empty()) throw ConfigError("--reopen needs --input (a jammed packing)");
      if (!opt->input.empty() && opt->equivalent != "none") {
        throw ConfigError("--equivalent applies to the random start (--dist); it cannot be combined with --input");
      }
      if (opt->block != 0.0 && opt->block < 1.0) {
        throw ConfigError(
            fmt::format("--block {}: must be 0 (automatic) or at least 1 collision per particle "
                        "(smaller blocks spend the run synchronising)",
                        opt->block));
      }
    }
    if (cmd->count("--checkpoint-interval") && opt->checkpoint.empty()) {
      throw ConfigError("--checkpoint-interval needs --checkpoint FILE");
    }

    // Every output is checked before any computation (hours of work must not end in "cannot write"),
    // against every input and against each other.
    std::vector<std::filesystem::path> inputs;
    if (!opt->input.empty()) inputs.emplace_back(opt->input);
    std::vector<std::filesystem::path> outputsSoFar;
    auto checkOutput = [&](const std::string& path, const char* what, bool mayBeResumeFile) {
      if (path.empty()) return;
      std::vector<std::filesystem::path> against = inputs;
      if (resuming && !mayBeResumeFile) against.emplace_back(opt->resume);
      io::checkOutputPath(path, what, against);
      for (const auto& other : outputsSoFar) {
        if (io::samePath(path, other)) {
          throw ConfigError(fmt::format("{} '{}': the same file as another output of this run", what, path));
        }
      }
      outputsSoFar.emplace_back(path);
    };
    checkOutput(opt->output, "-o/--output", false);
    checkOutput(opt->eosCsv, "--eos-csv", false);
    checkOutput(opt->checkpoint, "--checkpoint", true);

    io::ParticleData start;
    std::string origin;
    std::unique_ptr<edmd::HardSphereSystem> systemPtr;
    edmd::CompressionState cstate;
    edmd::SystemOptions sopt;
    sopt.broadPhase = opt->broadPhase;
    sopt.neighbourhoodScale = opt->neighbourhoodScale;
    sopt.skinCap = opt->skinCap;
    std::int64_t eosOffset = -1;
    if (resuming) {
      const std::vector<double>& lengths = saved.reals("box_lengths");
      const std::vector<std::int64_t>& bounds = saved.integers("box_boundaries");
      if (lengths.size() != 3 || bounds.size() != 3) {
        throw InputError(fmt::format("{}: checkpoint entries box_lengths/box_boundaries need 3 values", opt->resume));
      }
      std::array<Boundary, 3> b{};
      for (int k = 0; k < 3; ++k)
        b[static_cast<std::size_t>(k)] = bounds[static_cast<std::size_t>(k)] ? Boundary::Wall : Boundary::Periodic;
      start.box = Box(Eigen::Vector3d(lengths[0], lengths[1], lengths[2]), b);
      const std::vector<std::int64_t>& ids = saved.integers("ids");
      start.id.assign(ids.begin(), ids.end());
      for (const auto& [key, value] : saved.text) {
        if (key.rfind("attribute.", 0) == 0) start.attributes[key.substr(10)] = value;
      }
      origin = fmt::format("resumed from {} ({})", opt->resume, saved.string("origin"));
      const edmd::SystemState engine = getEngine(saved);
      const Index n = static_cast<Index>(engine.radius.size());
      if (static_cast<Index>(start.id.size()) != n) {
        throw InputError(fmt::format("{}: checkpoint has {} ids for {} particles", opt->resume, start.id.size(), n));
      }
      const std::size_t un = static_cast<std::size_t>(n);
      if (n < 2 || engine.position.size() != 3 * un || engine.velocity.size() != 3 * un ||
          engine.external.size() != un) {
        throw InputError(fmt::format("{}: checkpoint engine arrays disagree in size ({} radii)", opt->resume, n));
      }
      // Construct in the caller's numbering (the constructor checks the state), then restore the engine's own.
      Eigen::Matrix3Xd x = Eigen::Matrix3Xd::Zero(3, n), v = Eigen::Matrix3Xd::Zero(3, n);
      Eigen::VectorXd r = Eigen::VectorXd::Ones(n);
      for (Index i = 0; i < n; ++i) {
        const Index e = static_cast<Index>(engine.external[static_cast<std::size_t>(i)]);
        if (e < 0 || e >= n) throw InputError(fmt::format("{}: checkpoint numbering out of range", opt->resume));
        for (int k = 0; k < 3; ++k) {
          x(k, e) = engine.position[3 * static_cast<std::size_t>(i) + static_cast<std::size_t>(k)];
          v(k, e) = engine.velocity[3 * static_cast<std::size_t>(i) + static_cast<std::size_t>(k)];
        }
        r[e] = engine.radius[static_cast<std::size_t>(i)];
      }
      systemPtr = std::make_unique<edmd::HardSphereSystem>(start.box, x, r, v, sopt);
      systemPtr->restoreState(engine);
      cstate.begun = true;
      cstate.stage = saved.integerScalar("stage");
      cstate.blocks = saved.integerScalar("blocks");
      cstate.initial = countsFrom(saved, "initial_counts");
      const std::vector<double>& plateau = saved.reals("plateau");
      if (plateau.size() != 3)
        throw InputError(fmt::format("{}: checkpoint entry plateau needs 3 values", opt->resume));
      cstate.pressureLimit = plateau[0];
      cstate.windowMax = plateau[1];
      cstate.previousWindowMax = plateau[2];
      const std::vector<std::int64_t>& window = saved.integers("plateau_blocks");
      if (window.size() != 2)
        throw InputError(fmt::format("{}: checkpoint entry plateau_blocks needs 2 values", opt->resume));
      cstate.windowBlocks = window[0];
      cstate.windowStart = window[1];
      eosOffset = saved.integerScalar("eos_offset");
    } else if (!opt->input.empty()) {
      // --boundary with --input: it fills in what a text file leaves open and must agree with what a file
      // states (an HDF5 snapshot always does, a text file with a '# boundaries:' line).
      const bool boundaryGiven = cmd->count("--boundary") > 0;
      const std::array<Boundary, 3> requested = parseBoundaries(opt->boundaries);
      start = io::readParticles(opt->input, boundaryGiven ? requested : io::kAllPeriodic);
      if (boundaryGiven) {
        for (int k = 0; k < 3; ++k) {
          if (start.box.boundary(k) != requested[static_cast<std::size_t>(k)]) {
            throw ConfigError(fmt::format(
                "--boundary {} conflicts with the boundaries of {} ({}): the file states its own; omit --boundary "
                "(or write the file without them to choose)",
                opt->boundaries, opt->input, start.box.describe()));
          }
        }
      }
      origin = opt->input;
      if (opt->reopen > 0.0) {
        // Near jamming p ~ 3 / (1 - phi / phi_J) (seed 001 eq. 9.1): at phi_J (the input) x (1 - 3/P) the
        // pressure is about P. The input must be jammed well beyond P for that to hold.
        const std::optional<double> p = io::numericAttribute(start, "reduced_pressure", opt->input);
        if (p && !(*p > 10.0 * opt->reopen)) {
          throw ConfigError(fmt::format("--reopen {}: the input {} has reduced pressure {:g}, not well above it",
                                        opt->reopen, opt->input, *p));
        }
        const double factor = std::cbrt(1.0 - 3.0 / opt->reopen);
        start.radius *= factor;
        origin += fmt::format(", radii x {:.12g} (reopened to p ~ {:g})", factor, opt->reopen);
      }
    } else {
      if (opt->count < 2) {
        throw ConfigError(
            fmt::format("--count {}: a compression needs at least 2 spheres (a lone sphere has no "
                        "binary collisions, so neither a pressure nor a collision budget ends its run)",
                        opt->count));
      }
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
      origin = fmt::format("random sequential addition of {} spheres ({}) at phi {}", opt->count,
                           opt->equivalent == "none" ? dist->describe() : equivalentDescription, opt->initialPhi);
      fmt::print("random sequential addition: {:.2f} s\n", rsaClock.seconds());
    }
    if (!resuming) {
      const Index count = start.count();
      if (count < 2) {
        throw ConfigError(
            fmt::format("{}: {} sphere{}; a compression needs at least 2 (a lone sphere has no binary "
                        "collisions, so neither a pressure nor a collision budget ends its run)",
                        opt->input, count, count == 1 ? "" : "s"));
      }
      if (start.id.size() != static_cast<std::size_t>(count)) {
        start.id.resize(static_cast<std::size_t>(count));
        for (Index i = 0; i < count; ++i) start.id[static_cast<std::size_t>(i)] = i;
      }
      systemPtr = std::make_unique<edmd::HardSphereSystem>(
          start.box, start.position, start.radius, edmd::maxwellBoltzmannVelocities(start.radius, opt->seed), sopt);
      // Unreachable targets are refused here, before the run (the same checks compress() makes).
      edmd::validateCompression(*systemPtr, copt);
    }
    edmd::HardSphereSystem& system = *systemPtr;
    const Index n = system.count();
    fmt::print("start: {}\n", origin);
    fmt::print("box {}, {} spheres, size ratio {:.4g}, phi {:.6f}; neighbour lists: {} ({:.1f} per sphere)\n",
               start.box.describe(), n, system.largestRadius() / system.smallestRadius(), system.packingFraction(),
               system.describeBroadPhase(), system.meanNeighbours());
    fmt::print("schedule {} -> {}; pressures up to {:.2g} resolvable\n", edmd::formatSchedule(copt.schedule),
               opt->targetPhi > 0 ? fmt::format("phi {}", opt->targetPhi) : fmt::format("p {:g}", opt->targetPressure),
               edmd::maxResolvablePressure(system));

    std::ofstream eosCsv;
    if (!opt->eosCsv.empty()) {
      if (resuming) {
        // Rows after the checkpoint belong to the lost part of the run: cut them, then go on appending.
        std::error_code ec;
        const auto size = std::filesystem::file_size(opt->eosCsv, ec);
        if (ec || static_cast<std::int64_t>(size) < eosOffset) {
          throw InputError(
              fmt::format("--eos-csv '{}' (from the checkpoint): missing or shorter than the {} bytes it "
                          "had at the checkpoint",
                          opt->eosCsv, eosOffset));
        }
        std::filesystem::resize_file(opt->eosCsv, static_cast<std::uintmax_t>(eosOffset));
        eosCsv.open(opt->eosCsv, std::ios::app);
      } else {
        eosCsv.open(opt->eosCsv);
      }
      if (!eosCsv) throw ConfigError(fmt::format("--eos-csv: cannot write '{}'", opt->eosCsv));
      if (!resuming) {
        eosCsv << "# polydem jam EOS: one line per block; Z = reduced pressure PV/(N kT) of the block\n"
               << "phi,Z,rate,collisions_per_particle,time,wall_seconds\n";
      }
    }
    io::PeriodicFlush flushEos;

    auto writeCheckpointNow = [&](edmd::HardSphereSystem& sys, const edmd::CompressionState& cs) {
      io::Checkpoint c;
      c.kind = "jam";
      c.putInteger("format", kCheckpointFormat);
      putSettings(c, *opt);
      c.text["origin"] = resuming ? saved.string("origin") : origin;
      for (const auto& [key, value] : start.attributes) c.text["attribute." + key] = value;
      c.real["box_lengths"] = {start.box.length(0), start.box.length(1), start.box.length(2)};
      c.integer["box_boundaries"] = {start.box.periodic(0) ? 0 : 1, start.box.periodic(1) ? 0 : 1,
                                     start.box.periodic(2) ? 0 : 1};
      c.integer["ids"] = std::vector<std::int64_t>(start.id.begin(), start.id.end());
      c.putInteger("stage", cs.stage);
      c.putInteger("blocks", cs.blocks);
      c.integer["initial_counts"] = countsVector(cs.initial);
      c.real["plateau"] = {cs.pressureLimit, cs.windowMax, cs.previousWindowMax};
      c.integer["plateau_blocks"] = {cs.windowBlocks, cs.windowStart};
      std::int64_t offset = 0;
      if (eosCsv.is_open()) {
        eosCsv.flush();
        offset = static_cast<std::int64_t>(eosCsv.tellp());
      }
      c.putInteger("eos_offset", offset);
      putEngine(c, sys.saveState());
      io::writeCheckpoint(opt->checkpoint, c);
    };

    Stopwatch clock;
    double lastPrint = -1e300;
    auto line = [&](const edmd::Progress& p) {
      fmt::print(
          "phi {:.6f}  p {:>10}  phiJ~ {:>8}  rate {:.0e}  coll/particle {:>9.0f}  events/s {:.3g}  "
          "coll/s {:.3g}  nb {:.1f} exits/coll {:.3f}  wall {:.1f} s\n",
          p.packingFraction, fmtPressure(p.pressure),
          // phi / (1 - 3/p) is undefined while p <= 3 (a dilute gas): a dash, not "nan".
          std::isfinite(p.jammingEstimate) ? fmt::format("{:.6f}", p.jammingEstimate) : std::string("-"), p.rate,
          p.collisionsPerParticle, p.eventsPerSecond, p.collisionsPerSecond, p.meanNeighbours, p.exitsPerCollision,
          p.wallSeconds);
      std::fflush(stdout);
    };
    edmd::Progress lastShown;
    Stopwatch sinceCheckpoint;
    bool stoppedForTest = false;
    // Wall-clock things (progress lines, checkpoint times) only read the system: the trajectory is the same
    // whether or when they happen (saveState() synchronises, which at a block boundary changes nothing).
    const edmd::BoundaryHook atBoundary = [&](edmd::HardSphereSystem& sys, const edmd::CompressionState& cs) {
      const bool testStop = opt->stopAfterBlocks > 0 && cs.blocks >= opt->stopAfterBlocks;
      const bool stop = interruptRequested() || testStop;
      if (!opt->checkpoint.empty() && (stop || sinceCheckpoint.seconds() >= opt->checkpointInterval)) {
        writeCheckpointNow(sys, cs);
        sinceCheckpoint = Stopwatch();
        if (stop) fmt::print("wrote checkpoint {} at block {}\n", opt->checkpoint, cs.blocks);
      }
      stoppedForTest = testStop && !interruptRequested();
      return stop;
    };
    const edmd::CompressionResult result = edmd::compress(
        system, copt,
        [&](const edmd::Progress& p) {
          if (eosCsv.is_open()) {
            eosCsv << fmt::format("{:.17g},{:.8g},{:.3g},{:.2f},{:.8g},{:.2f}\n", p.packingFraction, p.pressure, p.rate,
                                  p.collisionsPerParticle, p.time, p.wallSeconds);
            flushEos(eosCsv);
          }
          if (p.wallSeconds - lastPrint >= opt->progressSeconds) {
            line(p);
            lastPrint = p.wallSeconds;
            lastShown = p;
          }
        },
        atBoundary, &cstate);
    if (lastShown.blocks != result.last.blocks) line(result.last);
    const double compressSeconds = clock.seconds();
    bool interrupted = result.stopReason == "interrupted";
    std::string stopReason = result.stopReason;

    double pressure = result.last.pressure;
    edmd::EquilibriumRun eq;
    if (opt->runCollisions > 0.0 && !interrupted) {
      eq = edmd::runAtFixedDensity(system, opt->runCollisions, 100.0, [] { return interruptRequested(); });
      if (interruptRequested()) {
        interrupted = true;
        stopReason = "interrupted (during --run-collisions)";
      }
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
    jamming::ContactOptions contactOptions;
    contactOptions.relativeGap = opt->contactGap > 0.0 ? opt->contactGap : jamming::defaultContactGap(pressure);
    contactOptions.broadPhase = opt->broadPhase;
    const jamming::ContactNetwork net = jamming::analyseContacts(SphereView{x, r}, system.box(), contactOptions);
    const double phi = system.packingFraction();
    const double phiJ = edmd::jammingDensityEstimate(phi, pressure);
    const edmd::EventCounts& c = result.counts;
    const std::string phiJText = std::isfinite(phiJ) ? fmt::format("{:.8f}", phiJ) : std::string("undefined (p <= 3)");

    const bool targetReached = result.targetReached && !interrupted;
    fmt::print("\nstopped on {} after {} blocks\n", stopReason, result.last.blocks);
    fmt::print("target reached          {}\n", targetReached ? "yes" : fmt::format("no ({})", stopReason));
    fmt::print("packing fraction        {:.8f}\n", phi);
    fmt::print("reduced pressure        {}\n", fmtPressure(pressure));
    fmt::print("phi_J estimate          {}  (phi / (1 - 3/p))\n", phiJText);
    fmt::print("collisions              {} ({:.0f} per particle), {} events; {} exits, {} rebuilds\n", c.collisions,
               static_cast<double>(c.collisions) / n, c.events(), c.exits, c.rebuilds);
    fmt::print("wall time               {:.2f} s ({:.3g} collisions/s, {:.3g} events/s)\n", compressSeconds,
               c.collisions / std::max(compressSeconds, 1e-9), c.events() / std::max(compressSeconds, 1e-9));
    fmt::print("contacts (gap <= {:.1e}) {}  z = {:.4f}\n", contactOptions.relativeGap, net.contacts.size(),
               net.meanCoordination());
    fmt::print("rattlers (< {} contacts)  {} ({:.2f}%)\n", contactOptions.minContacts, n - net.backbone,
               100.0 * net.rattlerFraction());
    if (net.backbone > 0) {
      fmt::print("backbone                {} spheres, {} contacts, z = {:.4f}, contacts - (3N' {:+d}) = {}\n",
                 net.backbone, net.backboneContacts, net.backboneCoordination(), 1 - net.periodicAxes,
                 net.isostaticExcess());
    } else {
      fmt::print("backbone                none (every sphere a rattler): z and isostaticity undefined\n");
    }
    fmt::print("largest overlap         {:.3g} (relative; at collisions {:.3g})\n", net.maxOverlap,
               system.maxOverlapSeen());
    if (net.backbone > 0 && net.isostaticExcess() < 0 && pressure >= 1e9) {
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
      out.id = start.id;
      out.time = system.time();
      out.attributes = start.attributes;
      out.attributes["generator"] = "polydem jam";
      out.attributes["schedule"] = edmd::formatSchedule(copt.schedule);
      out.attributes["target"] = opt->targetPhi > 0 ? fmt::format("phi {:.17g}", opt->targetPhi)
                                                    : fmt::format("p {:.17g}", opt->targetPressure);
      out.attributes["target_reached"] = targetReached ? "yes" : "no";
      out.attributes["stop_reason"] = stopReason;
      out.attributes["packing_fraction"] = fmt::format("{:.17g}", phi);
      out.attributes["reduced_pressure"] = fmt::format("{:.17g}", pressure);
      if (std::isfinite(phiJ)) out.attributes["phi_j_estimate"] = fmt::format("{:.17g}", phiJ);
      out.attributes["contacts"] = std::to_string(net.contacts.size());
      out.attributes["contact_gap"] = fmt::format("{:.3g}", contactOptions.relativeGap);
      out.attributes["z"] = fmt::format("{:.6f}", net.meanCoordination());
      if (net.backbone > 0) out.attributes["z_backbone"] = fmt::format("{:.6f}", net.backboneCoordination());
      out.attributes["rattler_fraction"] = fmt::format("{:.6f}", net.rattlerFraction());
      out.attributes["collisions"] = std::to_string(c.collisions);
      io::writeParticles(opt->output, out);
      fmt::print("wrote {}\n", opt->output);
    }
    if (eosCsv.is_open()) eosCsv.flush();
    if (interrupted) {
      const int sig = interruptSignal();
      fmt::print(
          "interrupted ({}) at block {}{}\n",
          stoppedForTest ? fmt::format("--stop-after-blocks {}", opt->stopAfterBlocks) : fmt::format("signal {}", sig),
          result.last.blocks,
          opt->checkpoint.empty() || !std::filesystem::exists(opt->checkpoint)
              ? std::string("; no checkpoint was written, so the run cannot be resumed")
              : fmt::format("; continue with `polydem jam --resume {}`{}", opt->checkpoint,
                            stopReason == "interrupted" ? "" : " (it repeats the run from that checkpoint)"));
      return kExitInterrupted;
    }
    if (!targetReached) {
      fmt::print("target not reached: {}\n", stopReason);
      return kExitTargetNotReached;
    }
    return kExitOk;
  };
}

}  // namespace polydem::app
