// polydem bench: named benchmark suites that write a self-contained report (CSV, PNG via gnuplot,
// Markdown summary with the machine, the command line and the date).
//
//   quick     CI smoke run (< 1 min): every backend on small scenes, pair sets must agree (exit 1
//             otherwise), plus small trel and model cases
//   levels    seed 000 Fig. 2.5: slowdown factor against the number of HGrid levels L for uniform
//             radius and uniform volume, omega = 50, measured beside the cost models' predictions
//   backends  time and memory per particle of every backend across size distributions and densities
//   optimiser the cost model's choice against an exhaustive measured search over L and mode
//   scaling   cost per particle against N (10^4..10^6) and against the size ratio, vs mono linked cell
//   trel      seed 000 Fig. 2.6: DEM time relative to the monodisperse system against N (bi, uniform
//             volume omega 10 and 50), with the broad-phase / force / integration split
//   model     seed 000 2.2.5: cost model against counted work and time for Top-Down, Bottom-Up, the
//             constant-m rule and linked cell over power laws alpha = 0..-3, omega = 10, 100
//   paper     levels + trel + model (the three seed reproductions)
//   full      every suite
// Dense states come from event-driven compression when random sequential addition stalls (--dense).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <sstream>
#include <thread>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/common.hpp"
#include "apps/polydem/pair_report.hpp"
#include "apps/polydem/validators.hpp"
#include "broadphase/auto_select.hpp"
#include "broadphase/hgrid.hpp"
#include "broadphase/hgrid_cost_model.hpp"
#include "broadphase/morton_order.hpp"
#include "broadphase/registry.hpp"
#include "core/errors.hpp"
#include "core/initial_configuration.hpp"
#include "core/io/particle_file.hpp"
#include "core/io/safe_output.hpp"
#include "edmd/compression.hpp"
#include "integrators/dem_simulation.hpp"
#include "integrators/initial_velocities.hpp"
#include "polydem/config.hpp"

namespace polydem::app {

namespace {

struct BenchOptions {
  std::string suite;
  std::string out = "bench-report";
  int repeat = 5;
  Index count = 0;  // 0: the suite's default
  double packing = 0.0;  // 0: the suite's default
  int maxLevels = 16;
  std::string commandLine;
  std::vector<std::string> inputs;  ///< particle files benchmarked as they are (levels, backends, model)
  std::string cacheDir;             ///< dense states written/reused here ("" = <out>/states)
  std::string dense = "edmd";       ///< when RSA stalls: edmd (compress to the target) or rsa (use less dense)
  std::vector<Index> counts;        ///< N values of the trel suite (empty: the suite's default)
  int steps = 0;                    ///< DEM steps per timed round (0: the suite's default)
  double equilibrate = -1.0;        ///< trel: EDMD collisions per particle at fixed density (< 0: default)
};

struct BenchScene {
  std::string label;
  Configuration config;
  double packing = 0.0;  ///< realised
  std::string placement;
};

/// Reorder particles along a Morton (Z-order) curve of their positions, as a DEM code does once at
/// start-up, so that particles close in space are close in memory.
void mortonSort(Configuration& c) {
  const Index n = static_cast<Index>(c.radius.size());
  std::vector<std::pair<std::uint64_t, Index>> keys;
  broadphase::mortonOrder(SphereView{c.position, c.radius}, c.box, keys);
  Eigen::Matrix3Xd position(3, n);
  Eigen::VectorXd radius(n);
  for (Index k = 0; k < n; ++k) {
    position.col(k) = c.position.col(keys[static_cast<std::size_t>(k)].second);
    radius[k] = c.radius[keys[static_cast<std::size_t>(k)].second];
  }
  c.position.swap(position);
  c.radius.swap(radius);
}

std::filesystem::path stateCache(const BenchOptions& opt) {
  return opt.cacheDir.empty() ? std::filesystem::path(opt.out) / "states" : std::filesystem::path(opt.cacheDir);
}

/// A non-overlapping configuration at `packing`: random sequential addition when it reaches the target;
/// otherwise (dense = edmd) Lubachevsky-Stillinger growth with the event-driven engine from the densest
/// RSA state, stopped exactly at the target (the seed's preparation, ch. 2.1.4; the same as
/// `polydem jam --target-phi`), or (dense = rsa) the densest RSA state in steps of 0.04. Compressed
/// states are cached as HDF5 files keyed by distribution, N, packing and seed. Particles are Morton-sorted.
BenchScene makeBenchScene(const BenchOptions& opt, const DistributionSpec& spec, Index count, double packing,
                          std::uint64_t seed, double equilibrate = 0.0) {
  const auto dist = makeDistribution(spec);
  PackingRequest request;
  request.radii = dist->sample(count, Sampling::Systematic, seed);
  std::mt19937_64 rng(seed);
  std::shuffle(request.radii.begin(), request.radii.end(), rng);
  request.boundaries = {Boundary::Periodic, Boundary::Periodic, Boundary::Periodic};
  request.seed = seed;
  request.maxAttemptsPerParticle = 2000;  // fail fast when RSA stalls
  BenchScene scene;
  scene.label = spec.kind == "mono" ? "mono" : fmt::format("{} omega={:g}", spec.kind, spec.omega);
  if (spec.kind == "power-law") scene.label += fmt::format(" alpha={:g}", spec.alpha);
  // Small wide systems: a periodic box must hold two cut-offs; use walls when it cannot.
  double volume = 0.0;
  for (double r : request.radii) volume += 4.0 / 3.0 * kPi * r * r * r;
  const double rmax = *std::max_element(request.radii.begin(), request.radii.end());
  if (std::cbrt(volume / packing) < 2.0 * (2.2 * rmax)) {
    request.boundaries = {Boundary::Wall, Boundary::Wall, Boundary::Wall};
    scene.label += " (walls)";
  }
  const std::filesystem::path cached =
      stateCache(opt) / fmt::format("{}_w{:g}_a{:g}_n{}_phi{:g}_s{}{}{}.h5", spec.kind, spec.omega, spec.alpha, count,
                                    packing, seed, request.boundaries[0] == Boundary::Wall ? "_walls" : "",
                                    equilibrate > 0.0 ? fmt::format("_eq{:g}", equilibrate) : std::string());
  if ((opt.dense == "edmd" || equilibrate > 0.0) && std::filesystem::exists(cached)) {
    const io::ParticleData data = io::readParticles(cached);
    scene.config.box = data.box;
    scene.config.position = data.position;
    scene.config.radius = data.radius;
    mortonSort(scene.config);
    scene.packing = packing;
    scene.placement = fmt::format("cached {}", cached.filename().string());
    return scene;
  }
  for (double phi = packing; phi > 0.05; phi -= 0.04) {
    request.packingFraction = phi;
    try {
      scene.config = randomSequentialAddition(request);
    } catch (const ConfigError&) {
      continue;  // RSA stalled: try a little less dense
    }
    scene.packing = phi;
    const bool compressing = phi != packing && opt.dense == "edmd";
    if (phi == packing) {
      scene.placement = "rsa";
    } else if (!compressing) {
      scene.placement = fmt::format("rsa (stalled at {:.2f}, used {:.2f})", packing, phi);
    }
    if (compressing || equilibrate > 0.0) {
      Stopwatch clock;
      edmd::HardSphereSystem system(scene.config.box, scene.config.position, scene.config.radius,
                                    edmd::maxwellBoltzmannVelocities(scene.config.radius, seed), edmd::SystemOptions{});
      if (compressing) {
        edmd::CompressionOptions copt;
        copt.schedule = {{1e-2, std::numeric_limits<double>::infinity()}};
        copt.targetPackingFraction = packing;
        const edmd::CompressionResult r = edmd::compress(system, copt);
        scene.placement = fmt::format("edmd from rsa {:.2f}", phi);
        fmt::print("  {} N = {}: RSA stalled, event-driven compression {:.2f} -> {:.3f} ({}, {:.0f} collisions per "
                   "particle, {:.1f} s)\n",
                   scene.label, count, phi, system.packingFraction(), r.stopReason,
                   static_cast<double>(r.counts.collisions) / count, clock.seconds());
      }
      if (equilibrate > 0.0) {
        // Random sequential addition leaves every sphere apart from its neighbours, unlike a compressed
        // fluid: relax all states the same way (hard-sphere collisions at fixed density) so that systems
        // prepared differently have comparable local structure.
        edmd::runAtFixedDensity(system, equilibrate, std::min(equilibrate, 100.0));
        scene.placement += fmt::format(", {:g} collisions/particle at fixed density", equilibrate);
      }
      scene.config.position = system.positions();
      scene.config.radius = system.radii();
      scene.packing = system.packingFraction();
      std::filesystem::create_directories(cached.parent_path());
      io::ParticleData data;
      data.box = scene.config.box;
      data.position = scene.config.position;
      data.radius = scene.config.radius;
      data.id.resize(static_cast<std::size_t>(count));
      for (Index i = 0; i < count; ++i) data.id[static_cast<std::size_t>(i)] = i;
      data.attributes["generator"] = "polydem bench: " + scene.placement;
      data.attributes["distribution"] = dist->describe();
      io::writeParticles(cached, data);
    }
    mortonSort(scene.config);
    return scene;
  }
  throw ConfigError(fmt::format("could not place {} at any packing fraction", scene.label));
}

/// The files the suites write into --out (checked before any computation).
constexpr const char* kReportFiles[] = {"README.md",      "backends.csv", "backends.gp",  "backends.png",
                                        "backends_matrix.dat", "levels.csv", "levels.gp", "levels.png",
                                        "model.csv",      "model.gp",     "model.png",    "optimiser.csv",
                                        "scaling.csv",    "trel.csv",     "trel.gp",      "trel.png"};

/// Create the directory `dir` (and its parents) for output; ConfigError naming `what` if that fails or
/// `dir` is an existing file.
void prepareOutputDirectory(const std::filesystem::path& dir, std::string_view what) {
  std::error_code ec;
  if (std::filesystem::exists(dir, ec) && !std::filesystem::is_directory(dir, ec)) {
    throw ConfigError(fmt::format("{} '{}': exists and is not a directory", what, dir.string()));
  }
  std::filesystem::create_directories(dir, ec);
  if (ec) throw ConfigError(fmt::format("{} '{}': cannot create the directory: {}", what, dir.string(), ec.message()));
  io::checkOutputPath(dir / "README.md", what);
}

/// A particle file benchmarked as it is (Morton-sorted like every scene). A benchmark of fewer than two
/// particles has no pair to find and no time per particle worth reporting: refused.
BenchScene sceneFromFile(const std::string& file) {
  const io::ParticleData data = io::readParticles(file);
  if (data.count() < 2) {
    throw InputError(fmt::format("{}: {} particle{}: a broad-phase benchmark needs at least 2", file, data.count(),
                                 data.count() == 1 ? "" : "s"));
  }
  BenchScene scene;
  scene.label = std::filesystem::path(file).filename().string();
  scene.config.box = data.box;
  scene.config.position = data.position;
  scene.config.radius = data.radius;
  mortonSort(scene.config);
  scene.packing = (4.0 / 3.0 * kPi * data.radius.array().cube().sum()) / data.box.volume();
  scene.placement = "file " + file;
  return scene;
}

std::string machineDescription() {
  std::string cpu = "unknown CPU";
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("model name", 0) == 0) {
      cpu = line.substr(line.find(':') + 2);
      break;
    }
  }
  return fmt::format("{}, {} hardware threads, compiler g++ {}, flags: {}", cpu, std::thread::hardware_concurrency(),
                     __VERSION__, POLYDEM_CXX_FLAGS);
}

