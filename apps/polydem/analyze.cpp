// polydem analyze: contact network, rattlers, isostaticity, cumulative coordination Z(tau) and the pair
// correlation g(x) of a hard-sphere packing (e.g. one written by `polydem jam`); structure of any
// configuration (gas, liquid, crystal, packing): bond-orientational order and crystallinity (--order),
// channel sizes (--channels-csv), S(k) and chi(k) (--sk-csv), rattlers by speed (--velocity-rattlers).
#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/common.hpp"
#include "core/errors.hpp"
#include "core/io/particle_file.hpp"
#include "edmd/compression.hpp"
#include "edmd/contact_network.hpp"
#include "edmd/jamming_test.hpp"
#include "edmd/leak_test.hpp"
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

void writeCsv(const std::string& path, const std::string& header, const std::vector<double>& a,
              const std::vector<double>& b) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) throw InputError(fmt::format("{}: cannot open for writing", path));
  fmt::print(f, "{}\n", header);
  for (std::size_t k = 0; k < a.size(); ++k) fmt::print(f, "{:.10g},{:.10g}\n", a[k], b[k]);
  std::fclose(f);
}

/// --order, --channels-csv, --sk-csv, --velocity-rattlers: structure of any configuration. `net` (the
/// contact network, if computed) lets the speed rattlers be compared with the contact-count ones.
void analyzeStructure(const AnalyzeOptions& opt, const io::ParticleData& data, bool velocityRattlers,
                      const edmd::ContactNetwork* net) {
  const SphereView spheres{data.position, data.radius};
  const Index n = data.count();
  if (velocityRattlers) {
    double threshold = 1e-4;
    if (!opt.velocityThreshold.empty() && !opt.velocityThreshold.front().empty()) {
      const std::string& text = opt.velocityThreshold.front();
      std::size_t used = 0;
      try {
        threshold = std::stod(text, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != text.size()) {
        throw ConfigError(fmt::format("--velocity-rattlers: '{}' is not a number (expected e.g. 1e-4)", text));
      }
    }
    if (!data.velocity) {
      throw ConfigError(fmt::format(
          "--velocity-rattlers: {} has no velocities; write it with `polydem jam --velocities`", opt.input));
    }
    const structure::VelocityRattlers r = structure::velocityRattlers(*data.velocity, data.radius, data.box, threshold);
    fmt::print(
        "rattlers (|v|/v_rms <= {:.1e}) {} ({:.2f}%), volume fraction nu_r {:.5f} ({:.2f}% of the solid "
        "volume)\n",
        threshold, r.count, 100.0 * r.numberFraction, r.volumeFraction, 100.0 * r.volumeShare);
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
  if (opt.order || !opt.channelsCsv.empty()) {
    const auto start = std::chrono::steady_clock::now();
    const structure::NeighbourList nb = structure::delaunayNeighbours(spheres, data.box);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    fmt::print("Delaunay neighbours     {:.3f} per sphere (image shell {:.4g}, {} triangulation(s), {:.2f} s){}\n",
               nb.meanDegree(), nb.imageShell, nb.attempts, seconds,
               nb.unverifiedCells ? fmt::format(", {} cells unverified", nb.unverifiedCells) : std::string());
    if (nb.hidden) fmt::print("  {} spheres hidden by overlapping larger ones (no neighbours)\n", nb.hidden);
    if (opt.order) {
      const structure::BondOrder order = structure::bondOrder(nb);
      fmt::print("bond order (l = 6)      p_c = {:.4f} ({} solid-like of {}), mean q6 = {:.4f}, Q6 = {:.4f}\n",
                 order.crystallineFraction, order.solidCount, n, order.meanQ, order.globalQ);
    }
    if (!opt.channelsCsv.empty()) {
      const auto t0 = std::chrono::steady_clock::now();
      const structure::ChannelHistogram h = structure::channelSizes(spheres, nb);
      const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      fmt::print(
          "channels R_j/r_i        {} acute of {} triangles, {} with a gap circle; mean {:.4f}, sd {:.4f} "
          "({:.2f} s)\n",
          h.acute, h.triangles, h.channels, h.mean, h.stddev, sec);
      if (h.overflow) fmt::print("  {} channels with R_j/r_i >= 1e4 are not in the histogram\n", h.overflow);
      std::FILE* f = std::fopen(opt.channelsCsv.c_str(), "w");
      if (!f) throw InputError(fmt::format("{}: cannot open for writing", opt.channelsCsv));
      fmt::print(f, "x_low,x_mid,f,count\n");
      for (std::size_t k = 0; k < h.counts.size(); ++k) {
        fmt::print(f, "{:.4f},{:.4f},{:.8g},{}\n", k * h.binWidth, (k + 0.5) * h.binWidth, h.density[k], h.counts[k]);
      }
      std::fclose(f);
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
    fmt::print(
        "S(k)                    {} wave vectors (stride {}) in {} shells up to K = {} ({:.2f} s); S(K_min = "
        "{:.3f}) = {:.4g}, peak S = {:.4g} at K = {:.3f}\n",
        sk.totalVectors, sk.stride, sk.k.size(), opt.skMax, sec, sk.k.empty() ? 0.0 : sk.k[0],
        sk.s.empty() ? 0.0 : sk.s[0], sk.s.empty() ? 0.0 : sk.s[peak], sk.k.empty() ? 0.0 : sk.k[peak]);
    std::FILE* f = std::fopen(opt.skCsv.c_str(), "w");
    if (!f) throw InputError(fmt::format("{}: cannot open for writing", opt.skCsv));
    fmt::print(f, "K,S,chi,vectors\n");
    for (std::size_t s = 0; s < sk.k.size(); ++s) {
      fmt::print(f, "{:.6f},{:.8g},{:.8g},{}\n", sk.k[s], sk.s[s], sk.chi[s], sk.vectors[s]);
    }
    std::fclose(f);
    fmt::print("wrote {}\n", opt.skCsv);
  }
}

}  // namespace

Runner addAnalyze(CLI::App& app) {
  auto opt = std::make_shared<AnalyzeOptions>();
  CLI::App* cmd = app.add_subcommand(
      "analyze", "contact network, rattlers, isostaticity, Z(tau) and g(r) of a hard-sphere packing");
  cmd->add_option("input", opt->input, "particle file (.h5/.hdf5 or text)")->required();
  cmd->add_option("--contact-gap", opt->contactGap,
                  "contact when gap <= this x (r_i + r_j); 0 = from the reduced pressure (see --pressure)")
      ->capture_default_str();
  cmd->add_option("--pressure", opt->pressure,
                  "reduced pressure of the packing for the default contact gap (0 = the file's reduced_pressure "
                  "attribute, else 1e6)")
      ->capture_default_str();
  cmd->add_option("--broad-phase", opt->broadPhase, "broad phase for the pair searches")->capture_default_str();
  cmd->add_option("--z-csv", opt->coordinationCsv, "write Z(tau) for tau = 1e-15 .. 1e-1 (tau,Z)");
  cmd->add_option("--gr-csv", opt->correlationCsv, "write g(x), x = r_ij / (r_i + r_j) (x,g)");
  cmd->add_option("--gr-max", opt->correlationMax, "largest x of g(x)")->capture_default_str();
  cmd->add_option("--gr-bins", opt->correlationBins, "bins of g(x)")->capture_default_str();
  cmd->add_flag("--certify", opt->certify,
                "linear-programming test of collective jamming (GLPK): 'jammed' or an unjamming motion");
  cmd->add_option("--remove", opt->removeSphere,
                  "--certify: take this sphere out (e.g. a backbone sphere: a deliberately unjammed packing)");
  cmd->add_option("--load-gap", opt->loadGap,
                  "--certify: pairs with gap <= this x (r_i + r_j) are constraints of the load test")
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
      ->capture_default_str();
  cmd->add_option("--beta", opt->beta,
                  "--certify sequential: load again while a step moves a sphere by more than this (own diameters)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--max-limit", opt->maxLimit,
                  "--certify sequential: unjammed if a loaded sphere moves further in all (own diameters)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--mean-limit", opt->meanLimit,
                  "--certify sequential: unjammed if the mean displacement of the loaded spheres exceeds this")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--max-steps", opt->maxSteps, "--certify sequential: LPs per load at most")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  cmd->add_option("--loads", opt->loads, "--certify: random loads (each also applied reversed)")->capture_default_str();
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
  cmd->add_option("--motion-csv", opt->motionCsv, "write the load test's motion (the unjamming motion, or the displacements the loads achieved)");
  cmd->add_option("--leak-test", opt->leakCollisions,
                  "pressure-leak test (seed ch. 9): plain event-driven dynamics for this many collisions per particle; "
                  "a jammed packing keeps its pressure and its backbone does not drift (with --remove: without the sphere)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--leak-blocks", opt->leakBlocks, "--leak-test: blocks (one pressure each)")
      ->check(CLI::Range(4, 100000))
      ->capture_default_str();
  cmd->add_option("--leak-tolerance", opt->leakTolerance,
                  "--leak-test: a relative pressure drop (last quarter against first) beyond this is a leak")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--leak-drift", opt->leakDrift,
                  "--leak-test: a drift: the last quarter's mean backbone displacement above this factor x the first half's largest")
      ->check(CLI::Range(1.0 + 1e-12, 1e300))
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
  cmd->add_option("--sk-kmax", opt->skMax, "largest K = k D of --sk-csv")->capture_default_str();
  cmd->add_option("--sk-max-vectors", opt->skMaxVectors,
                  "--sk-csv: above this many wave vectors use every s-th per axis (coarser shells; 0 = all)")
      ->capture_default_str();
  CLI::Option* velocityOption =
      cmd->add_option("--velocity-rattlers", opt->velocityThreshold,
                      "rattlers by speed: |v| / v_rms <= threshold (default 1e-4; needs velocities, `polydem jam "
                      "--velocities`); give the value with '=' or after the input file")
          ->expected(0, 1);

  return [opt, velocityOption]() {
    const io::ParticleData data = io::readParticles(opt->input);
    const Index n = data.count();
    if (opt->removeSphere >= n) {
      throw ConfigError(fmt::format("--remove {}: the packing has {} spheres", opt->removeSphere, n));
    }
    const SphereView spheres{data.position, data.radius};
    if (opt->structureOnly) {
      double volume = 0.0;
      for (Index i = 0; i < n; ++i) volume += 4.0 / 3.0 * kPi * std::pow(data.radius[i], 3);
      fmt::print("{}: {} spheres in a box {}, size ratio {:.4g}\n", opt->input, n, data.box.describe(),
                 n ? data.radius.maxCoeff() / data.radius.minCoeff() : 0.0);
      fmt::print("packing fraction        {:.8f}\n", volume / data.box.volume());
      analyzeStructure(*opt, data, velocityOption->count() > 0, nullptr);
      return 0;
    }
    double pressure = opt->pressure;
    if (!(pressure > 0.0)) {
      const auto it = data.attributes.find("reduced_pressure");
      pressure = it != data.attributes.end() ? std::stod(it->second) : 1e6;
    }
    edmd::ContactOptions contact;
    contact.relativeGap = opt->contactGap > 0.0 ? opt->contactGap : edmd::defaultContactGap(pressure);
    contact.broadPhase = opt->broadPhase;
    const edmd::ContactNetwork net = edmd::analyseContacts(spheres, data.box, contact);
    double volume = 0.0;
    for (Index i = 0; i < n; ++i) volume += 4.0 / 3.0 * kPi * std::pow(data.radius[i], 3);
    const double phi = volume / data.box.volume();

    fmt::print("{}: {} spheres in a box {}, size ratio {:.4g}\n", opt->input, n, data.box.describe(),
               n ? data.radius.maxCoeff() / data.radius.minCoeff() : 0.0);
    fmt::print("packing fraction        {:.8f}\n", phi);
    fmt::print("reduced pressure        {:.4g}  (phi_J estimate {:.8f})\n", pressure,
               edmd::jammingDensityEstimate(phi, pressure));
    fmt::print("smallest gap            {:.3g} (relative; negative = overlap)\n", net.minGap);
    fmt::print("contacts (gap <= {:.1e}) {}  z = {:.4f}\n", contact.relativeGap, net.contacts.size(),
               net.meanCoordination());
    fmt::print("rattlers (< {} contacts)  {} ({:.2f}%)\n", contact.minContacts, n - net.backbone,
               100.0 * net.rattlerFraction());
    fmt::print("backbone                {} spheres, {} contacts, z = {:.4f}\n", net.backbone, net.backboneContacts,
               net.backboneCoordination());
    {
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
    fmt::print("backbone contact numbers{}\n", hist);

    std::vector<double> taus;
    for (int e = -15; e <= -1; ++e) taus.push_back(std::pow(10.0, e));
    const std::vector<double> z = edmd::cumulativeCoordination(spheres, data.box, taus, opt->broadPhase);
    std::string line;
    for (std::size_t k = 0; k < taus.size(); ++k) line += fmt::format(" {:.0e}:{:.3f}", taus[k], z[k]);
    fmt::print("Z(tau), all spheres    {}\n", line);
    if (!opt->coordinationCsv.empty()) {
      writeCsv(opt->coordinationCsv, "tau,Z", taus, z);
      fmt::print("wrote {}\n", opt->coordinationCsv);
    }
    if (!opt->correlationCsv.empty()) {
      const edmd::PairCorrelation g =
          edmd::pairCorrelation(spheres, data.box, opt->correlationMax, opt->correlationBins, opt->broadPhase);
      writeCsv(opt->correlationCsv, "x,g", g.x, g.g);
      fmt::print("wrote {}\n", opt->correlationCsv);
    }
    analyzeStructure(*opt, data, velocityOption->count() > 0, &net);
    if (opt->certify) {
      edmd::ContactNetwork tested = net;
      if (opt->removeSphere >= 0) {
        // The sphere disappears from the test (no constraints from it); the rattlers stay those of the
        // intact packing, so its neighbours keep being tested.
        tested.rattler[static_cast<std::size_t>(opt->removeSphere)] = 1;
        fmt::print("removed sphere {} ({} contacts, {}) for the jamming test\n", opt->removeSphere,
                   net.coordination[static_cast<std::size_t>(opt->removeSphere)],
                   net.rattler[static_cast<std::size_t>(opt->removeSphere)] ? "a rattler" : "a backbone sphere");
      }
      if (!opt->skipIdeal) {
        const edmd::JammingTestResult ideal = edmd::testCollectiveJamming(spheres, data.box, tested);
        fmt::print("ideal-contact LP test   {} ({:.2f} s; LP optima: opening {:.3g}, floppy {:.3g})\n", ideal.verdict,
                   ideal.seconds, ideal.openingObjective, ideal.floppyObjective);
        std::fflush(stdout);
      }
      edmd::LoadTestOptions loadOptions;
      loadOptions.gapTolerance = opt->loadGap;
      loadOptions.displacementLimit = opt->displacementLimit;
      loadOptions.loads = opt->loads;
      loadOptions.subpackingRounds = opt->subpackingRounds;
      loadOptions.sequential = opt->loadTest == "sequential";
      loadOptions.beta = opt->beta;
      loadOptions.maxLimit = opt->maxLimit;
      loadOptions.meanLimit = opt->meanLimit;
      loadOptions.maxSteps = opt->maxSteps;
      loadOptions.localRattlers = !opt->noLocalRattlers;
      loadOptions.strict = opt->strict;
      if (opt->strict && loadOptions.sequential) {
        throw ConfigError("--strict needs --load-test single (the sequential test keeps the cell fixed)");
      }
      loadOptions.progress = [](const std::string& line) {
        fmt::print("  load test: {}\n", line);
        std::fflush(stdout);
      };
      loadOptions.solver = opt->lpSolver == "simplex"    ? edmd::LpSolver::Simplex
                           : opt->lpSolver == "interior" ? edmd::LpSolver::InteriorPoint
                                                         : edmd::LpSolver::Automatic;
      if (opt->removeSphere >= 0) loadOptions.removed.push_back(opt->removeSphere);
      const edmd::LoadTestResult jam = edmd::testJammingUnderLoad(spheres, data.box, tested, loadOptions);
      fmt::print("jamming test (loads)    {} ({} constraints with gap <= {:.2g} (r_i + r_j), {}, {:.2f} s)\n",
                 jam.verdict, jam.constraints, loadOptions.gapTolerance, jam.solver, jam.seconds);
      if (!opt->motionCsv.empty()) {
        std::FILE* f = std::fopen(opt->motionCsv.c_str(), "w");
        if (!f) throw InputError(fmt::format("{}: cannot open for writing", opt->motionCsv));
        // Radius, contacts and rattler flag with the motion, so the moving spheres can be told apart.
        fmt::print(f, "i,radius,contacts,rattler,dx,dy,dz,moved_over_diameter\n");
        for (Index i = 0; i < n; ++i) {
          const double r = spheres.radius[i];
          fmt::print(f, "{},{:.10g},{},{},{:.10g},{:.10g},{:.10g},{:.6g}\n", i, r,
                     net.coordination[static_cast<std::size_t>(i)],
                     tested.rattler[static_cast<std::size_t>(i)] ? 1 : 0, jam.motion(0, i), jam.motion(1, i),
                     jam.motion(2, i), jam.motion.col(i).norm() / (2.0 * r));
        }
        std::fclose(f);
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
      edmd::LeakTestOptions leak;
      leak.collisionsPerParticle = opt->leakCollisions;
      leak.blocks = opt->leakBlocks;
      leak.pressureTolerance = opt->leakTolerance;
      leak.driftFactor = opt->leakDrift;
      leak.progress = [](const std::string& line) {
        fmt::print("  leak test: {}\n", line);
        std::fflush(stdout);
      };
      const edmd::LeakTestResult result = edmd::testPressureLeak(x, r, data.box, watched, leak);
      fmt::print("pressure-leak test      {} ({} collisions, {:.1f} s, {:.3g} collisions/s)\n", result.verdict,
                 result.counts.collisions, result.seconds,
                 static_cast<double>(result.counts.collisions) / std::max(result.seconds, 1e-9));
    }
    return 0;
  };
}

}  // namespace polydem::app
