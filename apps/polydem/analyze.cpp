// polydem analyze: contact network, rattlers, isostaticity, cumulative coordination Z(tau) and the pair
// correlation g(x) of a hard-sphere packing (e.g. one written by `polydem jam`); structure of any
// configuration (gas, liquid, crystal, packing): bond-orientational order and crystallinity (--order),
// channel sizes (--channels-csv), S(k) and chi(k) (--sk-csv), rattlers by speed (--velocity-rattlers).
//
// This file: the options, their validation and the run (load and validate the input, compute, report,
// write), whose parts live in analyze_contacts.cpp, analyze_jamming.cpp and analyze_structure.cpp.
// Verdicts only where they apply (issue 15): see analyze_contacts.cpp.
#include "apps/polydem/analyze.hpp"

#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/common.hpp"
#include "apps/polydem/validators.hpp"
#include "broadphase/registry.hpp"
#include "core/errors.hpp"
#include "core/io/attributes.hpp"
#include "core/io/particle_file.hpp"
#include "core/io/safe_output.hpp"
#include "jamming/ideal_contacts.hpp"

namespace polydem::app {

namespace analyze {
namespace {

void addContactOptions(CLI::App& cmd, AnalyzeOptions& opt) {
  cmd.add_option("input", opt.input, "particle file (.h5/.hdf5 or text)")->required();
  cmd.add_option("--contact-gap", opt.contactGap,
                 "contact when gap <= this x (r_i + r_j), also the largest overlap (x the smaller radius) "
                 "accepted; 0 = from the reduced pressure (see --pressure)")
      ->check(finiteIn(0.0, 1.0))
      ->capture_default_str();
  cmd.add_option("--pressure", opt.pressure,
                 "reduced pressure of the packing for the default contact gap (0 = the file's reduced_pressure "
                 "attribute; without one, give --pressure or --contact-gap)")
      ->check(finiteNonNegative())
      ->capture_default_str();
  cmd.add_option("--broad-phase", opt.broadPhase, "broad phase for the pair searches")->capture_default_str();
  cmd.add_option("--z-csv", opt.coordinationCsv, "write Z(tau) for tau = 1e-15 .. 1e-1 (tau,Z)");
  cmd.add_option("--gr-csv", opt.correlationCsv, "write g(x), x = r_ij / (r_i + r_j) (x,g)");
  cmd.add_option("--gr-max", opt.correlationMax, "--gr-csv: largest x of g(x), > 1")
      ->check(finiteIn(1.0, 1e3))
      ->capture_default_str();
  cmd.add_option("--gr-bins", opt.correlationBins, "--gr-csv: bins of g(x)")
      ->check(CLI::Range(1, 100000000))
      ->capture_default_str();
}

void addCertifyOptions(CLI::App& cmd, AnalyzeOptions& opt) {
  cmd.add_flag("--certify", opt.certify,
               "linear-programming test of collective jamming (GLPK): 'jammed' or an unjamming motion");
  cmd.add_option("--remove", opt.removeSphere,
                 "--certify, --leak-test: take this sphere (index) out (e.g. a backbone sphere: a deliberately "
                 "unjammed packing)")
      ->check(CLI::Range(0, std::numeric_limits<Index>::max()));
  cmd.add_option("--load-gap", opt.loadGap,
                 "--certify: pairs with gap <= this x (r_i + r_j) are constraints of the load test")
      ->check(finitePositive())
      ->capture_default_str();
  cmd.add_option("--load-test", opt.loadTest,
                 "--certify: sequential = the seed's Algorithm 14 for packings with gaps (each load's motion is "
                 "scaled to the first collision, applied and loaded again; verdict from the accumulated "
                 "displacements); single = one LP per load, any sphere beyond --displacement-limit unjams "
                 "(Algorithm 13, with --subpacking-rounds)")
      ->check(CLI::IsMember({"sequential", "single"}))
      ->capture_default_str();
  cmd.add_option("--displacement-limit", opt.displacementLimit,
                 "--certify: single: a load moving a sphere further than this (mean diameters) unjams; "
                 "sequential: reported for the LPs' own motions")
      ->check(finitePositive())
      ->capture_default_str();
  cmd.add_option("--beta", opt.beta,
                 "--certify sequential: load again while a step moves a sphere by more than this (own diameters)")
      ->check(finitePositive())
      ->capture_default_str();
  cmd.add_option("--max-limit", opt.maxLimit,
                 "--certify sequential: unjammed if a loaded sphere moves further in all (own diameters)")
      ->check(finitePositive())
      ->capture_default_str();
  cmd.add_option("--mean-limit", opt.meanLimit,
                 "--certify sequential: unjammed if the mean displacement of the loaded spheres exceeds this")
      ->check(finitePositive())
      ->capture_default_str();
  cmd.add_option("--max-steps", opt.maxSteps, "--certify sequential: LPs per load at most")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  cmd.add_option("--loads", opt.loads, "--certify: random loads (each also applied reversed), at least 1")
      ->check(CLI::Range(1, 1000000))
      ->capture_default_str();
  cmd.add_option("--lp-solver", opt.lpSolver,
                 "--certify: load-test LP solver: simplex (GLPK), interior (own interior point with CHOLMOD), "
                 "auto = simplex up to 2000 spheres")
      ->check(CLI::IsMember({"auto", "simplex", "interior"}))
      ->capture_default_str();
  cmd.add_option("--subpacking-rounds", opt.subpackingRounds,
                 "--certify: if the packing is unjammed, set the displaced spheres aside (sequential: remove them) "
                 "and load the rest again, up to this many rounds in all, to find a jammed subpacking (seed "
                 "Algorithm 13)")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  cmd.add_flag("--strict", opt.strict,
               "--certify --load-test single: strict jamming, the periodic cell may deform (volume not growing)");
  cmd.add_flag("--no-local-rattlers", opt.noLocalRattlers,
               "--certify: load every backbone sphere, also those the local LP (neighbours fixed) finds loose");
  cmd.add_flag("--no-ideal", opt.skipIdeal, "--certify: skip the ideal-contact LP test");
  cmd.add_option("--motion-csv", opt.motionCsv,
                 "--certify: write the load test's motion (the unjamming motion, or the displacements the loads "
                 "achieved)");
}

void addLeakOptions(CLI::App& cmd, AnalyzeOptions& opt) {
  cmd.add_option("--leak-test", opt.leakCollisions,
                 "pressure-leak test (seed ch. 9): plain event-driven dynamics for this many collisions per particle; "
                 "a jammed packing keeps its pressure and its backbone does not drift (with --remove: without the "
                 "sphere)")
      ->check(finitePositive());
  cmd.add_option("--leak-blocks", opt.leakBlocks, "--leak-test: blocks (one pressure each)")
      ->check(CLI::Range(4, 100000))
      ->capture_default_str();
  cmd.add_option("--leak-tolerance", opt.leakTolerance,
                 "--leak-test: a relative pressure drop (last quarter against first) beyond this is a leak")
      ->check(finitePositive())
      ->capture_default_str();
  cmd.add_option("--leak-drift", opt.leakDrift,
                 "--leak-test: a drift: the last quarter's mean backbone displacement above this factor (> 1) x "
                 "the first half's largest")
      ->check(finiteIn(1.0, 1e300))
      ->capture_default_str();
}

CLI::Option* addStructureOptions(CLI::App& cmd, AnalyzeOptions& opt) {
  cmd.add_flag("--structure-only", opt.structureOnly,
               "skip the contact network and jamming statistics (gases, liquids, crystals)");
  cmd.add_flag("--order", opt.order,
               "bond-orientational order over weighted Delaunay neighbours: q6, Q6, crystalline fraction p_c "
               "(d6 > 0.65, >= 6 connections)");
  cmd.add_option("--channels-csv", opt.channelsCsv,
                 "write the channel-size histogram f(R_j / r_i), bin 0.01 (x_low,x_mid,f,count)");
  cmd.add_option("--sk-csv", opt.skCsv,
                 "write shell-averaged S(k) and spectral density chi(k) (K,S,chi,vectors), "
                 "K = k D, D = 2 <r>; periodic boxes only");
  cmd.add_option("--sk-kmax", opt.skMax, "--sk-csv: largest K = k D")->check(finitePositive())->capture_default_str();
  cmd.add_option("--sk-max-vectors", opt.skMaxVectors,
                 "--sk-csv: above this many wave vectors use every s-th per axis (coarser shells; 0 = all)")
      ->check(finiteIn(0.0, 1e15))
      ->capture_default_str();
  return cmd
      .add_option("--velocity-rattlers", opt.velocityThreshold,
                  "rattlers by speed: |v| / v_rms <= threshold (default 1e-4; needs velocities, `polydem jam "
                  "--velocities`); give the value with '=' or after the input file")
      ->expected(0, 1);
}

/// Refuses options that cannot act together, before any work; reads the --velocity-rattlers value.
void validateOptions(AnalyzeOptions& opt, const CLI::App& cmd, const CLI::Option& velocityOption) {
  auto given = [&](const char* name) { return cmd.get_option(name)->count() > 0; };
  // Options that only act with another one are refused without it rather than silently ignored.
  auto needs = [&](std::initializer_list<const char*> names, bool present, const char* what) {
    for (const char* name : names) {
      if (given(name) && !present) throw ConfigError(fmt::format("{} needs {}", name, what));
    }
  };
  needs({"--load-gap", "--load-test", "--displacement-limit", "--beta", "--max-limit", "--mean-limit", "--max-steps",
         "--loads", "--lp-solver", "--subpacking-rounds", "--strict", "--no-local-rattlers", "--no-ideal",
         "--motion-csv"},
        opt.certify, "--certify");
  needs({"--leak-blocks", "--leak-tolerance", "--leak-drift"}, given("--leak-test"), "--leak-test");
  needs({"--remove"}, opt.certify || given("--leak-test"), "--certify or --leak-test");
  needs({"--gr-max", "--gr-bins"}, !opt.correlationCsv.empty(), "--gr-csv");
  needs({"--sk-kmax", "--sk-max-vectors"}, !opt.skCsv.empty(), "--sk-csv");
  if (opt.structureOnly) {
    for (const char* name : {"--certify", "--leak-test", "--z-csv", "--gr-csv", "--pressure", "--contact-gap"}) {
      if (given(name)) {
        throw ConfigError(
            fmt::format("{} needs the contact network, which --structure-only skips: drop one of them", name));
      }
    }
  }
  if (!(opt.correlationMax > 1.0)) {
    throw ConfigError(
        fmt::format("--gr-max: {} must be > 1 (x = r_ij / (r_i + r_j) is 1 at contact)", opt.correlationMax));
  }
  if (!(opt.leakDrift > 1.0)) {
    throw ConfigError(fmt::format("--leak-drift: {} must be > 1 (a ratio of displacements)", opt.leakDrift));
  }
  if (opt.strict && opt.loadTest != "single") {
    throw ConfigError("--strict needs --load-test single (the sequential test keeps the cell fixed)");
  }
  if (opt.certify && !opt.skipIdeal && !jamming::jammingTestAvailable()) {
    throw ConfigError(
        "--certify: the ideal-contact LP test needs GLPK (libglpk-dev), which this build did not "
        "find; add --no-ideal to run the load test alone");
  }
  try {
    broadphase::makeBroadPhase(opt.broadPhase);
  } catch (const ConfigError& e) {
    throw ConfigError(fmt::format("--broad-phase: {}", e.what()));
  }
  opt.velocityRattlers = velocityOption.count() > 0;
  if (!opt.velocityThreshold.empty() && !opt.velocityThreshold.front().empty()) {
    const std::optional<double> value = io::parseFiniteDouble(opt.velocityThreshold.front());
    if (!value || !(*value > 0.0)) {
      throw ConfigError(fmt::format("--velocity-rattlers: '{}' is not a finite number > 0 (expected e.g. 1e-4)",
                                    opt.velocityThreshold.front()));
    }
    opt.velocityRattlerLimit = *value;
  }
}

/// Every output checked before any work: writable, and neither the input nor another output.
void checkOutputs(const AnalyzeOptions& opt) {
  const std::vector<std::filesystem::path> inputs{opt.input};
  std::vector<std::pair<const char*, std::string>> seen;
  for (const auto& [name, path] :
       std::initializer_list<std::pair<const char*, const std::string*>>{{"--z-csv", &opt.coordinationCsv},
                                                                         {"--gr-csv", &opt.correlationCsv},
                                                                         {"--motion-csv", &opt.motionCsv},
                                                                         {"--channels-csv", &opt.channelsCsv},
                                                                         {"--sk-csv", &opt.skCsv}}) {
    if (path->empty()) continue;
    io::checkOutputPath(*path, name, inputs);
    for (const auto& [other, otherPath] : seen) {
      if (io::samePath(*path, otherPath)) {
        throw ConfigError(
            fmt::format("{} '{}': is also the file of {}; give each output its own name", name, *path, other));
      }
    }
    seen.emplace_back(name, *path);
  }
}

/// Reads the input and refuses it if an option asks for what it cannot give.
io::ParticleData loadInput(const AnalyzeOptions& opt) {
  const io::ParticleData data = io::readParticles(opt.input);
  const Index n = data.count();
  if (opt.removeSphere >= n) {
    throw ConfigError(
        n == 0 ? fmt::format("--remove {}: the packing has no spheres", opt.removeSphere)
               : fmt::format("--remove {}: the packing has {} spheres (indices 0..{})", opt.removeSphere, n, n - 1));
  }
  if (opt.velocityRattlers && n > 0 && !data.velocity) {
    throw ConfigError(
        fmt::format("--velocity-rattlers: {} has no velocities; write it with `polydem jam --velocities`", opt.input));
  }
  if (!opt.skCsv.empty() && n == 0) {
    throw InputError(
        fmt::format("--sk-csv: {} has no spheres, so S(k) is undefined (0/0); nothing computed", opt.input));
  }
  if (!opt.skCsv.empty() && !data.box.fullyPeriodic()) {
    throw InputError(
        fmt::format("--sk-csv: S(k) needs a box periodic on every axis; {} has {}", opt.input, data.box.describe()));
  }
  if (!opt.channelsCsv.empty() && n == 0) {
    throw InputError(
        fmt::format("--channels-csv: {} has no spheres, so there are no channels (f is 0/0); nothing "
                    "computed",
                    opt.input));
  }
  return data;
}

/// The contact-network outputs the input cannot support are refused before the contact search.
void checkContactOutputs(const AnalyzeOptions& opt, const io::ParticleData& data) {
  const Index n = data.count();
  if (!opt.correlationCsv.empty() && n < 2) {
    throw InputError(
        fmt::format("--gr-csv: {} has {} sphere{}, so g(x) (pairs over the ideal-gas count) is "
                    "undefined; nothing computed",
                    opt.input, n, n == 1 ? "" : "s"));
  }
  if (!opt.correlationCsv.empty()) {
    if (!data.box.fullyPeriodic()) {
      throw InputError(
          fmt::format("--gr-csv: g(x) is normalised by the ideal-gas pair count of a periodic box; {} "
                      "has {}",
                      opt.input, data.box.describe()));
    }
    // Pairs are counted by the minimum image, which misses images beyond half a box length.
    const double reach = opt.correlationMax * 2.0 * data.radius.maxCoeff();
    if (2.0 * reach > data.box.lengths().minCoeff()) {
      throw ConfigError(fmt::format(
          "--gr-max {}: g(x) up to x = {} needs centre distances up to {} x 2 r_max = {:.6g}, more than half the "
          "shortest box length {:.6g}; lower --gr-max below {:.4g}",
          opt.correlationMax, opt.correlationMax, opt.correlationMax, reach, data.box.lengths().minCoeff(),
          data.box.lengths().minCoeff() / (4.0 * data.radius.maxCoeff())));
    }
  }
  if (!opt.coordinationCsv.empty() && n == 0) {
    throw InputError(
        fmt::format("--z-csv: {} has no spheres, so Z(tau) (contacts per sphere) is undefined; "
                    "nothing computed",
                    opt.input));
  }
}

}  // namespace

/// The run of `polydem analyze` on validated options: load, compute, report, write.
int run(const AnalyzeOptions& opt) {
  checkOutputs(opt);
  const io::ParticleData data = loadInput(opt);
  if (opt.structureOnly) {
    printHeader(opt, data);
    analyzeStructure(opt, data, nullptr);
    return 0;
  }
  checkContactOutputs(opt, data);
  const ContactAnalysis contacts = computeContacts(opt, data);
  reportContacts(opt, data, contacts);
  analyzeStructure(opt, data, &contacts.net);
  if (opt.certify) certifyJamming(opt, data, contacts.net);
  if (opt.leakCollisions > 0.0) runLeakTest(opt, data, contacts.net);
  return 0;
}

}  // namespace analyze

Runner addAnalyze(CLI::App& app) {
  auto opt = std::make_shared<analyze::AnalyzeOptions>();
  CLI::App* cmd = app.add_subcommand(
      "analyze", "contact network, rattlers, isostaticity, Z(tau) and g(r) of a hard-sphere packing");
  analyze::addContactOptions(*cmd, *opt);
  analyze::addCertifyOptions(*cmd, *opt);
  analyze::addLeakOptions(*cmd, *opt);
  CLI::Option* velocityOption = analyze::addStructureOptions(*cmd, *opt);
  return [opt, velocityOption, cmd]() {
    analyze::validateOptions(*opt, *cmd, *velocityOption);
    return analyze::run(*opt);
  };
}

}  // namespace polydem::app