std::string today() {
  std::time_t t = std::time(nullptr);
  char buf[64];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M UTC", std::gmtime(&t));
  return buf;
}

/// An output file of a suite, written under a temporary name beside its final one and renamed over it by
/// commit() once complete, so an interrupted bench never leaves a truncated CSV or script (issue 15).
class ReportFile {
 public:
  explicit ReportFile(const std::filesystem::path& final) : file_(final), stream_(file_.temporary()) {
    if (!stream_) throw InputError(fmt::format("{}: cannot be written", final.string()));
  }
  std::ofstream& stream() { return stream_; }
  void commit() {
    stream_.close();
    if (!stream_) throw InputError(fmt::format("{}: write failed", file_.final().string()));
    file_.commit();
  }

 private:
  io::AtomicFile file_;
  std::ofstream stream_;
};

/// Run gnuplot on `script`, which sets its output to `png`; the plot is drawn into a temporary file (the
/// script is run from a temporary copy that names it) and committed only when gnuplot succeeds.
bool runGnuplot(const std::filesystem::path& script, const std::filesystem::path& png) {
  std::ifstream in(script);
  std::stringstream text;
  text << in.rdbuf();
  std::string body = text.str();
  io::AtomicFile plot(png);
  const std::string from = "set output '" + png.string() + "'";
  const auto at = body.find(from);
  if (at == std::string::npos) return false;
  body.replace(at, from.size(), "set output '" + plot.temporary().string() + "'");
  io::AtomicFile copy(script);  // never committed: removed when it goes out of scope
  {
    std::ofstream out(copy.temporary());
    out << body;
    if (!out) return false;
  }
  const std::string cmd = fmt::format("gnuplot '{}' 2>/dev/null", copy.temporary().string());
  if (std::system(cmd.c_str()) != 0 || !std::filesystem::exists(plot.temporary())) return false;
  plot.commit();
  return true;
}

struct Timed {
  double seconds = 0.0;  // median build + findPairs
  double spread = 0.0;   // (max - min) / median
  std::size_t pairs = 0;     ///< candidate pairs (gap within the skin)
  std::size_t contacts = 0;  ///< of those, pairs that overlap (gap < 0)
  std::uint64_t pairTests = 0, cellAccesses = 0;
  std::size_t bytes = 0;
  std::string description;
};

Timed timeBackend(broadphase::BroadPhase& bp, const SphereView& spheres, const Box& box, double skin, int repeat) {
  std::vector<broadphase::Pair> pairs;
  std::vector<double> t;
  for (int k = 0; k <= repeat; ++k) {
    CpuStopwatch clock;
    bp.build(spheres, box, skin);
    bp.findPairs(spheres, pairs);
    if (k > 0) t.push_back(clock.seconds());
  }
  Timed r;
  r.seconds = median(t);
  r.spread = (*std::max_element(t.begin(), t.end()) - *std::min_element(t.begin(), t.end())) / r.seconds;
  r.pairs = pairs.size();
  for (const broadphase::Pair& p : pairs) {
    const Eigen::Vector3d d = box.minimumImage(spheres.centre.col(p.i) - spheres.centre.col(p.j));
    const double reach = spheres.radius[p.i] + spheres.radius[p.j];
    if (d.squaredNorm() < reach * reach) ++r.contacts;
  }
  r.bytes = bp.memoryBytes();
  r.description = bp.describe();
  bp.setCounting(true);
  bp.resetCounters();
  bp.build(spheres, box, skin);
  bp.findPairs(spheres, pairs);
  r.pairTests = bp.counters().pairTests;
  r.cellAccesses = bp.counters().cellAccesses;
  bp.setCounting(false);
  return r;
}

// ---- levels: seed 000 Fig. 2.5 ---------------------------------------------------------------------------

struct LevelsOutcome {
  std::string label;
  int bestLevels = 1;
  double speedupOverOneLevel = 1.0;
};

