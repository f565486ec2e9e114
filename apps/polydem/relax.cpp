// polydem relax: run a soft-sphere DEM relaxation described by a TOML scene file (see
// apps/polydem/relax_scene.hpp and examples/relax_uv10.toml), with command-line overrides, optional
// soft compression, outputs (HDF5/text snapshots, CSV time series, final state) and a closing report.
// `--sweep dt-factor=10,20,50` or `--sweep skin=...` reruns the scene per setting and tabulates error
// against wall time (CSV, and a PNG when gnuplot is installed).
//
// No lost work (issue 15): every output path is checked before anything is computed; files are written
// atomically; time-series rows are flushed every few seconds. With output.checkpoint the complete state
// (DemState: particles, forces, contact springs, the neighbour list's build positions, step, time, the
// scene) is saved every output.checkpoint_interval steps, every output.checkpoint_seconds of wall time,
// at the end and when SIGINT/SIGTERM arrives (exit 130); `relax --resume FILE.h5` continues the run
// bit-identically. Wall-clock timing (progress lines, timed checkpoints) only decides when the state is
// read, never what it becomes. The time loop has no random numbers: the RNGs (generation, impact
// velocities) are used up before step 0, so the checkpoint needs no RNG state.
//
// This file: the options, and run() = load (scene or checkpoint), check outputs, then compute, write and
// report. The parts are declared in relax.hpp: relax_start.cpp (the starting state, soft compression),
// relax_checkpoint.cpp, relax_run.cpp (the time loop and its outputs), relax_report.cpp, relax_sweep.cpp.
#include "apps/polydem/relax.hpp"

#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/exit_codes.hpp"
#include "apps/polydem/summary.hpp"
#include "apps/polydem/validators.hpp"
#include "core/errors.hpp"
#include "core/interrupt.hpp"
#include "core/io/checkpoint.hpp"
#include "polydem/mpi_config.hpp"
#if POLYDEM_WITH_MPI
#include "parallel/mpi_session.hpp"
#endif

