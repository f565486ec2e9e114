#pragma once
// polydem bench: what the suites share: the options, the scenes (generated and cached, or read from a
// file, Morton-sorted), the timing of one backend, the report files written atomically and the plots.
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

namespace polydem::app::bench {

struct BenchOptions {
  std::string suite;
  std::string out = "bench-report";
  int repeat = 5;
  Index count = 0;       // 0: the suite's default
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
void mortonSort(Configuration& c);

/// Where dense states are cached: --cache, or <out>/states.
std::filesystem::path stateCache(const BenchOptions& opt);

/// A non-overlapping configuration at `packing` (RSA, else event-driven compression from the densest RSA
/// state, cached as HDF5; see bench_common.cpp). Particles are Morton-sorted.
BenchScene makeBenchScene(const BenchOptions& opt, const DistributionSpec& spec, Index count, double packing,
                          std::uint64_t seed, double equilibrate = 0.0);

/// The files the suites write into --out (checked before any computation).
inline constexpr const char* kReportFiles[] = {"README.md",           "backends.csv", "backends.gp", "backends.png",
                                               "backends_matrix.dat", "levels.csv",   "levels.gp",   "levels.png",
                                               "model.csv",           "model.gp",     "model.png",   "optimiser.csv",
                                               "scaling.csv",         "trel.csv",     "trel.gp",     "trel.png"};

/// Create the directory `dir` (and its parents) for output; ConfigError naming `what` if that fails or
/// `dir` is an existing file.
void prepareOutputDirectory(const std::filesystem::path& dir, std::string_view what);

/// A particle file benchmarked as it is (Morton-sorted); InputError for fewer than two particles.
BenchScene sceneFromFile(const std::string& file);

/// CPU model, cores, compiler and flags, for the report header.
std::string machineDescription();
/// The date and time (UTC), for the report header.
std::string today();

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

/// Run gnuplot on `script`, which sets its output to `png`; the plot is committed only when gnuplot succeeds.
bool runGnuplot(const std::filesystem::path& script, const std::filesystem::path& png);

struct Timed {
  double seconds = 0.0;      // median build + findPairs
  double spread = 0.0;       // (max - min) / median
  std::size_t pairs = 0;     ///< candidate pairs (gap within the skin)
  std::size_t contacts = 0;  ///< of those, pairs that overlap (gap < 0)
  std::uint64_t pairTests = 0, cellAccesses = 0;
  std::size_t bytes = 0;
  std::string description;
};

/// Median over `repeat` timed rounds (after one warm-up) of build + findPairs, the pairs and contacts found,
/// memory, and the counted pair tests and cell accesses of one more counted round.
Timed timeBackend(broadphase::BroadPhase& bp, const SphereView& spheres, const Box& box, double skin, int repeat);

/// An HGrid of the given mode with the given cell sizes (duplicates dropped), for hand-set level choices.
std::unique_ptr<broadphase::BroadPhase> gridWith(broadphase::CrossLevel mode, std::vector<double> sizes);

/// A suite: appends its section to `markdown`, writes its files into --out; 0 on success. `quick`: the
/// small CI cases.
using SuiteFunction = int (*)(const BenchOptions& opt, std::string& markdown, bool quick);
int runLevels(const BenchOptions& opt, std::string& markdown, bool quick);
int runBackends(const BenchOptions& opt, std::string& markdown, bool quick);
int runOptimiser(const BenchOptions& opt, std::string& markdown, bool quick);
int runScaling(const BenchOptions& opt, std::string& markdown, bool quick);
int runRelativeTime(const BenchOptions& opt, std::string& markdown, bool quick);
int runModel(const BenchOptions& opt, std::string& markdown, bool quick);

}  // namespace polydem::app::bench
