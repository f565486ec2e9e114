// polydem analyze: contact network, rattlers, isostaticity, cumulative coordination Z(tau) and the pair
// correlation g(x) of a hard-sphere packing (e.g. one written by `polydem jam`); structure of any
// configuration (gas, liquid, crystal, packing): bond-orientational order and crystallinity (--order),
// channel sizes (--channels-csv), S(k) and chi(k) (--sk-csv), rattlers by speed (--velocity-rattlers).
//
// Verdicts only where they apply (issue 15): before any contact statistics or jamming verdict the input
// must be a valid hard-sphere packing (jamming::requireHardSpherePacking: no overlap beyond the contact
// tolerance, no density above what any packing of its radii can have); the contact tolerance comes from
// the packing's reduced pressure, which is never assumed (the file's attribute, --pressure or
// --contact-gap); quantities that do not exist for the input (no spheres, an empty backbone) are printed
// as "undefined" with the reason, never as nan or as a vacuous verdict.
#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/common.hpp"
#include "apps/polydem/validators.hpp"
#include "broadphase/registry.hpp"
#include "core/errors.hpp"
#include "core/io/attributes.hpp"
#include "core/io/particle_file.hpp"
#include "core/io/safe_output.hpp"
#include "edmd/compression.hpp"
#include "jamming/contact_network.hpp"
#include "jamming/ideal_contacts.hpp"
#include "jamming/load_protocols.hpp"
#include "jamming/pressure_leak.hpp"
#include "structure/bond_order.hpp"
#include "structure/channel_size.hpp"
#include "structure/delaunay_neighbours.hpp"
#include "structure/rattlers.hpp"
#include "structure/structure_factor.hpp"