LevelsOutcome levelsCase(const BenchOptions& opt, const BenchScene& scene, const std::string& series, double omega,
                         std::ofstream& csv, std::string& markdown) {
  const Index count = static_cast<Index>(scene.config.radius.size());
  const Configuration& c = scene.config;
  const SphereView spheres{c.position, c.radius};
  std::vector<double> radii(c.radius.data(), c.radius.data() + c.radius.size());
  const double volume = c.box.volume();
  const double K21 = 0.3;  // the seed's ch. 2.1 value for L (m + K)
  const auto appendix = broadphase::appendixProcedure(radii, volume, 0.0, K21, opt.maxLevels);
  const auto psd = broadphase::CostModelPsd::sample(radii, volume, 0.0);
  fmt::print("{}: N = {}, packing {:.3f} ({})\n", scene.label, count, scene.packing, scene.placement);

  struct Row {
    int L;
    double m, t, spread, model21, model22, modelCd, modelCa;
    std::uint64_t tcd, tca;
    std::string sizes;
  };
  std::vector<Row> rows;
  for (const auto& level : appendix.table) {
    broadphase::HGridTopDown grid;
    broadphase::HGridConfig config;
    config.cellSizes = level.cellSizes;
    grid.setConfig(config);
    const Timed t = timeBackend(grid, spheres, c.box, 0.0, opt.repeat);
    const auto geometry = broadphase::snappedGeometry(level.cellSizes, c.box.lengths());
    const auto breakdown = broadphase::costBreakdown(psd, geometry, broadphase::CrossLevel::TopDown);
    const double model22 = breakdown.total;
    std::string sizes;
    for (double s : level.cellSizes) sizes += fmt::format("{}{:.4g}", sizes.empty() ? "" : ";", s);
    rows.push_back({level.levels, level.perCell, t.seconds, t.spread, level.cost, model22, breakdown.pairTests,
                    breakdown.cellAccesses, t.pairTests, t.cellAccesses, sizes});
    fmt::print("  L = {:2d}: m = {:.3f}, {:.4f} us/particle (spread {:.0f}%), model L(m+K) = {:.3f}, T/N = {:.2f}\n",
               level.levels, level.perCell, 1e6 * t.seconds / count, 100 * t.spread, level.cost, model22);
  }
  auto minOf = [&](auto field) {
    double best = std::numeric_limits<double>::infinity();
    for (const Row& r : rows) best = std::min(best, field(r));
    return best;
  };
  const double tMin = minOf([](const Row& r) { return r.t; });
  const double m21Min = minOf([](const Row& r) { return r.model21; });
  const double m22Min = minOf([](const Row& r) { return r.model22; });
  LevelsOutcome outcome;
  outcome.label = scene.label;
  for (const Row& r : rows) {
    csv << fmt::format("{},{},{},{:.6f},{:.6f},{:.5f},{:.4f},{:.5f},{:.5f},{:.5f},{:.5f},{:.5f},{:.5f},{:.5f},{:.5f},{}\n",
                       series, omega, r.L, scene.packing, r.m, 1e6 * r.t / count, r.spread, r.t / tMin,
                       r.model21 / m21Min, r.model22 / m22Min, static_cast<double>(r.tcd) / count,
                       static_cast<double>(r.tca) / count, r.modelCd, r.modelCa, r.model22, r.sizes);
    if (r.t == tMin) outcome.bestLevels = r.L;
  }
  outcome.speedupOverOneLevel = rows.front().t / tMin;
  const Row& bestRow = *std::find_if(rows.begin(), rows.end(), [&](const Row& r) { return r.L == outcome.bestLevels; });
  markdown += fmt::format(
      "| {} | {:.3f} ({}) | {} | {:.1f}x | {:.3f} / {:.3f} | {:.2f} / {:.2f} | {} | {} |\n", scene.label, scene.packing,
      scene.placement, outcome.bestLevels, outcome.speedupOverOneLevel,
      static_cast<double>(bestRow.tcd) / count, bestRow.modelCd, static_cast<double>(bestRow.tca) / count,
      bestRow.modelCa,
      appendix.optimalLevels,
      [&] {
        int best = 1;
        for (const Row& r : rows)
          if (r.model22 == m22Min) best = r.L;
        return best;
      }());
  return outcome;
}

int runLevels(const BenchOptions& opt, std::string& markdown) {
  const std::filesystem::path dir = opt.out;
  ReportFile csvFile(dir / "levels.csv");
  std::ofstream& csv = csvFile.stream();
  csv << "distribution,omega,L,packing,m,us_per_particle,spread,slowdown,slowdown_model_ch21,slowdown_model_ch22,"
         "pair_tests_per_particle,cell_accesses_per_particle,model_pair_tests,model_cell_accesses,model_T_per_particle,"
         "cell_sizes\n";
  markdown +=
      "## Slowdown factor against the number of levels (seed 000 Fig. 2.5)\n\n"
      "Top-Down HGrid, cell sizes from the seed's ch. 2.1 appendix procedure (equal particles per cell on every\n"
      "level); time = one build + one findPairs (contact detection only; the seed timed whole DEM steps).\n"
      "Models: L (m + K) with K = 0.3 (ch. 2.1) and T/N of eq. 2.35 with K = 0.2 (ch. 2.2), snapped cells.\n\n"
      "The counted work at the fastest L is shown beside the model's (random-centre) prediction: these are\n"
      "non-overlapping packings, where excluded volume breaks the model's assumptions.\n\n"
      "| system | packing | fastest L | speed-up over L = 1 | T_cd/N counted / model | T_ca/N counted / model |"
      " model ONL (ch. 2.1) | model best L (ch. 2.2) |\n"
      "| --- | --- | --- | --- | --- | --- | --- | --- |\n";
  std::vector<std::string> series;
  if (!opt.inputs.empty()) {
    for (const std::string& file : opt.inputs) {
      const BenchScene scene = sceneFromFile(file);
      series.push_back(scene.label);
      const double omega = scene.config.radius.maxCoeff() / scene.config.radius.minCoeff();
      levelsCase(opt, scene, scene.label, omega, csv, markdown);
    }
  } else {
    const Index count = opt.count > 0 ? opt.count : 125001;
    const double packing = opt.packing > 0 ? opt.packing : 0.62;
    for (const char* kind : {"uniform-volume", "uniform-radius"}) {
      DistributionSpec spec;
      spec.kind = kind;
      spec.omega = 50.0;
      Stopwatch prep;
      const BenchScene scene = makeBenchScene(opt, spec, count, packing, 1);
      fmt::print("{} prepared in {:.1f} s\n", scene.label, prep.seconds());
      series.push_back(kind);
      levelsCase(opt, scene, kind, spec.omega, csv, markdown);
    }
  }
  csvFile.commit();
  ReportFile gpFile(dir / "levels.gp");
  std::ofstream& gp = gpFile.stream();
  gp << "set datafile separator ','\nset terminal png size 900,600\nset output '" << (dir / "levels.png").string()
     << "'\nset termoption noenhanced\nset logscale y\nset xlabel 'number of levels L'\nset ylabel 'slowdown factor'\n"
     << "set key top left\nset title 'HGrid slowdown against L, measured vs cost models'\nplot ";
  for (std::size_t k = 0; k < series.size(); ++k) {
    const std::string sel = fmt::format("(strcol(1) eq '{}' ? $3 : 1/0)", series[k]);
    gp << (k ? ", " : "") << "'" << (dir / "levels.csv").string() << "' using " << sel << ":8 with linespoints lc "
       << k + 1 << " title '" << series[k] << " measured', '' using " << sel << ":10 with lines dt 2 lc " << k + 1
       << " title '" << series[k] << " model eq. 2.35', '' using " << sel << ":9 with lines dt 3 lc " << k + 1
       << " title '" << series[k] << " model L(m+K)'";
  }
  gp << "\n";
  gpFile.commit();
  markdown += runGnuplot(dir / "levels.gp", dir / "levels.png") ? "\n![levels](levels.png)\n\n"
                                                                : "\n(gnuplot not available: no plot)\n\n";
  return 0;
}

