// polydem: command-line front end. `polydem --help` lists the subcommands.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <map>
#include <set>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/exit_codes.hpp"
#include "apps/polydem/summary.hpp"
#include "core/errors.hpp"
#include "core/io/safe_output.hpp"
#include "polydem/config.hpp"
#include "polydem/mpi_config.hpp"
#if POLYDEM_WITH_MPI
#include "parallel/mpi_session.hpp"
#endif

int main(int argc, char** argv) {
#if POLYDEM_WITH_MPI
  // MPI_Init only under mpirun; ranks > 0 print nothing (docs/parallel.md).
  polydem::parallel::Session mpi(argc, argv);
  const bool root = polydem::parallel::isRoot();
#else
  const bool root = true;
#endif
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // progress lines appear promptly when redirected
  CLI::App app{"polydem " POLYDEM_VERSION ": simulation and packing of polydisperse spheres"};
  app.require_subcommand(1);
  app.set_version_flag("--version", POLYDEM_VERSION);
  std::map<CLI::App*, polydem::app::Runner> runners;
  auto add = [&](polydem::app::Runner (*registerFn)(CLI::App&)) {
    const std::size_t before = app.get_subcommands({}).size();
    polydem::app::Runner run = registerFn(app);
    runners[app.get_subcommands({})[before]] = std::move(run);
  };
  add(&polydem::app::addGenerate);
  add(&polydem::app::addPairs);
  add(&polydem::app::addExample);
  add(&polydem::app::addRelax);
  add(&polydem::app::addJam);
  add(&polydem::app::addAnalyze);
  add(&polydem::app::addBench);
  add(&polydem::app::addPredict);
  add(&polydem::app::addConvert);
  add(&polydem::app::addLammpsNeighbor);
  add(&polydem::app::addMinimise);
  // --summary-json on the subcommands whose reports feed it (apps/polydem/summary.hpp).
  std::string summaryPath;
  const std::set<std::string> withSummary = {"pairs", "relax", "jam", "analyze", "bench"};
  for (auto& [sub, run] : runners) {
    if (withSummary.count(sub->get_name()) > 0) polydem::app::addSummaryOption(*sub, summaryPath);
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; every bad command line (unknown option, a value that fails its
    // validator, trailing garbage) is a configuration error, exit code 2 (apps/polydem/exit_codes.hpp).
    const int code = app.exit(e);
    return code == 0 ? polydem::app::kExitOk : polydem::app::kExitConfigError;
  }
  CLI::App* sub = nullptr;
  polydem::app::Runner* run = nullptr;
  for (auto& [candidate, runner] : runners) {
    if (candidate->parsed()) {
      sub = candidate;
      run = &runner;
    }
  }
  if (run == nullptr) return polydem::app::kExitOk;
  int code = polydem::app::kExitOk;
  std::string message;
  try {
#if POLYDEM_WITH_MPI
    polydem::parallel::requireParallelSupport(sub->get_name());
#endif
    if (!summaryPath.empty() && root) {
      // Checked before the run (issue 15): not a directory, writable, not one of the inputs (the
      // subcommand's positional arguments, --input, and the checkpoint of jam --resume).
      std::vector<std::filesystem::path> inputs;
      for (const CLI::Option* opt : sub->get_options()) {
        if (opt->get_positional() || opt->check_name("--input") || opt->check_name("--resume")) {
          for (const std::string& r : opt->results()) inputs.emplace_back(r);
        }
      }
      polydem::io::checkOutputPath(summaryPath, "--summary-json", inputs);
      polydem::app::summary().enable();
      polydem::app::recordInvocation(argc, argv, *sub);
    }
    code = (*run)();
  } catch (const polydem::ConfigError& e) {
    message = fmt::format("configuration error: {}", e.what());
    code = polydem::app::kExitConfigError;
  } catch (const polydem::InputError& e) {
    message = fmt::format("input error: {}", e.what());
    code = polydem::app::kExitConfigError;
  } catch (const polydem::SimulationError& e) {
    message = fmt::format("simulation error: {}", e.what());
    code = polydem::app::kExitSimulationError;
  } catch (const std::exception& e) {
    message = fmt::format("error: {}", e.what());
    code = polydem::app::kExitError;
  }
  if (!message.empty() && root) fmt::print(stderr, "polydem: {}\n", message);
  if (polydem::app::summary().enabled()) {
    polydem::app::recordExit(code, message);
    try {
      polydem::io::writeFileAtomically(summaryPath, polydem::app::summary().toJson());
    } catch (const std::exception& e) {
      fmt::print(stderr, "polydem: error: could not write --summary-json {}: {}\n", summaryPath, e.what());
      if (code == polydem::app::kExitOk) code = polydem::app::kExitError;
    }
  }
#if POLYDEM_WITH_MPI
  code = mpi.finish(code);
#endif
  return code;
}
