// polydem bench: named benchmark suites that write a self-contained report (CSV, PNG via gnuplot,
// Markdown summary with the machine, the command line and the date).
//
//   quick     CI smoke run (< 1 min): every backend on small scenes, pair sets must agree (exit 1
//             otherwise), plus small trel and model cases
//   levels    Ogarko thesis Fig. 2.5: slowdown factor against the number of HGrid levels L for uniform
//             radius and uniform volume, omega = 50, measured beside the cost models' predictions
//   backends  time and memory per particle of every backend across size distributions and densities
//   optimiser the cost model's choice against an exhaustive measured search over L and mode
//   scaling   cost per particle against N (10^4..10^6) and against the size ratio, vs mono linked cell
//   trel      Ogarko thesis Fig. 2.6: DEM time relative to the monodisperse system against N (bi, uniform
//             volume omega 10 and 50), with the broad-phase / force / integration split
//   model     Ogarko thesis 2.2.5: cost model against counted work and time for Top-Down, Bottom-Up, the
//             constant-m rule and linked cell over power laws alpha = 0..-3, omega = 10, 100
//   paper     levels + trel + model (the three seed reproductions)
//   full      every suite
// Dense states come from event-driven compression when random sequential addition stalls (--dense).
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "apps/polydem/bench_common.hpp"
#include "apps/polydem/commands.hpp"
#include "apps/polydem/summary.hpp"
#include "apps/polydem/validators.hpp"
#include "core/errors.hpp"
#include "core/io/safe_output.hpp"