// ---- backends ---------------------------------------------------------------------------------------------

int runBackends(const BenchOptions& opt, std::string& markdown, bool quick) {
  const std::filesystem::path dir = opt.out;
  ReportFile csvFile(dir / "backends.csv");
  std::ofstream& csv = csvFile.stream();
  csv << "distribution,omega,packing,placement,backend,us_per_particle,spread,pairs,contacts,pair_tests_per_particle,"
         "cell_accesses_per_particle,bytes_per_particle,configuration\n";
  const Index count = opt.count > 0 ? opt.count : (quick ? 4000 : 100000);
  std::vector<std::pair<std::string, double>> dists = {{"mono", 1.0},           {"bi", 10.0},
                                                       {"uniform-radius", 50.0}, {"uniform-volume", 10.0},
                                                       {"uniform-volume", 50.0}};
  std::vector<double> packings = quick ? std::vector<double>{0.3} : std::vector<double>{0.1, 0.4, 0.62};
  std::vector<std::string> names = broadphase::backendNames();
  names.push_back("auto");
  markdown += fmt::format(
      "## Broad phases side by side (N = {}, skin = 0.1 r_min, periodic, RSA configurations)\n\n"
      "Median of {} runs of build + findPairs, thread CPU time in microseconds per particle.\n\n| system | packing |",
      count, opt.repeat);
  for (const auto& n : names) markdown += " " + n + " |";
  markdown += "\n| --- | --- |";
  for (std::size_t k = 0; k < names.size(); ++k) markdown += " --- |";
  markdown += "\n";
  bool agree = true;
  ReportFile matrixFile(dir / "backends_matrix.dat");
  std::ofstream& matrix = matrixFile.stream();  // one row per system, one column per backend
  matrix << "system";
  int plotted = 0;
  for (const auto& n : names) {
    if (n == "brute" && count > 20000) continue;  // skipped below: an all-NaN column breaks the histogram
    matrix << " " << n;
    ++plotted;
  }
  matrix << "\n";
  std::vector<std::function<BenchScene()>> makers;
  if (!opt.inputs.empty()) {
    for (const std::string& file : opt.inputs) makers.push_back([file] { return sceneFromFile(file); });
  } else {
    for (const auto& [kind, omega] : dists) {
      for (double packing : packings) {
        makers.push_back([&opt, kind, omega, count, packing] {
          DistributionSpec spec;
          spec.kind = kind;
          spec.omega = omega;
          return makeBenchScene(opt, spec, count, packing, 2);
        });
      }
    }
  }
  for (const auto& make : makers) {
    {
      const BenchScene scene = make();
      const Index count = static_cast<Index>(scene.config.radius.size());
      const SphereView spheres{scene.config.position, scene.config.radius};
      const double skin = 0.1 * scene.config.radius.minCoeff();
      markdown += fmt::format("| {} | {:.2f} |", scene.label, scene.packing);
      std::string label = fmt::format("{}@{:.2f}", scene.label, scene.packing);
      for (char& ch : label) {
        if (ch == ' ') ch = '_';
      }
      matrix << '"' << label << '"';
      std::size_t reference = 0;
      bool first = true;
      for (const std::string& name : names) {
        if (name == "brute" && count > 20000) {
          markdown += " - |";
          continue;
        }
        auto bp = broadphase::makeBroadPhase(name);
        const Timed t = timeBackend(*bp, spheres, scene.config.box, skin, opt.repeat);
        if (first) reference = t.pairs;
        first = false;
        if (t.pairs != reference) {
          agree = false;
          fmt::print(stderr, "MISMATCH: {} reports {} pairs, expected {} on {} at {}\n", name, t.pairs, reference,
                     scene.label, scene.packing);
        }
        csv << fmt::format("{},{:.4g},{:.4f},{},{},{:.5f},{:.4f},{},{},{:.4f},{:.4f},{:.2f},\"{}\"\n", scene.label,
                           scene.config.radius.maxCoeff() / scene.config.radius.minCoeff(),
                           scene.packing, scene.placement, name, 1e6 * t.seconds / count, t.spread, t.pairs, t.contacts,
                           static_cast<double>(t.pairTests) / count, static_cast<double>(t.cellAccesses) / count,
                           static_cast<double>(t.bytes) / count, t.description);
        markdown += fmt::format(" {:.3f} |", 1e6 * t.seconds / count);
        matrix << fmt::format(" {:.5f}", 1e6 * t.seconds / count);
        fmt::print("  {:<28} {:.2f} {:<12} {:10.4f} us/particle  {:8} pairs  {:7.1f} B/particle\n", scene.label,
                   scene.packing, name, 1e6 * t.seconds / count, t.pairs, static_cast<double>(t.bytes) / count);
      }
      markdown += "\n";
      matrix << "\n";
    }
  }
  csvFile.commit();
  matrixFile.commit();
  ReportFile gpFile(dir / "backends.gp");
  std::ofstream& gp = gpFile.stream();
  gp << "set terminal png size 1200,650\nset output '" << (dir / "backends.png").string() << "'\n"
     << "set termoption noenhanced\nset style data histograms\nset style histogram clustered gap 1\nset style fill solid 0.8 border -1\n"
     << "set logscale y\nset ylabel 'microseconds per particle (build + findPairs)'\nset xtics rotate by -30\n"
     << "set key outside right\nset title 'Broad phases side by side (N = " << count << ")'\n"
     << "plot for [col=2:" << plotted + 1 << "] '" << (dir / "backends_matrix.dat").string()
     << "' using col:xtic(1) title columnheader\n";
  gpFile.commit();
  markdown += runGnuplot(dir / "backends.gp", dir / "backends.png") ? "![backends](backends.png)\n\n"
                                                                    : "(gnuplot failed: no plot)\n\n";
  markdown += fmt::format("\nAll backends report the same pair counts: {}\n\n", agree ? "yes" : "**NO**");
  return agree ? 0 : 1;
}

// ---- optimiser: the cost model's choice against an exhaustive measured search -------------------------

std::unique_ptr<broadphase::BroadPhase> gridWith(broadphase::CrossLevel mode, std::vector<double> sizes) {
  sizes.erase(std::unique(sizes.begin(), sizes.end()), sizes.end());
  broadphase::HGridConfig config;
  config.cellSizes = sizes;
  config.mode = mode;
  if (mode == broadphase::CrossLevel::TopDown) {
    auto g = std::make_unique<broadphase::HGridTopDown>();
    g->setConfig(config);
    return g;
  }
  auto g = std::make_unique<broadphase::HGridBottomUp>();
  g->setConfig(config);
  return g;
}