namespace polydem::app {

namespace {

/// The command line of `polydem relax`.
struct RelaxOptions {
  std::string scene;
  std::string resume;
  bool printDefaults = false;
  std::vector<std::string> sets;
  std::optional<std::int64_t> steps;
  std::optional<double> dtFactor;
  std::optional<std::string> broadPhase;
  std::optional<double> skin;
  std::optional<std::string> kernel;
  std::optional<int> threads;
  std::string sweep;
  bool quiet = false;
  std::string decomposition;  ///< MPI runs only (docs/parallel.md); empty = rcb
};

std::string readText(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw InputError(fmt::format("{}: cannot open scene file", file.string()));
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

/// The scene overrides of the command line: the --set assignments, then the named options.
std::vector<std::string> overridesOf(const RelaxOptions& opt) {
  std::vector<std::string> overrides = opt.sets;
  if (opt.steps) overrides.push_back(fmt::format("run.steps={}", *opt.steps));
  if (opt.dtFactor) overrides.push_back(fmt::format("run.dt_factor={:.17g}", *opt.dtFactor));
  if (opt.broadPhase) overrides.push_back(fmt::format("run.broadphase=\"{}\"", *opt.broadPhase));
  if (opt.skin) overrides.push_back(fmt::format("run.skin={:.17g}", *opt.skin));
  if (opt.kernel) overrides.push_back(fmt::format("run.kernel=\"{}\"", *opt.kernel));
  if (opt.threads) overrides.push_back(fmt::format("run.threads={}", *opt.threads));
  for (const std::string& o : overrides) {
    if (o.find('\n') != std::string::npos) throw ConfigError(fmt::format("--set '{}': no line breaks", o));
  }
  return overrides;
}

/// What `load` finds: the scene (from the scene file, or from the checkpoint), the context saved into
/// outputs and checkpoints, the input files no output may overwrite, and the checkpoint of --resume.
struct LoadedRun {
  RunContext context;
  RelaxScene scene;
  std::vector<std::filesystem::path> inputs;
  std::optional<io::Checkpoint> checkpoint;
};

LoadedRun load(const RelaxOptions& opt) {
  const std::vector<std::string> overrides = overridesOf(opt);
  LoadedRun run;
  if (!opt.resume.empty()) {
    if (!opt.scene.empty()) {
      throw ConfigError(fmt::format("relax --resume {} takes no scene file ({}): the checkpoint holds the scene",
                                    opt.resume, opt.scene));
    }
    if (!opt.sweep.empty()) throw ConfigError("relax --resume cannot be combined with --sweep");
    for (const std::string& o : overrides) {
      if (!resumableKey(o)) {
        throw ConfigError(
            fmt::format("relax --resume: '{}' would change the trajectory of the saved run; only run.steps (--steps), "
                        "run.threads (--threads), run.progress_interval and output.* may be given",
                        o));
      }
    }
    run.checkpoint = io::readCheckpoint(opt.resume, kCheckpointKind);
    run.context = contextFrom(*run.checkpoint, overrides);
    run.inputs.push_back(run.context.sceneSource);
  } else {
    if (opt.scene.empty()) throw ConfigError("relax: give a scene file (or --resume FILE.h5, --print-defaults)");
    run.context.sceneText = readText(opt.scene);
    run.context.sceneSource = opt.scene;
    run.context.overrides = overrides;
    run.inputs.push_back(opt.scene);
  }
  run.scene = parseRelaxScene(run.context.sceneText, run.context.overrides, run.context.sceneSource);
  if (!run.scene.particleFile.empty()) run.inputs.push_back(run.scene.resolve(run.scene.particleFile));
  return run;
}

/// The settings of the time loop: the scene's, plus the impact overlap when the impact rule set the
/// velocities (error messages then name velocities.overlap as the fix).
integrators::DemSettings runSettings(const RelaxScene& scene) {
  integrators::DemSettings settings = scene.dem;
  if (scene.initialVelocities == "impact") settings.impactOverlap = scene.impactOverlap;
  return settings;
}

int exitCode(const RunSummary& r) { return static_cast<int>(r.interrupted ? kExitInterrupted : kExitOk); }

/// A soft compression that stopped short of its target: write what there is, marked, and do not run on it.
int writeShortOfTarget(const RelaxScene& scene, Start& start, RunContext& context,
                       const integrators::SoftCompression& compression, bool quiet) {
  const int code = static_cast<int>(start.interrupted ? kExitInterrupted : kExitTargetNotReached);
#if POLYDEM_WITH_MPI
  if (severalRanks() && !parallel::isRoot()) return code;  // rank 0 writes and reports
#endif
  fmt::print("TARGET NOT REACHED: {}\n", *start.targetNotReached);
  RelaxScene stop = scene;
  stop.steps = 0;
  stop.checkpoint.clear();  // an interrupted compression wrote its own; a finished one has nothing to resume
  if (start.interrupted && !scene.checkpoint.empty()) {
    context.checkpointNote = fmt::format("{} (soft compression, step {}): continue with polydem relax --resume {}",
                                         scene.checkpoint, compression.progress().steps, scene.checkpoint);
  } else if (!scene.checkpoint.empty()) {
    context.checkpointNote = "none written (a soft compression that ended short of its target is not resumed)";
  }
  runScene(stop, integrators::DemSimulation(std::move(start.particles), start.box, scene.dem), context,
           RunMode{.quiet = quiet, .targetNotReached = start.targetNotReached});
  return code;
}

/// Compute (and write, report) a run from its start: the soft compression if any, the velocities,
/// the time loop. `compression` is set when a checkpoint of the compression is being resumed.
int runFromStart(const RelaxScene& scene, Start start, RunContext& context,
                 std::optional<integrators::SoftCompression> compression, bool quiet,
                 [[maybe_unused]] const std::string& decomposition = "rcb") {
  if (compression) {
#if POLYDEM_WITH_MPI
    if (severalRanks()) {
      compressOnRanks(scene, *compression, start, context, quiet, decomposition);
    } else {
      compressStart(scene, *compression, start, context, quiet, true);
    }
#else
    compressStart(scene, *compression, start, context, quiet, true);
#endif
  }
  if (start.targetNotReached) return writeShortOfTarget(scene, start, context, *compression, quiet);
  setVelocities(scene, start);
  const integrators::DemSettings settings = runSettings(scene);
  RelaxScene running = scene;
  running.dem = settings;
  integrators::DemSimulation sim(std::move(start.particles), start.box, settings);
  // Continuing a run from its snapshot (velocities from the file): the clock continues too.
  if (scene.initialVelocities == "file") sim.setTimeOrigin(start.fileTime);
#if POLYDEM_WITH_MPI
  if (severalRanks()) {  // docs/parallel.md
    const std::unique_ptr<StepDriver> driver = makeStepDriver(sim, decomposition);
    return exitCode(runScene(running, std::move(sim), context, RunMode{.quiet = quiet, .driver = driver.get()}));
  }
#endif
  return exitCode(runScene(running, std::move(sim), context, RunMode{.quiet = quiet}));
}

/// Continue the run saved in `run.checkpoint`: the time loop (phase "run") or the soft compression.
int resume(const RelaxOptions& opt, LoadedRun& run) {
  const RelaxScene& scene = run.scene;
  const io::Checkpoint& checkpoint = *run.checkpoint;
  const integrators::DemState state = stateFrom(checkpoint);
  if (checkpoint.string("phase") == "run") {
    if (scene.steps < state.step) {
      throw ConfigError(
          fmt::format("run.steps = {} is below the checkpoint's step {}: run.steps counts from "
                      "step 0, give a larger total with --steps",
                      scene.steps, state.step));
    }
#if POLYDEM_WITH_MPI
    if (severalRanks()) {  // a checkpoint of any rank count resumes on any other (docs/parallel.md)
      integrators::DemSimulation sim = integrators::DemSimulation::restore(state, runSettings(scene));
      const std::unique_ptr<StepDriver> driver =
          makeStepDriver(sim, opt.decomposition.empty() ? "rcb" : opt.decomposition);
      return exitCode(runScene(scene, std::move(sim), run.context,
                               RunMode{.quiet = opt.quiet, .resumed = true, .driver = driver.get()}));
    }
#endif
    return exitCode(runScene(scene, integrators::DemSimulation::restore(state, runSettings(scene)), run.context,
                             RunMode{.quiet = opt.quiet, .resumed = true}));
  }
  if (checkpoint.string("phase") != "compression" || !scene.compression) {
    throw InputError(
        fmt::format("{}: checkpoint phase '{}' does not match its scene", opt.resume, checkpoint.string("phase")));
  }
  const integrators::CompressionProgress progress = compressionFrom(checkpoint);
  std::optional<integrators::SoftCompression> compression;
  compression.emplace(state, scene.dem, *scene.compression, progress);
  Start start;
  start.origin = run.context.origin;
  start.attributes = run.context.attributes;
  fmt::print("resumed the soft compression at step {}\n", progress.steps);
  return runFromStart(scene, std::move(start), run.context, std::move(compression), opt.quiet);
}

/// A new run: prepare the start (read or generate), then compress and run it.
int runNew(const RelaxOptions& opt, LoadedRun& run) {
  const RelaxScene& scene = run.scene;
  Start start = prepare(scene);
  run.context.attributes = start.attributes;
  run.context.origin = start.origin;
  if (scene.initialVelocities == "file" && scene.compression) {
    throw ConfigError("velocities.initial = \"file\" cannot follow [compression]");
  }
  std::optional<integrators::SoftCompression> compression;
  if (scene.compression) compression.emplace(std::move(start.particles), start.box, scene.dem, *scene.compression);
  return runFromStart(scene, std::move(start), run.context, std::move(compression), opt.quiet,
                      opt.decomposition.empty() ? "rcb" : opt.decomposition);
}

/// `polydem relax`: load the scene (or the checkpoint), check every output, then compute, write and
/// report (runScene) the run, the resumed run or the sweep. Returns the exit code.
int run(const RelaxOptions& opt) {
  if (opt.printDefaults) {
    fmt::print("{}", defaultSceneToml());
    return static_cast<int>(kExitOk);
  }
  LoadedRun loaded = load(opt);
  if (!opt.decomposition.empty() && !severalRanks()) {
    throw ConfigError(fmt::format("--decomposition {} applies to runs on several MPI ranks (mpirun -np N, N > 1)",
                                  opt.decomposition));
  }
#if POLYDEM_WITH_MPI
  if (severalRanks()) requireParallelSupport(!opt.sweep.empty());
#endif
  fmt::print("polydem relax {}\n", opt.resume.empty() ? opt.scene : "--resume " + opt.resume);
  if (summary().enabled()) {
    // The settings of a scene run are the scene itself: its file verbatim (the --set overrides are in
    // settings.set) or the checkpoint it was resumed from.
    if (opt.resume.empty()) {
      summary().put("scene.file", opt.scene);
      std::ifstream in(opt.scene);
      summary().put("scene.text", std::string(std::istreambuf_iterator<char>(in), {}));
    } else {
      summary().put("scene.resumed_from", opt.resume);
    }
  }
  installInterruptHandlers();
  if (!opt.sweep.empty()) return runSweep(loaded.scene, opt.sweep, opt.quiet, loaded.inputs);
  checkOutputs(loaded.scene, loaded.inputs);
  return loaded.checkpoint ? resume(opt, loaded) : runNew(opt, loaded);
}

}  // namespace

Runner addRelax(CLI::App& app) {
  auto opt = std::make_shared<RelaxOptions>();
  CLI::App* cmd = app.add_subcommand("relax", "soft-sphere DEM relaxation of a scene file (TOML)");
  cmd->add_option("scene", opt->scene, "scene file, e.g. examples/relax_uv10.toml");
  cmd->add_option("--resume", opt->resume,
                  "continue the run saved in this checkpoint (output.checkpoint); no scene file: the checkpoint "
                  "holds it. Allowed with it: --steps, --threads, -q, --set run.steps|run.threads|"
                  "run.progress_interval|output.*");
  cmd->add_flag("--print-defaults", opt->printDefaults, "print every scene key with its default (a TOML scene)");
  cmd->add_option("--set", opt->sets,
                  "override a scene key, section.key=value (repeatable), e.g. --set contact.restitution=0.5")
      ->allow_extra_args(false);  // one value per --set, so the scene file is never swallowed
  cmd->add_option("--steps", opt->steps, "run.steps (total, counted from step 0)")->check(finiteIn(0, 9e18));
  cmd->add_option("--dt-factor", opt->dtFactor, "run.dt_factor: steps per shortest contact (>= 5)")
      ->check(finiteIn(integrators::kMinStepsPerContact, std::numeric_limits<double>::infinity()));
  cmd->add_option("--broadphase", opt->broadPhase, "run.broadphase: brute, linked-cell, hgrid-td, ..., auto");
  cmd->add_option("--skin", opt->skin, "run.skin: Verlet skin (m)")->check(finiteNonNegative());
  cmd->add_option("--kernel", opt->kernel, "run.kernel: specialised or general (for comparisons)");
  cmd->add_option("--threads", opt->threads, "run.threads: OpenMP threads for forces and kicks (1 = serial)")
      ->check(finiteIn(1, 1024));
  cmd->add_option("--sweep", opt->sweep, "dt-factor=10,20,50,100,200 or skin=...: error against wall time");
  cmd->add_flag("-q,--quiet", opt->quiet, "no progress lines");
  cmd->add_option("--decomposition", opt->decomposition,
                  "under mpirun: rcb (recursive coordinate bisection by cost, rebalanced; default) or brick (grid)")
      ->check(CLI::IsMember({"rcb", "brick"}));
  return [opt]() { return run(*opt); };
}

}  // namespace polydem::app
