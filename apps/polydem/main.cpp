// polydem: command-line front end. `polydem --help` lists the subcommands.
#include <fmt/format.h>

#include <cstdio>
#include <exception>
#include <map>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/exit_codes.hpp"
#include "core/errors.hpp"
#include "polydem/config.hpp"

int main(int argc, char** argv) {
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
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; every bad command line (unknown option, a value that fails its
    // validator, trailing garbage) is a configuration error, exit code 2 (apps/polydem/exit_codes.hpp).
    const int code = app.exit(e);
    return code == 0 ? polydem::app::kExitOk : polydem::app::kExitConfigError;
  }
  try {
    for (auto& [sub, run] : runners) {
      if (sub->parsed()) return run();
    }
  } catch (const polydem::ConfigError& e) {
    fmt::print(stderr, "polydem: configuration error: {}\n", e.what());
    return 2;
  } catch (const polydem::InputError& e) {
    fmt::print(stderr, "polydem: input error: {}\n", e.what());
    return 2;
  } catch (const polydem::SimulationError& e) {
    fmt::print(stderr, "polydem: simulation error: {}\n", e.what());
    return 3;
  } catch (const std::exception& e) {
    fmt::print(stderr, "polydem: error: {}\n", e.what());
    return 1;
  }
  return 0;
}