int runOptimiser(const BenchOptions& opt, std::string& markdown) {
  const std::filesystem::path dir = opt.out;
  ReportFile csvFile(dir / "optimiser.csv");
  std::ofstream& csv = csvFile.stream();
  csv << "distribution,omega,alpha,packing,mode,L,us_per_particle,model_T_per_particle,is_optimiser_choice\n";
  const Index count = opt.count > 0 ? opt.count : 100000;
  const double packing = opt.packing > 0 ? opt.packing : 0.4;
  markdown += fmt::format(
      "## Optimiser against exhaustive search (N = {}, packing {}, skin 0.1 r_min)\n\n"
      "Every L = 1..12 in both modes with the cost model's optimal sizes for that L is timed (median of {}); the\n"
      "three fastest are then re-timed in {} interleaved rounds beside the optimiser's own choice (`auto`), and\n"
      "the medians of those rounds are compared (the minimum of 24 noisy scans alone is biased low).\n\n"
      "| system | optimiser choice | its time (us/particle) | fastest found | its time | ratio |\n"
      "| --- | --- | --- | --- | --- | --- |\n",
      count, packing, opt.repeat, std::max(7, opt.repeat));
  struct Case {
    std::string kind;
    double omega, alpha;
  };
  for (const Case& c : {Case{"uniform-volume", 10, 0}, Case{"uniform-volume", 50, 0}, Case{"power-law", 50, -2}}) {
    DistributionSpec spec;
    spec.kind = c.kind;
    spec.omega = c.omega;
    spec.alpha = c.alpha;
    const BenchScene scene = makeBenchScene(opt, spec, count, packing, 3);
    const SphereView spheres{scene.config.position, scene.config.radius};
    const double skin = 0.1 * scene.config.radius.minCoeff();
    std::vector<double> radii(scene.config.radius.data(), scene.config.radius.data() + count);
    const auto psd = broadphase::CostModelPsd::sample(radii, scene.config.box.volume(), skin);
    const double K = broadphase::modelCostRatio();
    struct Candidate {
      std::string name;
      std::unique_ptr<broadphase::BroadPhase> grid;
      double scan = 0.0;
      std::vector<double> rematch;
    };
    std::vector<Candidate> candidates;
    for (auto mode : {broadphase::CrossLevel::TopDown, broadphase::CrossLevel::BottomUp}) {
      for (int L = 1; L <= 12; ++L) {
        const auto sizes = broadphase::optimalCellSizes(psd, L, mode, K);
        auto grid = gridWith(mode, sizes);
        const Timed t = timeBackend(*grid, spheres, scene.config.box, skin, opt.repeat);
        const double model = broadphase::costPerParticle(psd, sizes, mode, K);
        const char* modeName = mode == broadphase::CrossLevel::TopDown ? "td" : "bu";
        csv << fmt::format("{},{},{},{:.3f},{},{},{:.5f},{:.4f},0\n", c.kind, c.omega, c.alpha, scene.packing, modeName,
                           L, 1e6 * t.seconds / count, model);
        candidates.push_back({fmt::format("hgrid-{} L={}", modeName, L), std::move(grid), t.seconds, {}});
      }
    }
    // The minimum of 24 noisy scans is biased low: re-time the three fastest and the optimiser's choice
    // in interleaved rounds and compare medians.
    std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) { return a.scan < b.scan; });
    candidates.resize(3);
    auto autoBp = broadphase::makeBroadPhase("auto");
    timeBackend(*autoBp, spheres, scene.config.box, skin, 1);  // runs the optimiser once (cached after)
    const auto* chosen = static_cast<const broadphase::AutoSelect*>(autoBp.get())->chosen();
    std::string choice = std::string(chosen->name());
    if (const auto* td = dynamic_cast<const broadphase::HGridTopDown*>(chosen)) {
      choice += fmt::format(" L={}", td->levelCount());
    } else if (const auto* bu = dynamic_cast<const broadphase::HGridBottomUp*>(chosen)) {
      choice += fmt::format(" L={}", bu->levelCount());
    }
    std::vector<double> autoTimes;
    const int rounds = std::max(7, opt.repeat);
    for (int round = 0; round < rounds; ++round) {
      autoTimes.push_back(timeBackend(*autoBp, spheres, scene.config.box, skin, 1).seconds);
      for (Candidate& cand : candidates) {
        cand.rematch.push_back(timeBackend(*cand.grid, spheres, scene.config.box, skin, 1).seconds);
      }
    }
    const double autoMedian = median(autoTimes);
    double best = std::numeric_limits<double>::infinity();
    std::string bestName;
    for (Candidate& cand : candidates) {
      const double m = median(cand.rematch);
      if (m < best) {
        best = m;
        bestName = cand.name;
      }
    }
    Timed a;
    a.seconds = autoMedian;
    csv << fmt::format("{},{},{},{:.3f},auto,{},{:.5f},,1\n", c.kind, c.omega, c.alpha, scene.packing, choice,
                       1e6 * a.seconds / count);
    markdown += fmt::format("| {}{} | {} | {:.4f} | {} | {:.4f} | {:.2f} |\n", scene.label,
                            c.alpha != 0 ? fmt::format(" alpha={:g}", c.alpha) : "", choice, 1e6 * a.seconds / count,
                            bestName, 1e6 * best / count, a.seconds / best);
    fmt::print("  {}: optimiser {} {:.4f} us, fastest {} {:.4f} us, ratio {:.2f}\n", scene.label, choice,
               1e6 * a.seconds / count, bestName, 1e6 * best / count, a.seconds / best);
  }
  csvFile.commit();
  markdown += "\n";
  return 0;
}

// ---- scaling: cost per particle against N and against the size ratio ----------------------------------

int runScaling(const BenchOptions& opt, std::string& markdown) {
  const std::filesystem::path dir = opt.out;
  ReportFile csvFile(dir / "scaling.csv");
  std::ofstream& csv = csvFile.stream();
  csv << "series,distribution,omega,N,packing,backend,us_per_particle,spread,bytes_per_particle,ratio_to_mono_linked_cell\n";
  const double packing = opt.packing > 0 ? opt.packing : 0.4;
  const std::vector<Index> sizes = opt.count > 0 ? std::vector<Index>{opt.count}
                                                 : std::vector<Index>{10000, 100000, 1000000};
  markdown += fmt::format(
      "## Cost per particle against N (packing {}, skin 0.1 r_min)\n\n"
      "`auto` on uniform volume omega = 50 beside linked cell on the monodisperse system of the same N and\n"
      "packing fraction (median of {} runs of build + findPairs).\n\n"
      "| N | mono, linked-cell (us) | UV omega=50, auto (us) | ratio |\n| --- | --- | --- | --- |\n",
      packing, opt.repeat);
  for (Index n : sizes) {
    DistributionSpec mono;
    const BenchScene m = makeBenchScene(opt, mono, n, packing, 4);
    auto lc = broadphase::makeBroadPhase("linked-cell");
    const Timed tm = timeBackend(*lc, {m.config.position, m.config.radius}, m.config.box, 0.1, opt.repeat);
    DistributionSpec uv;
    uv.kind = "uniform-volume";
    uv.omega = 50;
    const BenchScene p = makeBenchScene(opt, uv, n, packing, 4);
    auto au = broadphase::makeBroadPhase("auto");
    const Timed tp = timeBackend(*au, {p.config.position, p.config.radius}, p.config.box, 0.1, opt.repeat);
    csv << fmt::format("N,mono,1,{},{:.3f},linked-cell,{:.5f},{:.3f},{:.1f},1\n", n, m.packing, 1e6 * tm.seconds / n,
                       tm.spread, static_cast<double>(tm.bytes) / n);
    csv << fmt::format("N,uniform-volume,50,{},{:.3f},auto,{:.5f},{:.3f},{:.1f},{:.4f}\n", n, p.packing,
                       1e6 * tp.seconds / n, tp.spread, static_cast<double>(tp.bytes) / n, tp.seconds / tm.seconds);
    markdown += fmt::format("| {} | {:.4f} | {:.4f} | {:.2f} |\n", n, 1e6 * tm.seconds / n, 1e6 * tp.seconds / n,
                            tp.seconds / tm.seconds);
    fmt::print("  N = {}: mono linked-cell {:.4f} us, UV50 auto {:.4f} us, ratio {:.2f}\n", n, 1e6 * tm.seconds / n,
               1e6 * tp.seconds / n, tp.seconds / tm.seconds);
  }
  const Index n = opt.count > 0 ? opt.count : 100000;
  markdown += fmt::format(
      "\n## Cost per particle against the size ratio (N = {}, packing {})\n\n"
      "| omega | UV auto (us) | mono linked-cell (us) | ratio | linked-cell on UV (us) |\n"
      "| --- | --- | --- | --- | --- |\n",
      n, packing);
  DistributionSpec mono;
  const BenchScene m = makeBenchScene(opt, mono, n, packing, 5);
  auto lc = broadphase::makeBroadPhase("linked-cell");
  const Timed tm = timeBackend(*lc, {m.config.position, m.config.radius}, m.config.box, 0.1, opt.repeat);
  for (double omega : {1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0}) {
    DistributionSpec uv;
    uv.kind = "uniform-volume";
    uv.omega = omega;
    const BenchScene p = makeBenchScene(opt, uv, n, packing, 5);
    const SphereView sp{p.config.position, p.config.radius};
    auto au = broadphase::makeBroadPhase("auto");
    const Timed tp = timeBackend(*au, sp, p.config.box, 0.1, opt.repeat);
    std::string lcText = "-";
    if (omega <= 20.0) {  // linked cell on wide distributions takes minutes
      auto lcp = broadphase::makeBroadPhase("linked-cell");
      lcText = fmt::format("{:.4f}", 1e6 * timeBackend(*lcp, sp, p.config.box, 0.1, 1).seconds / n);
    }
    csv << fmt::format("omega,uniform-volume,{},{},{:.3f},auto,{:.5f},{:.3f},{:.1f},{:.4f}\n", omega, n, p.packing,
                       1e6 * tp.seconds / n, tp.spread, static_cast<double>(tp.bytes) / n, tp.seconds / tm.seconds);
    markdown += fmt::format("| {:g}{} | {:.4f} | {:.4f} | {:.2f} | {} |\n", omega,
                            p.config.box.fullyPeriodic() ? "" : " (walls)", 1e6 * tp.seconds / n,
                            1e6 * tm.seconds / n, tp.seconds / tm.seconds, lcText);
    fmt::print("  omega = {}: UV auto {:.4f} us, ratio to mono LC {:.2f}\n", omega, 1e6 * tp.seconds / n,
               tp.seconds / tm.seconds);
  }
  csvFile.commit();
  markdown += "\n";
  return 0;
}