namespace polydem::app {

namespace {

/// The suites: which parts each runs, in this order, and whether in their quick form.
struct SuitePart {
  bench::SuiteFunction run;
  bool quick = false;
};
struct Suite {
  const char* name;
  std::vector<SuitePart> parts;
};

const std::vector<Suite>& suites() {
  using namespace bench;
  static const std::vector<Suite> table = {
      {"quick", {{runBackends, true}, {runRelativeTime, true}, {runModel, true}}},
      {"levels", {{runLevels}}},
      {"backends", {{runBackends}}},
      {"optimiser", {{runOptimiser}}},
      {"scaling", {{runScaling}}},
      {"trel", {{runRelativeTime}}},
      {"model", {{runModel}}},
      {"paper", {{runLevels}, {runRelativeTime}, {runModel}}},
      {"full", {{runLevels}, {runRelativeTime}, {runModel}, {runBackends}, {runOptimiser}, {runScaling}}},
  };
  return table;
}

std::vector<std::string> suiteNames() {
  std::vector<std::string> names;
  for (const Suite& s : suites()) names.emplace_back(s.name);
  return names;
}

/// The options given on the command line (not the suite), for the report's command line.
std::string givenOptions(const CLI::App& cmd) {
  std::string args;
  for (const auto* o : cmd.get_options()) {
    if (o->get_name() == "suite" || o->count() == 0 || o->get_name() == "--help") continue;
    args += " " + o->get_name() + " " + o->as<std::string>();
  }
  return args;
}

/// Every output checked before any computation: the report directory and the cache, every file the
/// suites write there, none of them an input; every input read once, so a bad second file fails before
/// the first is benchmarked.
void checkBenchOptions(const bench::BenchOptions& opt) {
  using namespace bench;
  if (opt.repeat < 1) throw ConfigError(fmt::format("--repeat must be >= 1, got {}", opt.repeat));
  if (!opt.inputs.empty() && opt.suite != "levels" && opt.suite != "backends") {
    throw ConfigError(fmt::format("--input works with the levels and backends suites, not {}", opt.suite));
  }
  std::vector<std::filesystem::path> inputs(opt.inputs.begin(), opt.inputs.end());
  prepareOutputDirectory(opt.out, "--out");
  for (const char* name : kReportFiles) io::checkOutputPath(std::filesystem::path(opt.out) / name, "--out", inputs);
  prepareOutputDirectory(stateCache(opt), opt.cacheDir.empty() ? "--out (its states/ cache)" : "--cache");
  for (const std::string& file : opt.inputs) sceneFromFile(file);
}

/// `polydem bench SUITE`: check, run the suite's parts, write README.md.
int runBench(const bench::BenchOptions& opt, const std::string& given) {
  using namespace bench;
  checkBenchOptions(opt);
  std::string markdown =
      fmt::format("# polydem bench {}\n\n- date: {}\n- machine: {}\n- command: `polydem bench {}{}`\n\n", opt.suite,
                  today(), machineDescription(), opt.suite, given);
  Stopwatch clock;
  int status = 0;
  for (const Suite& suite : suites()) {
    if (opt.suite != suite.name) continue;
    for (const SuitePart& part : suite.parts) status |= part.run(opt, markdown, part.quick);
  }
  markdown += fmt::format("Total run time: {:.1f} s\n", clock.seconds());
  io::writeFileAtomically(std::filesystem::path(opt.out) / "README.md", markdown);
  fmt::print("report written to {}/README.md ({:.1f} s)\n", opt.out, clock.seconds());
  summary().put("bench.suite", opt.suite);
  summary().put("bench.report", (std::filesystem::path(opt.out) / "README.md").string());
  summary().put("bench.total_seconds", clock.seconds());
  summary().put("bench.machine", machineDescription());
  return status;
}

}  // namespace

Runner addBench(CLI::App& app) {
  auto opt = std::make_shared<bench::BenchOptions>();
  CLI::App* cmd = app.add_subcommand("bench", "run a named benchmark suite and write a report (CSV, PNG, Markdown)");
  cmd->add_option("suite", opt->suite, "quick, levels, backends, optimiser, scaling, trel, model, paper, full")
      ->required()
      ->check(CLI::IsMember(suiteNames()));
  cmd->add_option("--out", opt->out, "report directory")->capture_default_str();
  cmd->add_option("--repeat", opt->repeat, "timed repetitions per case (median and spread reported)")
      ->check(CLI::Range(1, 1000000))
      ->capture_default_str();
  cmd->add_option("-n,--count", opt->count, "particles per scene, >= 2 (0: the suite's default)")
      ->check(CLI::Range(Index(0), std::numeric_limits<Index>::max()))
      ->check(CLI::Validator(
          [](std::string& text) -> std::string {
            return text == "1" ? "1 particle: a broad-phase benchmark needs at least 2 (0: the suite's default)" : "";
          },
          "0 or >= 2"))
      ->capture_default_str();
  cmd->add_option("--counts", opt->counts, "N values of the trel suite, e.g. 10000,100000")
      ->delimiter(',')
      ->check(CLI::Range(Index(2), std::numeric_limits<Index>::max()));
  cmd->add_option("--phi", opt->packing, "packing fraction (0: the suite's default)")
      ->check(finiteIn(0.0, std::nextafter(1.0, 0.0)))
      ->capture_default_str();
  cmd->add_option("--max-levels", opt->maxLevels, "largest L in the levels suite")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  cmd->add_option("--steps", opt->steps, "DEM steps per timed round in the trel suite (0: default)")
      ->check(CLI::Range(0, std::numeric_limits<int>::max()))
      ->capture_default_str();
  cmd->add_option("-i,--input", opt->inputs,
                  "benchmark these particle files (text or HDF5) as they are, instead of generated scenes "
                  "(levels and backends suites)");
  cmd->add_option("--dense", opt->dense,
                  "when random sequential addition cannot reach the packing: edmd (event-driven compression to it) "
                  "or rsa (use the densest RSA state)")
      ->check(CLI::IsMember({"edmd", "rsa"}))
      ->capture_default_str();
  cmd->add_option("--equilibrate", opt->equilibrate,
                  "trel: event-driven collisions per particle at fixed density applied to every state (default 20; "
                  "quick 2)")
      ->check(finiteNonNegative());
  cmd->add_option("--cache", opt->cacheDir, "directory for compressed dense states (default: <out>/states)");
  return [opt, cmd]() { return runBench(*opt, givenOptions(*cmd)); };
}

}  // namespace polydem::app
