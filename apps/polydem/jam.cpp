// polydem jam: Lubachevsky-Stillinger compression of hard spheres to jamming (or to a target packing
// fraction) with the event-driven engine of edmd/, then the contact network and rattlers of the result.
// runJam() reads as the run: settings (or a checkpoint's), checks, the start, the compression, an optional
// run at fixed density, the report, the output and the exit code.
#include "apps/polydem/jam.hpp"

#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <set>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/common.hpp"
#include "apps/polydem/equivalent_option.hpp"
#include "apps/polydem/exit_codes.hpp"
#include "apps/polydem/summary.hpp"
#include "apps/polydem/validators.hpp"
#include "core/errors.hpp"
#include "core/initial_configuration.hpp"
#include "core/interrupt.hpp"
#include "core/io/attributes.hpp"
#include "core/io/checkpoint.hpp"
#include "core/io/particle_file.hpp"
#include "core/io/safe_output.hpp"
#include "edmd/compression.hpp"
#include "edmd/hard_sphere_system.hpp"
#include "jamming/contact_network.hpp"

namespace polydem::app {

namespace {

// Options that do not touch the trajectory: the only ones --resume accepts (everything else comes from the
// checkpoint, so a resumed run is the run that was interrupted).
const std::set<std::string> kResumeOverrides = {"--resume", "--progress", "--checkpoint-interval",
                                                "--stop-after-blocks", "--summary-json"};

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

std::string fmtPressure(double p) { return std::isfinite(p) ? fmt::format("{:.4g}", p) : std::string("-"); }

void addJamOptions(CLI::App* cmd, JamOptions* opt) {
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
  cmd->add_flag("--velocities", opt->writeVelocities,
                "store velocities in a text output too (HDF5 and LAMMPS outputs always hold them)");
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
}

// ---------------------------------------------------------------------------------------------------
// The run: one record that its parts fill in, in the order runJam() calls them.

struct JamRun {
  JamRun(JamOptions& options, const CLI::App& command) : opt(options), cmd(command) {}
  JamOptions& opt;
  const CLI::App& cmd;
  bool resuming = false;
  io::Checkpoint saved;  // the checkpoint resumed from
  edmd::CompressionOptions copt;
  io::ParticleData start;  // box, ids and attributes of the start (positions and radii too unless resumed)
  std::string origin;
  std::unique_ptr<edmd::HardSphereSystem> system;
  edmd::CompressionState cstate;
  std::int64_t eosOffset = -1;     // size of the EOS table at the checkpoint resumed from
  SessionRecord prior;             // the earlier sessions of a resumed run (none for a fresh one)
  edmd::EventCounts sessionStart;  // the system's counts when this session's compression began
  Stopwatch session;               // this session's compression (restarted by compressPacking)
  std::ofstream eosCsv;
  io::PeriodicFlush flushEos;
};

/// --resume: refuse options that would change the run, then take every setting from the checkpoint.
void loadResumeSettings(JamRun& run) {
  JamOptions& opt = run.opt;
  for (const CLI::Option* o : run.cmd.get_options()) {
    if (o->count() > 0 && !kResumeOverrides.count(o->get_name())) {
      throw ConfigError(fmt::format(
          "{} cannot be combined with --resume: the checkpoint holds every setting of the run, so that the "
          "resumed run is the interrupted one (only --progress, --checkpoint-interval, --stop-after-blocks and "
          "--summary-json may be given)",
          o->get_name()));
    }
  }
  const JamOptions overrides = opt;
  run.saved = io::readCheckpoint(opt.resume, "jam");
  if (run.saved.integerScalar("format") != kJamCheckpointFormat) {
    throw InputError(fmt::format("{}: jam checkpoint format {} (this polydem reads format {})", opt.resume,
                                 run.saved.integerScalar("format"), kJamCheckpointFormat));
  }
  getSettings(run.saved, opt);
  opt.resume = overrides.resume;
  opt.checkpoint = opt.resume;  // a resumed run keeps checkpointing into the file it resumed from
  opt.stopAfterBlocks = overrides.stopAfterBlocks;
  if (run.cmd.count("--progress")) opt.progressSeconds = overrides.progressSeconds;
  if (run.cmd.count("--checkpoint-interval")) opt.checkpointInterval = overrides.checkpointInterval;
}

/// Combinations of options that make no run.
void checkArguments(const JamRun& run) {
  const JamOptions& opt = run.opt;
  if (!run.resuming) {
    if (opt.reopen > 0.0 && opt.input.empty()) throw ConfigError("--reopen needs --input (a jammed packing)");
    if (!opt.input.empty() && opt.equivalent != "none") {
      throw ConfigError("--equivalent applies to the random start (--dist); it cannot be combined with --input");
    }
    if (opt.block != 0.0 && opt.block < 1.0) {
      throw ConfigError(
          fmt::format("--block {}: must be 0 (automatic) or at least 1 collision per particle "
                      "(smaller blocks spend the run synchronising)",
                      opt.block));
    }
  }
  if (run.cmd.count("--checkpoint-interval") && opt.checkpoint.empty()) {
    throw ConfigError("--checkpoint-interval needs --checkpoint FILE");
  }
}

/// Every output is checked before any computation (hours of work must not end in "cannot write"),
/// against every input and against each other.
void checkOutputs(const JamRun& run) {
  const JamOptions& opt = run.opt;
  std::vector<std::filesystem::path> inputs;
  if (!opt.input.empty()) inputs.emplace_back(opt.input);
  std::vector<std::filesystem::path> outputsSoFar;
  auto checkOutput = [&](const std::string& path, const char* what, bool mayBeResumeFile) {
    if (path.empty()) return;
    std::vector<std::filesystem::path> against = inputs;
    if (run.resuming && !mayBeResumeFile) against.emplace_back(opt.resume);
    io::checkOutputPath(path, what, against);
    for (const auto& other : outputsSoFar) {
      if (io::samePath(path, other)) {
        throw ConfigError(fmt::format("{} '{}': the same file as another output of this run", what, path));
      }
    }
    outputsSoFar.emplace_back(path);
  };
  checkOutput(opt.output, "-o/--output", false);
  checkOutput(opt.eosCsv, "--eos-csv", false);
  checkOutput(opt.checkpoint, "--checkpoint", true);
}

/// Start from the checkpoint: the system in its saved state, the compression where it stood.
void resumeStart(JamRun& run) {
  const std::string& file = run.opt.resume;
  run.start = getStartRecord(run.saved);
  run.origin = fmt::format("resumed from {} ({})", file, run.saved.string("origin"));
  run.system = restoreSystem(run.saved, file, run.opt, run.start);
  run.cstate = getCompressionState(run.saved);
  run.eosOffset = run.saved.integerScalar("eos_offset");
  run.prior = getSessionRecord(run.saved);
}

/// Start from --input, shrunk to about --reopen's pressure if given.
void loadInputStart(JamRun& run) {
  const JamOptions& opt = run.opt;
  // --boundary with --input: it fills in what a text file leaves open and must agree with what a file
  // states (an HDF5 snapshot always does, a text file with a '# boundaries:' line).
  const bool boundaryGiven = run.cmd.count("--boundary") > 0;
  const std::array<Boundary, 3> requested = parseBoundaries(opt.boundaries);
  run.start = io::readParticles(opt.input, boundaryGiven ? requested : io::kAllPeriodic);
  if (boundaryGiven) {
    for (int k = 0; k < 3; ++k) {
      if (run.start.box.boundary(k) != requested[static_cast<std::size_t>(k)]) {
        throw ConfigError(fmt::format(
            "--boundary {} conflicts with the boundaries of {} ({}): the file states its own; omit --boundary "
            "(or write the file without them to choose)",
            opt.boundaries, opt.input, run.start.box.describe()));
      }
    }
  }
  run.origin = opt.input;
  if (opt.reopen > 0.0) run.origin += reopenStart(run.start, opt.reopen, opt.input);
}

/// Start from random sequential addition of radii sampled from --dist (or its --equivalent mixture).
void sampleStart(JamRun& run) {
  Stopwatch rsaClock;
  run.start = sampledStart(*makeDistribution(run.opt.dist), run.opt, run.origin);
  fmt::print("random sequential addition: {:.2f} s\n", rsaClock.seconds());
}

/// The system of a fresh start, with Maxwell-Boltzmann velocities; unreachable targets refused here.
void startSystem(JamRun& run) { run.system = startedSystem(run.opt, run.copt, run.start, run.opt.input); }

void printStart(const JamRun& run) {
  const edmd::HardSphereSystem& system = *run.system;
  fmt::print("start: {}\n", run.origin);
  fmt::print("box {}, {} spheres, size ratio {:.4g}, phi {:.6f}; neighbour lists: {} ({:.1f} per sphere)\n",
             run.start.box.describe(), system.count(), system.largestRadius() / system.smallestRadius(),
             system.packingFraction(), system.describeBroadPhase(), system.meanNeighbours());
  fmt::print(
      "schedule {} -> {}; pressures up to {:.2g} resolvable\n", edmd::formatSchedule(run.copt.schedule),
      run.opt.targetPhi > 0 ? fmt::format("phi {}", run.opt.targetPhi) : fmt::format("p {:g}", run.opt.targetPressure),
      edmd::maxResolvablePressure(system));
  SummaryJson& sum = app::summary();
  sum.put("start.origin", run.origin);
  sum.put("start.box", run.start.box.describe());
  sum.put("start.spheres", static_cast<std::int64_t>(system.count()));
  sum.put("start.size_ratio", system.largestRadius() / system.smallestRadius());
  sum.put("start.packing_fraction", system.packingFraction());
  sum.put("start.broad_phase", system.describeBroadPhase());
  sum.put("start.mean_neighbours", system.meanNeighbours());
  sum.put("start.schedule", edmd::formatSchedule(run.copt.schedule));
  sum.put("start.max_resolvable_pressure", edmd::maxResolvablePressure(system));
}

/// --eos-csv: a new table, or, resumed, the table cut back to the checkpoint and appended to.
void openEosTable(JamRun& run) {
  const std::string& file = run.opt.eosCsv;
  if (file.empty()) return;
  if (run.resuming) {
    // Rows after the checkpoint belong to the lost part of the run: cut them, then go on appending.
    std::error_code ec;
    const auto size = std::filesystem::file_size(file, ec);
    if (ec || static_cast<std::int64_t>(size) < run.eosOffset) {
      throw InputError(
          fmt::format("--eos-csv '{}' (from the checkpoint): missing or shorter than the {} bytes it "
                      "had at the checkpoint",
                      file, run.eosOffset));
    }
    std::filesystem::resize_file(file, static_cast<std::uintmax_t>(run.eosOffset));
    run.eosCsv.open(file, std::ios::app);
  } else {
    run.eosCsv.open(file);
  }
  if (!run.eosCsv) throw ConfigError(fmt::format("--eos-csv: cannot write '{}'", file));
  if (!run.resuming) {
    run.eosCsv << "# polydem jam EOS: one line per block; Z = reduced pressure PV/(N kT) of the block\n"
               << "phi,Z,rate,collisions_per_particle,time,wall_seconds\n";
  }
}

void writeJamCheckpoint(JamRun& run, edmd::HardSphereSystem& system, const edmd::CompressionState& cs) {
  std::int64_t offset = 0;
  if (run.eosCsv.is_open()) {
    run.eosCsv.flush();
    offset = static_cast<std::int64_t>(run.eosCsv.tellp());
  }
  io::Checkpoint c =
      jamCheckpoint(run.opt, run.resuming ? run.saved.string("origin") : run.origin, run.start, system, cs, offset);
  // What the sessions up to this checkpoint spent: a later resume reports the whole run's time.
  putSessionRecord(c, {run.prior.wallKnown, run.prior.wallSeconds + run.session.seconds(), run.prior.sessions + 1});
  io::writeCheckpoint(run.opt.checkpoint, c);
}

/// p.wallSeconds counts from this session's start; a resumed run's lines and EOS rows add the earlier sessions'
/// time (when the checkpoint recorded it), so that the column keeps rising across a resume.
void printProgress(const edmd::Progress& p, double priorWall) {
  fmt::print(
      "phi {:.6f}  p {:>10}  phiJ~ {:>8}  rate {:.0e}  coll/particle {:>9.0f}  events/s {:.3g}  "
      "coll/s {:.3g}  nb {:.1f} exits/coll {:.3f}  wall {:.1f} s\n",
      p.packingFraction, fmtPressure(p.pressure),
      // phi / (1 - 3/p) is undefined while p <= 3 (a dilute gas): a dash, not "nan".
      std::isfinite(p.jammingEstimate) ? fmt::format("{:.6f}", p.jammingEstimate) : std::string("-"), p.rate,
      p.collisionsPerParticle, p.eventsPerSecond, p.collisionsPerSecond, p.meanNeighbours, p.exitsPerCollision,
      priorWall + p.wallSeconds);
  std::fflush(stdout);
}

struct CompressOutcome {
  edmd::CompressionResult result;
  double seconds = 0.0;         // this session's compression
  edmd::EventCounts session;    // this session's events (the result's counts cover every session)
  bool stoppedForTest = false;  // --stop-after-blocks acted, not a signal
};

/// The compression, with an EOS row and perhaps a progress line per block, and checkpoints at block
/// boundaries. Wall-clock things (progress lines, checkpoint times) only read the system: the trajectory
/// is the same whether or when they happen (saveState() synchronises, which at a block boundary changes
/// nothing).
CompressOutcome compressPacking(JamRun& run) {
  const JamOptions& opt = run.opt;
  CompressOutcome out;
  run.session = Stopwatch();
  run.sessionStart = run.system->counts();
  double lastPrint = -1e300;
  edmd::Progress lastShown;
  Stopwatch sinceCheckpoint;
  const edmd::BoundaryHook atBoundary = [&](edmd::HardSphereSystem& sys, const edmd::CompressionState& cs) {
    const bool testStop = opt.stopAfterBlocks > 0 && cs.blocks >= opt.stopAfterBlocks;
    const bool stop = interruptRequested() || testStop;
    if (!opt.checkpoint.empty() && (stop || sinceCheckpoint.seconds() >= opt.checkpointInterval)) {
      writeJamCheckpoint(run, sys, cs);
      sinceCheckpoint = Stopwatch();
      if (stop) fmt::print("wrote checkpoint {} at block {}\n", opt.checkpoint, cs.blocks);
    }
    out.stoppedForTest = testStop && !interruptRequested();
    return stop;
  };
  const auto onBlock = [&](const edmd::Progress& p) {
    if (run.eosCsv.is_open()) {
      run.eosCsv << fmt::format("{:.17g},{:.8g},{:.3g},{:.2f},{:.8g},{:.2f}\n", p.packingFraction, p.pressure, p.rate,
                                p.collisionsPerParticle, p.time, run.prior.wallSeconds + p.wallSeconds);
      run.flushEos(run.eosCsv);
    }
    if (p.wallSeconds - lastPrint >= opt.progressSeconds) {
      printProgress(p, run.prior.wallSeconds);
      lastPrint = p.wallSeconds;
      lastShown = p;
    }
  };
  out.result = edmd::compress(*run.system, run.copt, onBlock, atBoundary, &run.cstate);
  if (lastShown.blocks != out.result.last.blocks) printProgress(out.result.last, run.prior.wallSeconds);
  out.seconds = run.session.seconds();
  out.session = run.system->counts() - run.sessionStart;
  return out;
}

/// --run-collisions: the fixed-density run after the compression; its pressure replaces the last block's.
void runFixedDensity(JamRun& run, JamSummary& summary) {
  edmd::HardSphereSystem& system = *run.system;
  const CpuStopwatch cpu;  // CPU time too: the figure comparisons with other codes use (issue 17)
  const edmd::EquilibriumRun eq =
      edmd::runAtFixedDensity(system, run.opt.runCollisions, 100.0, [] { return interruptRequested(); });
  const double cpuSeconds = std::max(cpu.seconds(), 1e-9);
  const double perCpuSecond = static_cast<double>(eq.counts.collisions) / cpuSeconds;
  if (interruptRequested()) {
    summary.interrupted = true;
    summary.stopReason = "interrupted (during --run-collisions)";
  }
  fmt::print(
      "fixed density: {} collisions per particle, p {} (compression ended at {}), {:.3g} collisions/s, "
      "{:.3g} events/s, {:.2f} s; {:.1f} neighbours per sphere, {:.3f} exits per collision; {:.3g} collisions "
      "per CPU s ({:.2f} CPU s)\n",
      run.opt.runCollisions, fmtPressure(eq.pressure), fmtPressure(summary.pressure), eq.collisionsPerSecond,
      eq.eventsPerSecond, eq.wallSeconds, system.meanNeighbours(),
      static_cast<double>(eq.counts.exits) / static_cast<double>(std::max<std::int64_t>(1, eq.counts.collisions)),
      perCpuSecond, cpuSeconds);
  app::summary().put("fixed_density.collisions_per_particle", run.opt.runCollisions);
  app::summary().put("fixed_density.reduced_pressure", eq.pressure);
  app::summary().put("fixed_density.compression_end_pressure", summary.pressure);
  app::summary().put("fixed_density.collisions_per_second", eq.collisionsPerSecond);
  app::summary().put("fixed_density.wall_seconds", eq.wallSeconds);
  app::summary().put("fixed_density.collisions", static_cast<std::int64_t>(eq.counts.collisions));
  app::summary().put("fixed_density.cpu_seconds", cpuSeconds);
  app::summary().put("fixed_density.collisions_per_cpu_second", perCpuSecond);
  summary.pressure = eq.pressure;
}

void printReport(const JamRun& run, const CompressOutcome& outcome, const JamSummary& s) {
  const edmd::HardSphereSystem& system = *run.system;
  const Index n = system.count();
  const edmd::EventCounts& c = outcome.result.counts;
  const jamming::ContactNetwork& net = s.net;
  const double seconds = outcome.seconds;
  const std::string phiJText =
      std::isfinite(s.phiJ) ? fmt::format("{:.8f}", s.phiJ) : std::string("undefined (p <= 3)");
  fmt::print("\nstopped on {} after {} blocks\n", s.stopReason, outcome.result.last.blocks);
  fmt::print("target reached          {}\n", s.targetReached ? "yes" : fmt::format("no ({})", s.stopReason));
  fmt::print("packing fraction        {:.8f}\n", s.phi);
  fmt::print("reduced pressure        {}\n", fmtPressure(s.pressure));
  fmt::print("phi_J estimate          {}  (phi / (1 - 3/p))\n", phiJText);
  fmt::print("collisions              {} ({:.0f} per particle), {} events; {} exits, {} rebuilds\n", c.collisions,
             static_cast<double>(c.collisions) / n, c.events(), c.exits, c.rebuilds);
  // The rate is this session's events over this session's time; a resumed run's totals cover every session.
  const edmd::EventCounts& now = outcome.session;
  const std::int64_t sessions = run.prior.sessions + 1;
  const double allSeconds = run.prior.wallSeconds + seconds;
  if (sessions == 1) {
    fmt::print("wall time               {:.2f} s ({:.3g} collisions/s, {:.3g} events/s)\n", seconds,
               now.collisions / std::max(seconds, 1e-9), now.events() / std::max(seconds, 1e-9));
  } else {
    fmt::print(
        "wall time               {:.2f} s in this session ({} collisions: {:.3g} collisions/s, {:.3g} events/s); {}\n",
        seconds, now.collisions, now.collisions / std::max(seconds, 1e-9), now.events() / std::max(seconds, 1e-9),
        run.prior.wallKnown ? fmt::format("{:.2f} s over all {} sessions", allSeconds, sessions)
                            : fmt::format("session {}; the checkpoint resumed from does not record the earlier "
                                          "sessions' time (written by an older polydem)",
                                          sessions));
  }
  fmt::print("contacts (gap <= {:.1e}) {}  z = {:.4f}\n", s.contactOptions.relativeGap, net.contacts.size(),
             net.meanCoordination());
  fmt::print("rattlers (< {} contacts)  {} ({:.2f}%)\n", s.contactOptions.minContacts, n - net.backbone,
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
  SummaryJson& sum = app::summary();
  sum.put("report.stop_reason", s.stopReason);
  sum.put("report.blocks", static_cast<std::int64_t>(outcome.result.last.blocks));
  sum.put("report.target_reached", s.targetReached);
  sum.put("report.interrupted", s.interrupted);
  sum.put("report.packing_fraction", s.phi);
  sum.put("report.reduced_pressure", s.pressure);
  if (std::isfinite(s.phiJ)) {
    sum.put("report.phi_j_estimate", s.phiJ);
  } else {
    sum.undefined("report.phi_j_estimate", "p <= 3");
  }
  sum.put("report.collisions", static_cast<std::int64_t>(c.collisions));
  sum.put("report.collisions_per_particle", static_cast<double>(c.collisions) / n);
  sum.put("report.events", static_cast<std::int64_t>(c.events()));
  sum.put("report.cell_exits", static_cast<std::int64_t>(c.exits));
  sum.put("report.rebuilds", static_cast<std::int64_t>(c.rebuilds));
  sum.put("report.wall_seconds", seconds);
  sum.put("report.sessions", sessions);
  sum.put("report.session_collisions", static_cast<std::int64_t>(now.collisions));
  if (run.prior.wallKnown) {
    sum.put("report.wall_seconds_all_sessions", allSeconds);
  } else {
    sum.undefined("report.wall_seconds_all_sessions", "the checkpoint resumed from does not record earlier sessions");
  }
  sum.put("report.contacts.relative_gap", s.contactOptions.relativeGap);
  sum.put("report.contacts.count", static_cast<std::int64_t>(net.contacts.size()));
  sum.put("report.contacts.z", net.meanCoordination());
  sum.put("report.contacts.rattlers", static_cast<std::int64_t>(n - net.backbone));
  sum.put("report.contacts.rattler_fraction", net.rattlerFraction());
  sum.put("report.contacts.backbone_spheres", static_cast<std::int64_t>(net.backbone));
  if (net.backbone > 0) {
    sum.put("report.contacts.backbone_contacts", static_cast<std::int64_t>(net.backboneContacts));
    sum.put("report.contacts.backbone_z", net.backboneCoordination());
    sum.put("report.contacts.isostatic_excess", net.isostaticExcess());
  } else {
    sum.undefined("report.contacts.backbone_z", "every sphere a rattler");
    sum.undefined("report.contacts.isostatic_excess", "every sphere a rattler");
  }
  sum.put("report.largest_overlap", net.maxOverlap);
  sum.put("report.largest_overlap_at_collisions", system.maxOverlapSeen());
  if (!run.opt.output.empty()) sum.put("outputs.packing", run.opt.output);
  if (!run.opt.eosCsv.empty()) sum.put("outputs.eos_csv", run.opt.eosCsv);
  if (!run.opt.checkpoint.empty()) sum.put("outputs.checkpoint", run.opt.checkpoint);
  if (net.backbone > 0 && net.isostaticExcess() < 0 && s.pressure >= 1e9) {
    // A hypostatic backbone at high pressure: floppy modes left by too fast a late stage (Donev 2006,
    // thesis, §9.3.1; docs/edmd-results.md, pressure-leak test against the final growth rate).
    fmt::print(
        "note: the backbone is hypostatic: the late stages ran too fast for it to find its contacts; in our runs "
        "packings passed `polydem analyze --leak-test` when four decades of pressure beyond p ~ 1e4 ran at 3e-5 or "
        "slower, and `polydem jam -i {} --reopen 1e8 --schedule 3e-5` compresses this one again that way\n",
        run.opt.output.empty() ? std::string("PACKING") : run.opt.output);
  }
}

/// -o: the packing with its provenance and summary as attributes.
void writePacking(const JamRun& run, const edmd::CompressionResult& result, const JamSummary& s) {
  io::writeParticles(run.opt.output,
                     packingRecord(run.opt, run.copt, run.start, *run.system, s, result.counts.collisions));
  fmt::print("wrote {}\n", run.opt.output);
}

/// The exit code, and after an interrupt how to go on.
int finish(const JamRun& run, const CompressOutcome& outcome, const JamSummary& s) {
  const JamOptions& opt = run.opt;
  if (s.interrupted) {
    const int sig = interruptSignal();
    fmt::print("interrupted ({}) at block {}{}\n",
               outcome.stoppedForTest ? fmt::format("--stop-after-blocks {}", opt.stopAfterBlocks)
                                      : fmt::format("signal {}", sig),
               outcome.result.last.blocks,
               opt.checkpoint.empty() || !std::filesystem::exists(opt.checkpoint)
                   ? std::string("; no checkpoint was written, so the run cannot be resumed")
                   : fmt::format("; continue with `polydem jam --resume {}`{}", opt.checkpoint,
                                 s.stopReason == "interrupted" ? "" : " (it repeats the run from that checkpoint)"));
    return kExitInterrupted;
  }
  if (!s.targetReached) {
    fmt::print("target not reached: {}\n", s.stopReason);
    return kExitTargetNotReached;
  }
  return kExitOk;
}

int runJam(JamOptions& opt, const CLI::App& cmd) {
  installInterruptHandlers();
  JamRun run(opt, cmd);
  run.resuming = !opt.resume.empty();
  if (run.resuming) {
    loadResumeSettings(run);
  } else {
    finishDistributionSpec(opt.dist, opt.fractionKind);
  }
  run.copt = compressionOptions(opt);
  checkArguments(run);
  checkOutputs(run);
  if (run.resuming) {
    resumeStart(run);
  } else {
    if (opt.input.empty()) {
      sampleStart(run);
    } else {
      loadInputStart(run);
    }
    startSystem(run);
  }
  printStart(run);
  openEosTable(run);

  const CompressOutcome outcome = compressPacking(run);
  JamSummary summary;
  summary.stopReason = outcome.result.stopReason;
  summary.interrupted = summary.stopReason == "interrupted";
  summary.pressure = outcome.result.last.pressure;
  if (opt.runCollisions > 0.0 && !summary.interrupted) runFixedDensity(run, summary);
  analysePacking(opt, *run.system, summary);
  summary.targetReached = outcome.result.targetReached && !summary.interrupted;
  printReport(run, outcome, summary);
  if (!opt.output.empty()) writePacking(run, outcome.result, summary);
  if (run.eosCsv.is_open()) run.eosCsv.flush();
  return finish(run, outcome, summary);
}

}  // namespace

Runner addJam(CLI::App& app) {
  auto opt = std::make_shared<JamOptions>();
  CLI::App* cmd = app.add_subcommand(
      "jam", "Lubachevsky-Stillinger compression of hard spheres to jamming (event-driven), with contact statistics");
  addJamOptions(cmd, opt.get());
  return [opt, cmd]() -> int { return runJam(*opt, *cmd); };
}

}  // namespace polydem::app