// ---- trel: seed 000 Fig. 2.6, DEM time relative to the monodisperse system against N -------------------

struct DemCase {
  std::string label;
  std::string backend;
  std::unique_ptr<integrators::DemSimulation> sim;
  std::vector<double> cpu;  ///< CPU seconds per timed round
  integrators::PhaseTimes phases;
  std::int64_t timedSteps = 0;
  std::string placement;
  double packing = 0.0;
};

/// A DEM run of the seed's ch. 2.1.4 protocol on `scene`: linear elastic normal contacts (no friction, no
/// rotation), velocities such that two colliding smallest particles reach 1% overlap, dt = t_c,min / 50.
std::unique_ptr<integrators::DemSimulation> demOn(const BenchScene& scene, const std::string& backend) {
  const Index n = static_cast<Index>(scene.config.radius.size());
  ParticleStore particles(n, Features{});
  particles.position() = scene.config.position;
  particles.radius() = scene.config.radius;
  particles.setMassesFromDensity(1.0);
  integrators::DemSettings settings;
  settings.contact.stiffness = 1e4;
  settings.contact.restitution = 1.0;
  settings.broadPhase = backend;
  settings.stability.checkInterval = 0;  // timed rounds only; checked once at the end
  integrators::assignImpactVelocities(contact::ContactModel(settings.contact), particles, 0.01, 7);
  return std::make_unique<integrators::DemSimulation>(std::move(particles), scene.config.box, settings);
}