namespace polydem::app {

namespace {

struct AnalyzeOptions {
  std::string input;
  double contactGap = 0.0;
  double pressure = 0.0;
  std::string broadPhase = "hgrid-td";
  std::string coordinationCsv;
  std::string correlationCsv;
  double correlationMax = 3.0;
  int correlationBins = 600;
  bool certify = false;
  Index removeSphere = -1;
  std::string motionCsv;
  double loadGap = 0.05;
  double displacementLimit = 1e-3;
  int loads = 2;
  std::string lpSolver = "auto";
  int subpackingRounds = 1;
  std::string loadTest = "sequential";
  double beta = 0.01;
  double maxLimit = 0.05;
  double meanLimit = 1e-3;
  int maxSteps = 10;
  bool noLocalRattlers = false;
  bool strict = false;
  bool skipIdeal = false;
  double leakCollisions = 0.0;
  int leakBlocks = 20;
  double leakTolerance = 1e-3;
  double leakDrift = 1.5;
  bool structureOnly = false;
  bool order = false;
  std::string channelsCsv;
  std::string skCsv;
  double skMax = 20.0;
  double skMaxVectors = 2e6;
  std::vector<std::string> velocityThreshold;  // empty (or "") with the flag alone: 1e-4
};

std::string csvText(const std::string& header, const std::vector<double>& a, const std::vector<double>& b) {
  std::string text = header + "\n";
  for (std::size_t k = 0; k < a.size(); ++k) text += fmt::format("{:.10g},{:.10g}\n", a[k], b[k]);
  return text;
}

double solidVolume(const io::ParticleData& data) {
  double volume = 0.0;
  for (Index i = 0; i < data.count(); ++i) volume += 4.0 / 3.0 * kPi * std::pow(data.radius[i], 3);
  return volume;
}

void printHeader(const AnalyzeOptions& opt, const io::ParticleData& data) {
  const Index n = data.count();
  fmt::print("{}: {} spheres in a box {}, size ratio {}\n", opt.input, n, data.box.describe(),
             n ? fmt::format("{:.4g}", data.radius.maxCoeff() / data.radius.minCoeff())
               : std::string("undefined (no spheres)"));
  fmt::print("packing fraction        {:.8f}\n", solidVolume(data) / data.box.volume());
}

/// --order, --channels-csv, --sk-csv, --velocity-rattlers: structure of any configuration. `net` (the
/// contact network, if computed) lets the speed rattlers be compared with the contact-count ones.
void analyzeStructure(const AnalyzeOptions& opt, const io::ParticleData& data, bool velocityRattlers,
                      double velocityThreshold, const jamming::ContactNetwork* net) {
  const SphereView spheres{data.position, data.radius};
  const Index n = data.count();
  if (velocityRattlers) {
    if (n == 0) {
      fmt::print("rattlers by speed       undefined (no spheres)\n");
    } else {
      const structure::VelocityRattlers r =
          structure::velocityRattlers(*data.velocity, data.radius, data.box, velocityThreshold);
      fmt::print(
          "rattlers (|v|/v_rms <= {:.1e}) {} ({:.2f}%), volume fraction nu_r {:.5f} ({:.2f}% of the solid "
          "volume)\n",
          velocityThreshold, r.count, 100.0 * r.numberFraction, r.volumeFraction, 100.0 * r.volumeShare);
      if (net) {
        Index both = 0, geometric = 0;
        for (Index i = 0; i < n; ++i) {
          geometric += net->rattler[static_cast<std::size_t>(i)] != 0;
          both += net->rattler[static_cast<std::size_t>(i)] && r.rattler[static_cast<std::size_t>(i)];
        }
        fmt::print("  vs contact-count rattlers: {} of {} agree ({} by speed only, {} by contacts only)\n", both,
                   geometric, r.count - both, geometric - both);
      }
    }
  }
  if (opt.order || !opt.channelsCsv.empty()) {
    const auto start = std::chrono::steady_clock::now();
    const structure::NeighbourList nb = structure::delaunayNeighbours(spheres, data.box);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    fmt::print("Delaunay neighbours     {} (image shell {:.4g}, {} triangulation(s), {:.2f} s){}\n",
               n ? fmt::format("{:.3f} per sphere", nb.meanDegree()) : std::string("undefined (no spheres)"),
               nb.imageShell, nb.attempts, seconds,
               nb.unverifiedCells ? fmt::format(", {} cells unverified", nb.unverifiedCells) : std::string());
    if (nb.hidden) fmt::print("  {} spheres hidden by overlapping larger ones (no neighbours)\n", nb.hidden);
    if (opt.order) {
      if (nb.entries() == 0) {
        fmt::print("bond order (l = 6)      undefined (no Delaunay neighbours: {})\n",
                   n ? "no sphere has a neighbour" : "no spheres");
      } else {
        const structure::BondOrder order = structure::bondOrder(nb);
        fmt::print("bond order (l = 6)      p_c = {:.4f} ({} solid-like of {}), mean q6 = {:.4f}, Q6 = {:.4f}\n",
                   order.crystallineFraction, order.solidCount, n, order.meanQ, order.globalQ);
      }
    }
    if (!opt.channelsCsv.empty()) {
      const auto t0 = std::chrono::steady_clock::now();
      const structure::ChannelHistogram h = structure::channelSizes(spheres, nb);
      const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (h.channels == 0) {
        fmt::print("channels R_j/r_i        {} acute of {} triangles, none with a gap circle: mean and sd undefined "
                   "({:.2f} s)\n",
                   h.acute, h.triangles, sec);
      } else {
        fmt::print(
            "channels R_j/r_i        {} acute of {} triangles, {} with a gap circle; mean {:.4f}, sd {:.4f} "
            "({:.2f} s)\n",
            h.acute, h.triangles, h.channels, h.mean, h.stddev, sec);
      }
      if (h.overflow) fmt::print("  {} channels with R_j/r_i >= 1e4 are not in the histogram\n", h.overflow);
      std::string text = "x_low,x_mid,f,count\n";
      for (std::size_t k = 0; k < h.counts.size(); ++k) {
        // f is a density over the channels; with none it does not exist (0/0), and the counts say so.
        const double f = h.channels > 0 && std::isfinite(h.density[k]) ? h.density[k] : 0.0;
        text += fmt::format("{:.4f},{:.4f},{:.8g},{}\n", k * h.binWidth, (k + 0.5) * h.binWidth, f, h.counts[k]);
      }
      io::writeFileAtomically(opt.channelsCsv, text);
      fmt::print("wrote {}\n", opt.channelsCsv);
    }
  }
  if (!opt.skCsv.empty()) {
    const auto t0 = std::chrono::steady_clock::now();
    const structure::StructureFactor sk = structure::structureFactor(
        spheres, data.box, {.kMax = opt.skMax, .maxVectors = static_cast<std::int64_t>(opt.skMaxVectors)});
    const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::size_t peak = 0;
    for (std::size_t s = 1; s < sk.s.size(); ++s) {
      if (sk.s[s] > sk.s[peak]) peak = s;
    }
    if (sk.k.empty()) {
      fmt::print("S(k)                    no wave vector up to K = {} in this box ({:.2f} s): S undefined\n", opt.skMax,
                 sec);
    } else {
      fmt::print(
          "S(k)                    {} wave vectors (stride {}) in {} shells up to K = {} ({:.2f} s); S(K_min = "
          "{:.3f}) = {:.4g}, peak S = {:.4g} at K = {:.3f}\n",
          sk.totalVectors, sk.stride, sk.k.size(), opt.skMax, sec, sk.k[0], sk.s[0], sk.s[peak], sk.k[peak]);
    }
    std::string text = "K,S,chi,vectors\n";
    for (std::size_t s = 0; s < sk.k.size(); ++s) {
      text += fmt::format("{:.6f},{:.8g},{:.8g},{}\n", sk.k[s], sk.s[s], sk.chi[s], sk.vectors[s]);
    }
    io::writeFileAtomically(opt.skCsv, text);
    fmt::print("wrote {}\n", opt.skCsv);
  }
}

/// The packing's reduced pressure: --pressure, else the file's `reduced_pressure` attribute; nullopt if
/// neither (then only --contact-gap can set the contact tolerance). Throws InputError for a malformed or
/// non-positive attribute.
std::optional<double> packingPressure(const AnalyzeOptions& opt, const io::ParticleData& data) {
  if (opt.pressure > 0.0) return opt.pressure;
  const std::optional<double> p = io::numericAttribute(data, "reduced_pressure", opt.input);
  if (p && !(*p > 0.0)) {
    throw InputError(fmt::format("{}: attribute reduced_pressure: {} is not a positive reduced pressure; give "
                                 "--pressure P (or --contact-gap TAU)",
                                 opt.input, *p));
  }
  return p;
}

}  // namespace

Runner addAnalyze(CLI::App& app) {
  auto opt = std::make_shared<AnalyzeOptions>();
  CLI::App* cmd = app.add_subcommand(
      "analyze", "contact network, rattlers, isostaticity, Z(tau) and g(r) of a hard-sphere packing");
  cmd->add_option("input", opt->input, "particle file (.h5/.hdf5 or text)")->required();
  cmd->add_option("--contact-gap", opt->contactGap,
                  "contact when gap <= this x (r_i + r_j), also the largest overlap (x the smaller radius) "
                  "accepted; 0 = from the reduced pressure (see --pressure)")
      ->check(finiteIn(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--pressure", opt->pressure,
                  "reduced pressure of the packing for the default contact gap (0 = the file's reduced_pressure "
                  "attribute; without one, give --pressure or --contact-gap)")
      ->check(finiteNonNegative())
      ->capture_default_str();
  cmd->add_option("--broad-phase", opt->broadPhase, "broad phase for the pair searches")->capture_default_str();
  cmd->add_option("--z-csv", opt->coordinationCsv, "write Z(tau) for tau = 1e-15 .. 1e-1 (tau,Z)");
  cmd->add_option("--gr-csv", opt->correlationCsv, "write g(x), x = r_ij / (r_i + r_j) (x,g)");
  cmd->add_option("--gr-max", opt->correlationMax, "--gr-csv: largest x of g(x), > 1")
      ->check(finiteIn(1.0, 1e3))
      ->capture_default_str();
  cmd->add_option("--gr-bins", opt->correlationBins, "--gr-csv: bins of g(x)")
      ->check(CLI::Range(1, 100000000))
      ->capture_default_str();
  cmd->add_flag("--certify", opt->certify,
                "linear-programming test of collective jamming (GLPK): 'jammed' or an unjamming motion");
  cmd->add_option("--remove", opt->removeSphere,
                  "--certify, --leak-test: take this sphere (index) out (e.g. a backbone sphere: a deliberately "
                  "unjammed packing)")
      ->check(CLI::Range(0, std::numeric_limits<Index>::max()));
  cmd->add_option("--load-gap", opt->loadGap,
                  "--certify: pairs with gap <= this x (r_i + r_j) are constraints of the load test")
      ->check(finitePositive())
      ->capture_default_str();
  cmd->add_option("--load-test", opt->loadTest,
                  "--certify: sequential = the seed's Algorithm 14 for packings with gaps (each load's motion is "
                  "scaled to the first collision, applied and loaded again; verdict from the accumulated "
                  "displacements); single = one LP per load, any sphere beyond --displacement-limit unjams "
                  "(Algorithm 13, with --subpacking-rounds)")
      ->check(CLI::IsMember({"sequential", "single"}))
      ->capture_default_str();
  cmd->add_option("--displacement-limit", opt->displacementLimit,
                  "--certify: single: a load moving a sphere further than this (mean diameters) unjams; "
                  "sequential: reported for the LPs' own motions")
      ->check(finitePositive())
      ->capture_default_str();
  cmd->add_option("--beta", opt->beta,
                  "--certify sequential: load again while a step moves a sphere by more than this (own diameters)")
      ->check(finitePositive())
      ->capture_default_str();
  cmd->add_option("--max-limit", opt->maxLimit,
                  "--certify sequential: unjammed if a loaded sphere moves further in all (own diameters)")
      ->check(finitePositive())
      ->capture_default_str();
  cmd->add_option("--mean-limit", opt->meanLimit,
                  "--certify sequential: unjammed if the mean displacement of the loaded spheres exceeds this")
      ->check(finitePositive())
      ->capture_default_str();
  cmd->add_option("--max-steps", opt->maxSteps, "--certify sequential: LPs per load at most")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  cmd->add_option("--loads", opt->loads, "--certify: random loads (each also applied reversed), at least 1")
      ->check(CLI::Range(1, 1000000))
      ->capture_default_str();
  cmd->add_option("--lp-solver", opt->lpSolver,
                  "--certify: load-test LP solver: simplex (GLPK), interior (own interior point with CHOLMOD), "
                  "auto = simplex up to 2000 spheres")
      ->check(CLI::IsMember({"auto", "simplex", "interior"}))
      ->capture_default_str();
  cmd->add_option("--subpacking-rounds", opt->subpackingRounds,
                  "--certify: if the packing is unjammed, set the displaced spheres aside (sequential: remove them) "
                  "and load the rest again, up to this many rounds in all, to find a jammed subpacking (seed "
                  "Algorithm 13)")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  cmd->add_flag("--strict", opt->strict,
                "--certify --load-test single: strict jamming, the periodic cell may deform (volume not growing)");
  cmd->add_flag("--no-local-rattlers", opt->noLocalRattlers,
                "--certify: load every backbone sphere, also those the local LP (neighbours fixed) finds loose");
  cmd->add_flag("--no-ideal", opt->skipIdeal, "--certify: skip the ideal-contact LP test");
  cmd->add_option("--motion-csv", opt->motionCsv,
                  "--certify: write the load test's motion (the unjamming motion, or the displacements the loads "
                  "achieved)");
  cmd->add_option("--leak-test", opt->leakCollisions,
                  "pressure-leak test (seed ch. 9): plain event-driven dynamics for this many collisions per particle; "
                  "a jammed packing keeps its pressure and its backbone does not drift (with --remove: without the "
                  "sphere)")
      ->check(finitePositive());
  cmd->add_option("--leak-blocks", opt->leakBlocks, "--leak-test: blocks (one pressure each)")
      ->check(CLI::Range(4, 100000))
      ->capture_default_str();
  cmd->add_option("--leak-tolerance", opt->leakTolerance,
                  "--leak-test: a relative pressure drop (last quarter against first) beyond this is a leak")
      ->check(finitePositive())
      ->capture_default_str();
  cmd->add_option("--leak-drift", opt->leakDrift,
                  "--leak-test: a drift: the last quarter's mean backbone displacement above this factor (> 1) x "
                  "the first half's largest")
      ->check(finiteIn(1.0, 1e300))
      ->capture_default_str();
  cmd->add_flag("--structure-only", opt->structureOnly,
                "skip the contact network and jamming statistics (gases, liquids, crystals)");
  cmd->add_flag("--order", opt->order,
                "bond-orientational order over weighted Delaunay neighbours: q6, Q6, crystalline fraction p_c "
                "(d6 > 0.65, >= 6 connections)");
  cmd->add_option("--channels-csv", opt->channelsCsv,
                  "write the channel-size histogram f(R_j / r_i), bin 0.01 (x_low,x_mid,f,count)");
  cmd->add_option("--sk-csv", opt->skCsv,
                  "write shell-averaged S(k) and spectral density chi(k) (K,S,chi,vectors), "
                  "K = k D, D = 2 <r>; periodic boxes only");
  cmd->add_option("--sk-kmax", opt->skMax, "--sk-csv: largest K = k D")->check(finitePositive())->capture_default_str();
  cmd->add_option("--sk-max-vectors", opt->skMaxVectors,
                  "--sk-csv: above this many wave vectors use every s-th per axis (coarser shells; 0 = all)")
      ->check(finiteIn(0.0, 1e15))
      ->capture_default_str();
  CLI::Option* velocityOption =
      cmd->add_option("--velocity-rattlers", opt->velocityThreshold,
                      "rattlers by speed: |v| / v_rms <= threshold (default 1e-4; needs velocities, `polydem jam "
                      "--velocities`); give the value with '=' or after the input file")
          ->expected(0, 1);

  return [opt, velocityOption, cmd]() {
    auto given = [&](const char* name) { return cmd->get_option(name)->count() > 0; };
    // Options that only act with another one are refused without it rather than silently ignored.
    auto needs = [&](std::initializer_list<const char*> names, bool present, const char* what) {
      for (const char* name : names) {
        if (given(name) && !present) throw ConfigError(fmt::format("{} needs {}", name, what));
      }
    };
    needs({"--load-gap", "--load-test", "--displacement-limit", "--beta", "--max-limit", "--mean-limit", "--max-steps",
           "--loads", "--lp-solver", "--subpacking-rounds", "--strict", "--no-local-rattlers", "--no-ideal",
           "--motion-csv"},
          opt->certify, "--certify");
    needs({"--leak-blocks", "--leak-tolerance", "--leak-drift"}, given("--leak-test"), "--leak-test");
    needs({"--remove"}, opt->certify || given("--leak-test"), "--certify or --leak-test");
    needs({"--gr-max", "--gr-bins"}, !opt->correlationCsv.empty(), "--gr-csv");
    needs({"--sk-kmax", "--sk-max-vectors"}, !opt->skCsv.empty(), "--sk-csv");
    if (opt->structureOnly) {
      for (const char* name : {"--certify", "--leak-test", "--z-csv", "--gr-csv", "--pressure", "--contact-gap"}) {
        if (given(name)) {
          throw ConfigError(
              fmt::format("{} needs the contact network, which --structure-only skips: drop one of them", name));
        }
      }
    }
    if (!(opt->correlationMax > 1.0)) {
      throw ConfigError(fmt::format("--gr-max: {} must be > 1 (x = r_ij / (r_i + r_j) is 1 at contact)",
                                    opt->correlationMax));
    }
    if (!(opt->leakDrift > 1.0)) {
      throw ConfigError(fmt::format("--leak-drift: {} must be > 1 (a ratio of displacements)", opt->leakDrift));
    }
    if (opt->strict && opt->loadTest != "single") {
      throw ConfigError("--strict needs --load-test single (the sequential test keeps the cell fixed)");
    }
    if (opt->certify && !opt->skipIdeal && !jamming::jammingTestAvailable()) {
      throw ConfigError("--certify: the ideal-contact LP test needs GLPK (libglpk-dev), which this build did not "
                        "find; add --no-ideal to run the load test alone");
    }
    try {
      broadphase::makeBroadPhase(opt->broadPhase);
    } catch (const ConfigError& e) {
      throw ConfigError(fmt::format("--broad-phase: {}", e.what()));
    }
    double velocityThreshold = 1e-4;
    if (!opt->velocityThreshold.empty() && !opt->velocityThreshold.front().empty()) {
      const std::optional<double> value = io::parseFiniteDouble(opt->velocityThreshold.front());
      if (!value || !(*value > 0.0)) {
        throw ConfigError(fmt::format("--velocity-rattlers: '{}' is not a finite number > 0 (expected e.g. 1e-4)",
                                      opt->velocityThreshold.front()));
      }
      velocityThreshold = *value;
    }
    // Every output checked before any work: writable, and neither the input nor another output.
    {
      const std::vector<std::filesystem::path> inputs{opt->input};
      std::vector<std::pair<const char*, std::string>> seen;
      for (const auto& [name, path] : std::initializer_list<std::pair<const char*, const std::string*>>{
               {"--z-csv", &opt->coordinationCsv},
               {"--gr-csv", &opt->correlationCsv},
               {"--motion-csv", &opt->motionCsv},
               {"--channels-csv", &opt->channelsCsv},
               {"--sk-csv", &opt->skCsv}}) {
        if (path->empty()) continue;
        io::checkOutputPath(*path, name, inputs);
        for (const auto& [other, otherPath] : seen) {
          if (io::samePath(*path, otherPath)) {
            throw ConfigError(fmt::format("{} '{}': is also the file of {}; give each output its own name", name,
                                          *path, other));
          }
        }
        seen.emplace_back(name, *path);
      }
    }

    const io::ParticleData data = io::readParticles(opt->input);
    const Index n = data.count();
    if (opt->removeSphere >= n) {
      throw ConfigError(n == 0 ? fmt::format("--remove {}: the packing has no spheres", opt->removeSphere)
                               : fmt::format("--remove {}: the packing has {} spheres (indices 0..{})",
                                             opt->removeSphere, n, n - 1));
    }
    const bool velocityRattlers = velocityOption->count() > 0;
    if (velocityRattlers && n > 0 && !data.velocity) {
      throw ConfigError(fmt::format(
          "--velocity-rattlers: {} has no velocities; write it with `polydem jam --velocities`", opt->input));
    }
    if (!opt->skCsv.empty() && n == 0) {
      throw InputError(fmt::format("--sk-csv: {} has no spheres, so S(k) is undefined (0/0); nothing computed",
                                   opt->input));
    }
    if (!opt->skCsv.empty() && !data.box.fullyPeriodic()) {
      throw InputError(fmt::format("--sk-csv: S(k) needs a box periodic on every axis; {} has {}", opt->input,
                                   data.box.describe()));
    }
    if (!opt->channelsCsv.empty() && n == 0) {
      throw InputError(fmt::format("--channels-csv: {} has no spheres, so there are no channels (f is 0/0); nothing "
                                   "computed",
                                   opt->input));
    }
    const SphereView spheres{data.position, data.radius};
    if (opt->structureOnly) {
      printHeader(*opt, data);
      analyzeStructure(*opt, data, velocityRattlers, velocityThreshold, nullptr);
      return 0;
    }
    if (!opt->correlationCsv.empty() && n < 2) {
      throw InputError(fmt::format("--gr-csv: {} has {} sphere{}, so g(x) (pairs over the ideal-gas count) is "
                                   "undefined; nothing computed",
                                   opt->input, n, n == 1 ? "" : "s"));
    }
    if (!opt->correlationCsv.empty()) {
      if (!data.box.fullyPeriodic()) {
        throw InputError(fmt::format("--gr-csv: g(x) is normalised by the ideal-gas pair count of a periodic box; {} "
                                     "has {}",
                                     opt->input, data.box.describe()));
      }
      // Pairs are counted by the minimum image, which misses images beyond half a box length.
      const double reach = opt->correlationMax * 2.0 * data.radius.maxCoeff();
      if (2.0 * reach > data.box.lengths().minCoeff()) {
        throw ConfigError(fmt::format(
            "--gr-max {}: g(x) up to x = {} needs centre distances up to {} x 2 r_max = {:.6g}, more than half the "
            "shortest box length {:.6g}; lower --gr-max below {:.4g}",
            opt->correlationMax, opt->correlationMax, opt->correlationMax, reach, data.box.lengths().minCoeff(),
            data.box.lengths().minCoeff() / (4.0 * data.radius.maxCoeff())));
      }
    }
    if (!opt->coordinationCsv.empty() && n == 0) {
      throw InputError(fmt::format("--z-csv: {} has no spheres, so Z(tau) (contacts per sphere) is undefined; "
                                   "nothing computed",
                                   opt->input));
    }

    // The contact tolerance rests on the pressure, which is never assumed.
    const std::optional<double> pressure = packingPressure(*opt, data);
    if (!pressure && !(opt->contactGap > 0.0)) {
      throw ConfigError(fmt::format(
          "{} has no reduced_pressure attribute, and the contact network (contacts, rattlers, isostaticity, "
          "--certify, --leak-test) needs the contact gap it implies: give --pressure P (the packing's reduced "
          "pressure) or --contact-gap TAU (contact when gap <= TAU (r_i + r_j)), or --structure-only",
          opt->input));
    }
    jamming::ContactOptions contact;
    contact.relativeGap = opt->contactGap > 0.0 ? opt->contactGap : jamming::defaultContactGap(*pressure);
    contact.broadPhase = opt->broadPhase;
    const jamming::PackingValidity validity = jamming::requireHardSpherePacking(
        spheres, data.box, {.overlapTolerance = contact.relativeGap, .broadPhase = opt->broadPhase}, opt->input,
        data.id);
    // Contacts are found by the minimum image; a periodic length below 2 (2 r_max + gap) would let a sphere
    // touch two images of another, which the search cannot represent.
    const jamming::ContactNetwork net = [&] {
      try {
        return jamming::analyseContacts(spheres, data.box, contact);
      } catch (const ConfigError& e) {
        throw InputError(fmt::format("{}: the box is too small for the contact network: {}", opt->input, e.what()));
      }
    }();
    const double phi = solidVolume(data) / data.box.volume();

    printHeader(*opt, data);
    fmt::print("density bound           {:.8f} ({}); no overlap beyond the contact tolerance\n",
               validity.densityBound,
               validity.equalSpheres          ? "FCC, equal spheres"
               : validity.densityBound < 1.0 ? "pi/sqrt(18) <r^3>/r_min^3"
                                             : "1, disjoint spheres");
    if (pressure) {
      const std::string source = opt->pressure > 0.0 ? "--pressure" : "file attribute";
      const std::string estimate =
          net.backbone == 0 ? std::string("phi_J estimate undefined: empty backbone, not near jamming")
          : *pressure > 3.0 ? fmt::format("phi_J estimate {:.8f}", edmd::jammingDensityEstimate(phi, *pressure))
                            : std::string("phi_J estimate undefined: needs p > 3");
      fmt::print("reduced pressure        {:.4g} ({})  ({})\n", *pressure, source, estimate);
    } else {
      fmt::print("reduced pressure        unknown (no reduced_pressure attribute, no --pressure): phi_J estimate "
                 "undefined\n");
    }
    const std::optional<jamming::PairGap> gap = jamming::smallestGap(spheres, data.box, opt->broadPhase);
    auto id = [&](Index i) { return data.id.empty() ? i : data.id[static_cast<std::size_t>(i)]; };
    if (gap) {
      fmt::print("smallest gap            {:.3g} (relative to r_i + r_j; negative = overlap), spheres {} and {}\n",
                 gap->gap, id(gap->i), id(gap->j));
    } else {
      fmt::print("smallest gap            undefined (fewer than two spheres)\n");
    }
    fmt::print("contacts (gap <= {:.1e}) {}  z = {}\n", contact.relativeGap, net.contacts.size(),
               n ? fmt::format("{:.4f}", net.meanCoordination()) : std::string("undefined (no spheres)"));
    fmt::print("rattlers (< {} contacts)  {} ({})\n", contact.minContacts, n - net.backbone,
               n ? fmt::format("{:.2f}%", 100.0 * net.rattlerFraction()) : std::string("undefined: no spheres"));
    fmt::print("backbone                {} spheres, {} contacts, z = {}\n", net.backbone, net.backboneContacts,
               net.backbone ? fmt::format("{:.4f}", net.backboneCoordination())
                            : std::string("undefined (empty backbone)"));
    if (net.backbone == 0) {
      fmt::print("isostaticity            undefined (empty backbone: every sphere is a rattler)\n");
    } else {
      const std::int64_t excess = net.isostaticExcess();
      fmt::print("isostaticity            contacts - (3N' {:+d}) = {} ({})\n", 1 - net.periodicAxes, excess,
                 excess == 0  ? "isostatic"
                 : excess < 0 ? "hypostatic: not collectively jammed"
                              : "hyperstatic");
    }
    std::map<int, Index> histogram;
    for (Index i = 0; i < n; ++i) {
      if (!net.rattler[static_cast<std::size_t>(i)]) ++histogram[net.coordination[static_cast<std::size_t>(i)]];
    }
    std::string hist;
    for (const auto& [z, count] : histogram) hist += fmt::format(" {}:{}", z, count);
    fmt::print("backbone contact numbers{}\n", hist.empty() ? " none (empty backbone)" : hist);

    if (n == 0) {
      fmt::print("Z(tau), all spheres     undefined (no spheres)\n");
    } else {
      // tau up to 0.1, as far as the minimum image reaches on periodic axes: tau 2 r_max <= L / 2 - 2 r_max.
      double periodicMin = std::numeric_limits<double>::infinity();
      for (int k = 0; k < 3; ++k) {
        if (data.box.periodic(k)) periodicMin = std::min(periodicMin, data.box.length(k));
      }
      const double rmax = data.radius.maxCoeff();
      const double tauLimit = (periodicMin / 2.0 - 2.0 * rmax) / (2.0 * rmax * (1.0 + 1e-9));
      std::vector<double> taus;
      for (int e = -15; e <= -1; ++e) {
        if (std::pow(10.0, e) <= tauLimit) taus.push_back(std::pow(10.0, e));
      }
      const std::vector<double> z = jamming::cumulativeCoordination(spheres, data.box, taus, opt->broadPhase);
      std::string line;
      for (std::size_t k = 0; k < taus.size(); ++k) line += fmt::format(" {:.0e}:{:.3f}", taus[k], z[k]);
      if (taus.size() < 15) {
        line += taus.empty() ? std::string(" undefined (the box is too small for gaps of 1e-15)")
                             : fmt::format("; undefined above tau = {:.0e} (gaps beyond half the box length)",
                                           taus.back());
      }
      fmt::print("Z(tau), all spheres    {}\n", line);
      if (!opt->coordinationCsv.empty()) {
        io::writeFileAtomically(opt->coordinationCsv, csvText("tau,Z", taus, z));
        fmt::print("wrote {}\n", opt->coordinationCsv);
      }
    }
    if (!opt->correlationCsv.empty()) {
      const jamming::PairCorrelation g =
          jamming::pairCorrelation(spheres, data.box, opt->correlationMax, opt->correlationBins, opt->broadPhase);
      io::writeFileAtomically(opt->correlationCsv, csvText("x,g", g.x, g.g));
      fmt::print("wrote {}\n", opt->correlationCsv);
    }
    analyzeStructure(*opt, data, velocityRattlers, velocityThreshold, &net);
    if (opt->certify) {
      jamming::ContactNetwork tested = net;
      if (opt->removeSphere >= 0) {
        // The sphere disappears from the test (no constraints from it); the rattlers stay those of the
        // intact packing, so its neighbours keep being tested.
        tested.rattler[static_cast<std::size_t>(opt->removeSphere)] = 1;
        fmt::print("removed sphere {} ({} contacts, {}) for the jamming test\n", opt->removeSphere,
                   net.coordination[static_cast<std::size_t>(opt->removeSphere)],
                   net.rattler[static_cast<std::size_t>(opt->removeSphere)] ? "a rattler" : "a backbone sphere");
      }
      if (!opt->skipIdeal) {
        const jamming::JammingTestResult ideal = jamming::testCollectiveJamming(spheres, data.box, tested);
        fmt::print("ideal-contact LP test   {} ({:.2f} s{})\n", ideal.verdict, ideal.seconds,
                   ideal.lps > 0 ? fmt::format("; LP optima: opening {:.3g}, floppy {:.3g}", ideal.openingObjective,
                                               ideal.floppyObjective)
                                 : std::string("; no LP solved"));
        std::fflush(stdout);
      }
      jamming::LoadTestOptions loadOptions;
      loadOptions.gapTolerance = opt->loadGap;
      loadOptions.displacementLimit = opt->displacementLimit;
      loadOptions.loads = opt->loads;
      loadOptions.subpackingRounds = opt->subpackingRounds;
      loadOptions.protocol =
          opt->loadTest == "sequential" ? jamming::LoadProtocol::Sequential : jamming::LoadProtocol::SingleLp;
      loadOptions.beta = opt->beta;
      loadOptions.maxLimit = opt->maxLimit;
      loadOptions.meanLimit = opt->meanLimit;
      loadOptions.maxSteps = opt->maxSteps;
      loadOptions.localRattlers = !opt->noLocalRattlers;
      loadOptions.strict = opt->strict;
      loadOptions.progress = [](const std::string& line) {
        fmt::print("  load test: {}\n", line);
        std::fflush(stdout);
      };
      loadOptions.solver = opt->lpSolver == "simplex"    ? jamming::LpSolver::Simplex
                           : opt->lpSolver == "interior" ? jamming::LpSolver::InteriorPoint
                                                         : jamming::LpSolver::Automatic;
      if (opt->removeSphere >= 0) loadOptions.removed.push_back(opt->removeSphere);
      const jamming::LoadTestResult load = jamming::testJammingUnderLoad(spheres, data.box, tested, loadOptions);
      const jamming::LoadTestSummary& jam = jamming::summaryOf(load);
      if (jam.solver.empty()) {
        fmt::print("jamming test (loads)    {} (no LP solved)\n", jam.verdict);
      } else {
        fmt::print("jamming test (loads)    {} ({} constraints with gap <= {:.2g} (r_i + r_j), {}, {:.2f} s)\n",
                   jam.verdict, jam.constraints, loadOptions.gapTolerance, jam.solver, jam.seconds);
      }
      if (!opt->motionCsv.empty()) {
        // Radius, contacts and rattler flag with the motion, so the moving spheres can be told apart.
        std::string text = "i,radius,contacts,rattler,dx,dy,dz,moved_over_diameter\n";
        for (Index i = 0; i < n; ++i) {
          const double r = spheres.radius[i];
          text += fmt::format("{},{:.10g},{},{},{:.10g},{:.10g},{:.10g},{:.6g}\n", i, r,
                              net.coordination[static_cast<std::size_t>(i)],
                              tested.rattler[static_cast<std::size_t>(i)] ? 1 : 0, jam.motion(0, i), jam.motion(1, i),
                              jam.motion(2, i), jam.motion.col(i).norm() / (2.0 * r));
        }
        io::writeFileAtomically(opt->motionCsv, text);
        fmt::print("wrote {}\n", opt->motionCsv);
      }
    }
    if (opt->leakCollisions > 0.0) {
      // --remove takes the sphere out of the dynamics too: the hole is the deliberate defect.
      Eigen::Matrix3Xd x = data.position;
      Eigen::VectorXd r = data.radius;
      std::vector<char> watched = net.rattler;
      if (opt->removeSphere >= 0) {
        const Index k = opt->removeSphere, last = n - 1;
        x.col(k) = x.col(last);
        r[k] = r[last];
        watched[static_cast<std::size_t>(k)] = watched[static_cast<std::size_t>(last)];
        x.conservativeResize(3, last);
        r.conservativeResize(last);
        watched.pop_back();
        fmt::print("leak test without sphere {} (the last sphere takes its number)\n", k);
      }
      jamming::LeakTestOptions leak;
      leak.collisionsPerParticle = opt->leakCollisions;
      leak.blocks = opt->leakBlocks;
      leak.pressureTolerance = opt->leakTolerance;
      leak.driftFactor = opt->leakDrift;
      leak.progress = [](const std::string& line) {
        fmt::print("  leak test: {}\n", line);
        std::fflush(stdout);
      };
      const jamming::LeakTestResult result = jamming::testPressureLeak(x, r, data.box, watched, leak);
      if (result.outcome == jamming::JammingVerdict::NotTested) {
        fmt::print("pressure-leak test      {}\n", result.verdict);
      } else {
        fmt::print("pressure-leak test      {} ({} collisions, {:.1f} s, {:.3g} collisions/s)\n", result.verdict,
                   result.counts.collisions, result.seconds,
                   static_cast<double>(result.counts.collisions) / std::max(result.seconds, 1e-9));
      }
    }
    return 0;
  };
}

}  // namespace polydem::app