int runRelativeTime(const BenchOptions& opt, std::string& markdown, bool quick) {
  const std::filesystem::path dir = opt.out;
  const double packing = opt.packing > 0 ? opt.packing : (quick ? 0.5 : 0.6);
  const std::vector<Index> counts =
      !opt.counts.empty() ? opt.counts : (quick ? std::vector<Index>{2000, 5000} : std::vector<Index>{10000, 30000, 100000});
  const int steps = opt.steps > 0 ? opt.steps : (quick ? 40 : 200);
  const double equilibrate = opt.equilibrate >= 0.0 ? opt.equilibrate : (quick ? 2.0 : 20.0);
  struct System {
    std::string kind;
    double omega;
    std::string backend;
  };
  const std::vector<System> systems = {{"mono", 1.0, "linked-cell"},
                                       {"bi", 10.0, "auto"},
                                       {"uniform-volume", 10.0, "auto"},
                                       {"uniform-volume", 50.0, "auto"}};
  ReportFile csvFile(dir / "trel.csv");
  std::ofstream& csv = csvFile.stream();
  csv << "system,N,packing,placement,backend,broad_phase_choice,steps,us_per_particle_step,spread,t_rel,"
         "broad_phase_share,force_share,integration_share,rebuilds,pairs_per_particle,bytes_per_particle\n";
  markdown += fmt::format(
      "## DEM time relative to the monodisperse system against N (seed 000 Fig. 2.6)\n\n"
      "Packing fraction {}, periodic (walls when the box cannot hold two cut-offs of the largest sphere). Every state\n"
      "(random sequential addition, event-driven compression where RSA stalls) is then relaxed by {:g} hard-sphere\n"
      "collisions per particle at fixed density, so all systems have the local structure of a fluid. Linear\n"
      "elastic contacts, 1% impact overlap of the smallest pair, dt = t_c,min / 50, Verlet skin 0.2 r_min.\n"
      "Each round advances every system {} steps, the systems taking turns (interleaved), {} rounds; thread CPU\n"
      "time, median over rounds. T_rel = time of the system / time of the monodisperse system of the same N\n"
      "(linked cell), same number of steps (the seed's definition). Bi: equal volumes of the two sizes, omega = 10\n"
      "(the seed: L = 2 with the two diameters; here `auto` chooses). The split is broad phase (neighbour-list\n"
      "rebuilds), force and integration as shares of the loop's wall time (CPU time is not split).\n\n"
      "| N | system | placement | broad phase | neighbour pairs / particle | us/particle/step | T_rel | broad phase / force / integration |\n"
      "| --- | --- | --- | --- | --- | --- | --- | --- |\n",
      packing, equilibrate, steps, opt.repeat);
  std::map<std::string, std::vector<std::pair<Index, double>>> trel;
  for (Index n : counts) {
    std::vector<DemCase> cases;
    for (const System& sys : systems) {
      DistributionSpec spec;
      spec.kind = sys.kind;
      spec.omega = sys.omega;
      Stopwatch prep;
      const BenchScene scene = makeBenchScene(opt, spec, n, packing, 6, equilibrate);
      DemCase c;
      c.label = scene.label;
      c.backend = sys.backend;
      c.placement = scene.placement;
      c.packing = scene.packing;
      c.sim = demOn(scene, sys.backend);
      c.sim->advance(std::max(10, steps / 4));  // warm up: contacts form, first rebuilds
      fmt::print("  N = {} {}: packing {:.3f} ({}), {} ({:.1f} s to prepare)\n", n, scene.label, scene.packing,
                 scene.placement, c.sim->neighbours().backend().describe(), prep.seconds());
      cases.push_back(std::move(c));
    }
    for (int round = 0; round < opt.repeat; ++round) {
      for (DemCase& c : cases) {
        const integrators::PhaseTimes before = c.sim->times();
        CpuStopwatch clock;
        c.sim->advance(steps);
        c.cpu.push_back(clock.seconds());
        const integrators::PhaseTimes& after = c.sim->times();
        c.phases.broadPhase += after.broadPhase - before.broadPhase;
        c.phases.force += after.force - before.force;
        c.phases.integration += after.integration - before.integration;
        c.timedSteps += steps;
      }
    }
    const double mono = median(cases.front().cpu);
    for (DemCase& c : cases) {
      c.sim->checkStability();
      const double t = median(c.cpu);
      // Shares of the phases' wall time: under load wall time includes waiting, CPU time is not split.
      const double phaseSum = std::max(1e-12, c.phases.broadPhase + c.phases.force + c.phases.integration);
      const double perStep = 100.0 / phaseSum;
      const double spread = (*std::max_element(c.cpu.begin(), c.cpu.end()) - *std::min_element(c.cpu.begin(), c.cpu.end())) / t;
      const std::string choice = c.sim->neighbours().backend().describe();
      csv << fmt::format("\"{}\",{},{:.4f},\"{}\",{},\"{}\",{},{:.5f},{:.3f},{:.4f},{:.1f},{:.1f},{:.1f},{},{:.3f},{:.1f}\n",
                         c.label, n, c.packing, c.placement, c.backend, choice, steps,
                         1e6 * t / (static_cast<double>(steps) * n), spread, t / mono, c.phases.broadPhase * perStep,
                         c.phases.force * perStep, c.phases.integration * perStep, c.sim->rebuilds(),
                         static_cast<double>(c.sim->neighbours().list().pairCount()) / n,
                         static_cast<double>(c.sim->memoryBytes()) / n);
      // The table keeps the choice short ("auto -> hgrid-td L=4"); the CSV has the whole description.
      const std::string shortChoice = choice.substr(0, std::min(choice.find(" sizes"), choice.find(" cells of")));
      markdown += fmt::format("| {} | {} | {} | {} | {:.2f} | {:.4f} | {:.2f} | {:.0f}% / {:.0f}% / {:.0f}% |\n", n,
                              c.label, c.placement, shortChoice,
                              static_cast<double>(c.sim->neighbours().list().pairCount()) / n,
                              1e6 * t / (static_cast<double>(steps) * n), t / mono,
                              c.phases.broadPhase * perStep, c.phases.force * perStep, c.phases.integration * perStep);
      fmt::print("  N = {} {:<26} {:.4f} us/particle/step  T_rel {:.2f}  (bp {:.0f}%, force {:.0f}%, int {:.0f}%)\n", n,
                 c.label, 1e6 * t / (static_cast<double>(steps) * n), t / mono, c.phases.broadPhase * perStep,
                 c.phases.force * perStep, c.phases.integration * perStep);
      trel[c.label].push_back({n, t / mono});
    }
  }
  csvFile.commit();
  markdown += "\n| system | T_rel over N | max / min over N |\n| --- | --- | --- |\n";
  for (const auto& [label, values] : trel) {
    std::string list;
    double lo = std::numeric_limits<double>::infinity(), hi = 0.0;
    for (const auto& [n, v] : values) {
      list += fmt::format("{}{:.2f}", list.empty() ? "" : ", ", v);
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
    markdown += fmt::format("| {} | {} | {:.2f} |\n", label, list, hi / lo);
  }
  ReportFile gpFile(dir / "trel.gp");
  std::ofstream& gp = gpFile.stream();
  gp << "set datafile separator ','\nset terminal png size 900,600\nset output '" << (dir / "trel.png").string()
     << "'\nset termoption noenhanced\nset logscale x\nset xlabel 'N'\nset ylabel 'T_rel = T / T(mono, linked cell)'\n"
     << "set key top left\nset yrange [0:*]\nset title 'DEM time relative to monodisperse (seed Fig. 2.6), packing "
     << packing << "'\nplot ";
  int k = 0;
  for (const auto& [label, values] : trel) {
    gp << (k ? ", " : "") << "'" << (dir / "trel.csv").string() << "' using (strcol(1) eq '" << label
       << "' ? $2 : 1/0):10 with linespoints lw 2 title '" << label << "'";
    ++k;
  }
  gp << "\n";
  gpFile.commit();
  markdown +=
      runGnuplot(dir / "trel.gp", dir / "trel.png") ? "\n![trel](trel.png)\n\n" : "\n(gnuplot failed: no plot)\n\n";
  return 0;
}

// ---- model: seed 000 §2.2.5, predicted vs measured Top-Down / Bottom-Up across alpha and omega ---------

int runModel(const BenchOptions& opt, std::string& markdown, bool quick) {
  const std::filesystem::path dir = opt.out;
  const Index count = opt.count > 0 ? opt.count : (quick ? 5000 : 100000);
  const double packing = opt.packing > 0 ? opt.packing : 0.5;
  const std::vector<double> alphas = quick ? std::vector<double>{0.0, -3.0} : std::vector<double>{0.0, -1.0, -2.0, -3.0};
  const std::vector<double> omegas = quick ? std::vector<double>{10.0} : std::vector<double>{10.0, 100.0};
  const double K = broadphase::modelCostRatio();
  ReportFile csvFile(dir / "model.csv");
  std::ofstream& csv = csvFile.stream();
  csv << "alpha,omega,N,packing,placement,method,L,model_T_per_particle,model_pair_tests,model_cell_accesses,"
         "counted_pair_tests,counted_cell_accesses,counted_T_per_particle,us_per_particle,spread,cell_sizes\n";
  markdown += fmt::format(
      "## Cost model against measurement: Top-Down, Bottom-Up and linked cell across alpha and omega "
      "(seed 000 §2.2.5)\n\n"
      "Power-law size distributions f(r) ~ r^alpha on [r_min, omega r_min], N = {}, packing {}, skin 0.1 r_min,\n"
      "periodic. For each mode the optimiser's best L and sizes (eq. 2.35 minimised, K = {:.3f} from the\n"
      "calibration micro-benchmark); the seed's recommendation 3 (constant particles per cell, Top-Down) at its\n"
      "best L; linked cell where the model predicts under 3000 tests per particle. Model T/N = T_cd + K T_ca;\n"
      "counted = the same sum from the grid's own counters on this packing; time = build + findPairs, median of {}.\n\n"
      "| alpha | omega | method | L | model T/N | counted T/N | us/particle | predicted / measured BU:TD | picked by model | fastest measured |\n"
      "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n",
      count, packing, K, opt.repeat);
  for (double omega : omegas) {
    for (double alpha : alphas) {
      DistributionSpec spec;
      spec.kind = "power-law";
      spec.alpha = alpha;
      spec.omega = omega;
      const BenchScene scene = makeBenchScene(opt, spec, count, packing, 8);
      const SphereView spheres{scene.config.position, scene.config.radius};
      const double skin = 0.1 * scene.config.radius.minCoeff();
      std::vector<double> radii(scene.config.radius.data(), scene.config.radius.data() + count);
      const auto psd = broadphase::CostModelPsd::sample(radii, scene.config.box.volume(), skin);
      broadphase::OptimiserOptions oo;
      oo.K = K;
      oo.maxLevels = 20;
      const broadphase::OptimiserResult best = broadphase::optimiseHGrid(psd, oo);
      struct Method {
        std::string name;
        broadphase::CrossLevel mode;
        std::vector<double> sizes;
        double predicted;
      };
      std::vector<Method> methods;
      auto bestOf = [&](auto pick) {
        int bestL = 1;
        double bestT = std::numeric_limits<double>::infinity();
        for (const auto& row : best.table) {
          const double t = pick(row).predicted;
          if (t < bestT * (1.0 - oo.tolerance)) {
            bestT = t;
            bestL = row.levels;
          }
        }
        return std::make_pair(bestL, pick(best.table[static_cast<std::size_t>(bestL - 1)]));
      };
      const auto [ltd, td] = bestOf([](const broadphase::LevelsRow& r) { return r.topDown; });
      const auto [lbu, bu] = bestOf([](const broadphase::LevelsRow& r) { return r.bottomUp; });
      const auto [lcm, cm] = bestOf([](const broadphase::LevelsRow& r) { return r.constantMTopDown; });
      methods.push_back({fmt::format("top-down optimal"), broadphase::CrossLevel::TopDown, td.cellSizes, td.predicted});
      methods.push_back({fmt::format("bottom-up optimal"), broadphase::CrossLevel::BottomUp, bu.cellSizes, bu.predicted});
      methods.push_back({fmt::format("top-down constant m"), broadphase::CrossLevel::TopDown, cm.cellSizes, cm.predicted});
      const double lcModel = best.table.front().topDown.predicted;
      if (lcModel < 3000.0) {
        methods.push_back({"linked cell", broadphase::CrossLevel::TopDown, {psd.maxDiameter()}, lcModel});
      }
      const int levelsOf[] = {ltd, lbu, lcm, 1};
      std::vector<double> times;
      std::string fastest;
      double fastestTime = std::numeric_limits<double>::infinity();
      double tdTime = 0.0, buTime = 0.0;
      std::vector<std::string> rows;
      for (std::size_t k = 0; k < methods.size(); ++k) {
        const Method& m = methods[k];
        // Linked cell as a one-level grid of the largest diameter: the same counters as the model's L = 1.
        std::unique_ptr<broadphase::BroadPhase> bp = gridWith(m.mode, m.sizes);
        const Timed t = timeBackend(*bp, spheres, scene.config.box, skin, opt.repeat);
        const auto geometry = broadphase::snappedGeometry(m.sizes, scene.config.box.lengths());
        const auto breakdown = broadphase::costBreakdown(psd, geometry, m.mode);
        const double counted = (static_cast<double>(t.pairTests) + K * static_cast<double>(t.cellAccesses)) / count;
        std::string sizes;
        for (double sz : m.sizes) sizes += fmt::format("{}{:.4g}", sizes.empty() ? "" : ";", sz);
        csv << fmt::format("{},{},{},{:.4f},\"{}\",{},{},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.5f},{:.3f},{}\n",
                           alpha, omega, count, scene.packing, scene.placement, m.name, levelsOf[k], m.predicted,
                           breakdown.pairTests, breakdown.cellAccesses, static_cast<double>(t.pairTests) / count,
                           static_cast<double>(t.cellAccesses) / count, counted, 1e6 * t.seconds / count, t.spread,
                           sizes);
        if (k == 0) tdTime = t.seconds;
        if (k == 1) buTime = t.seconds;
        if (t.seconds < fastestTime) {
          fastestTime = t.seconds;
          fastest = fmt::format("{} (L = {})", m.name, levelsOf[k]);
        }
        rows.push_back(fmt::format("| {:g} | {:g} | {} | {} | {:.2f} | {:.2f} | {:.4f} |", alpha, omega, m.name,
                                   levelsOf[k], m.predicted, counted, 1e6 * t.seconds / count));
        fmt::print("  alpha {:g} omega {:g} {:<20} L = {:2d}: model {:.2f}, counted {:.2f}, {:.4f} us/particle\n", alpha,
                   omega, m.name, levelsOf[k], m.predicted, counted, 1e6 * t.seconds / count);
      }
      const std::string pick = best.chosen.linkedCell
                                   ? std::string("linked cell")
                                   : fmt::format("{} (L = {})", best.chosen.config.mode == broadphase::CrossLevel::TopDown
                                                                    ? "top-down"
                                                                    : "bottom-up",
                                                 best.chosen.levels);
      for (std::size_t k = 0; k < rows.size(); ++k) {
        markdown += rows[k];
        if (k == 0) {
          markdown += fmt::format(" {:.2f} / {:.2f} | {} | {} |\n", bu.predicted / td.predicted, buTime / tdTime, pick,
                                  fastest);
        } else {
          markdown += " | | |\n";
        }
      }
    }
  }
  csvFile.commit();
  // Predicted work against measured time: one point per (distribution, method); a line through the origin
  // would mean time proportional to the model's work.
  ReportFile gpFile(dir / "model.gp");
  std::ofstream& gp = gpFile.stream();
  gp << "set datafile separator ','\nset terminal png size 900,600\nset output '" << (dir / "model.png").string()
     << "'\nset termoption noenhanced\nset logscale xy\nset xlabel 'model T/N (pair tests + K cell accesses)'\n"
     << "set ylabel 'measured us per particle'\nset key top left\n"
     << "set title 'Cost model vs measurement, power laws (seed 000 2.2.5)'\nplot ";
  const char* methodsList[] = {"top-down optimal", "bottom-up optimal", "top-down constant m", "linked cell"};
  for (int k = 0; k < 4; ++k) {
    gp << (k ? ", " : "") << "'" << (dir / "model.csv").string() << "' using (strcol(6) eq '" << methodsList[k]
       << "' ? $8 : 1/0):14 with points pt " << 5 + 2 * k << " ps 1.5 title '" << methodsList[k] << "'";
  }
  gp << "\n";
  gpFile.commit();
  markdown +=
      runGnuplot(dir / "model.gp", dir / "model.png") ? "\n![model](model.png)\n\n" : "\n(gnuplot failed: no plot)\n\n";
  return 0;
}

}  // namespace

Runner addBench(CLI::App& app) {
  auto opt = std::make_shared<BenchOptions>();
  CLI::App* cmd = app.add_subcommand("bench", "run a named benchmark suite and write a report (CSV, PNG, Markdown)");
  cmd->add_option("suite", opt->suite, "quick, levels, backends, optimiser, scaling, trel, model, paper, full")
      ->required()
      ->check(CLI::IsMember({"quick", "levels", "backends", "optimiser", "scaling", "trel", "model", "paper", "full"}));
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
  return [opt, cmd]() {
    if (opt->repeat < 1) throw ConfigError(fmt::format("--repeat must be >= 1, got {}", opt->repeat));
    if (!opt->inputs.empty() && opt->suite != "levels" && opt->suite != "backends") {
      throw ConfigError(fmt::format("--input works with the levels and backends suites, not {}", opt->suite));
    }
    // Every output checked before any computation: the report directory and the cache, every file the
    // suites write there, none of them an input.
    std::vector<std::filesystem::path> inputs(opt->inputs.begin(), opt->inputs.end());
    prepareOutputDirectory(opt->out, "--out");
    for (const char* name : kReportFiles) io::checkOutputPath(std::filesystem::path(opt->out) / name, "--out", inputs);
    prepareOutputDirectory(stateCache(*opt), opt->cacheDir.empty() ? "--out (its states/ cache)" : "--cache");
    // Read every input once up front, so a bad second file fails before the first is benchmarked.
    for (const std::string& file : opt->inputs) sceneFromFile(file);
    std::string markdown = fmt::format(
        "# polydem bench {}\n\n- date: {}\n- machine: {}\n- command: `polydem bench {}{}`\n\n", opt->suite, today(),
        machineDescription(), opt->suite,
        [&] {
          std::string args;
          for (const auto* o : cmd->get_options()) {
            if (o->get_name() == "suite" || o->count() == 0 || o->get_name() == "--help") continue;
            args += " " + o->get_name() + " " + o->as<std::string>();
          }
          return args;
        }());
    Stopwatch clock;
    int status = 0;
    const std::string& suite = opt->suite;
    if (suite == "quick") {
      status = runBackends(*opt, markdown, true);
      status |= runRelativeTime(*opt, markdown, true);
      status |= runModel(*opt, markdown, true);
    }
    if (suite == "levels" || suite == "paper" || suite == "full") status |= runLevels(*opt, markdown);
    if (suite == "trel" || suite == "paper" || suite == "full") status |= runRelativeTime(*opt, markdown, false);
    if (suite == "model" || suite == "paper" || suite == "full") status |= runModel(*opt, markdown, false);
    if (suite == "backends" || suite == "full") status |= runBackends(*opt, markdown, false);
    if (suite == "optimiser" || suite == "full") status |= runOptimiser(*opt, markdown);
    if (suite == "scaling" || suite == "full") status |= runScaling(*opt, markdown);
    markdown += fmt::format("Total run time: {:.1f} s\n", clock.seconds());
    io::writeFileAtomically(std::filesystem::path(opt->out) / "README.md", markdown);
    fmt::print("report written to {}/README.md ({:.1f} s)\n", opt->out, clock.seconds());
    return status;
  };
}

}  // namespace polydem::app
