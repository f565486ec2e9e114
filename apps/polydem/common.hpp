#pragma once
// Helpers shared by the subcommands: option groups, parsing of boundary names, timing.
#include <array>
#include <chrono>
#include <ctime>
#include <string>
#include <vector>

#include "core/box.hpp"
#include "core/size_distribution.hpp"

namespace CLI {
class App;
class Validator;
}  // namespace CLI

namespace polydem::app {

/// --dist, --rmin, --omega, --alpha, --sigma, --median, --large-fraction, --fraction-kind, each validated
/// (finite, in range; the option is named in the message).
void addDistributionOptions(CLI::App& cmd, DistributionSpec& spec, std::string& fractionKind);

/// Names of the options addDistributionOptions() adds, for conflict checks.
const std::vector<std::string>& distributionOptionNames();

/// The first of `names` given on the command line of `cmd`, or "" if none was.
std::string firstGivenOption(const CLI::App& cmd, const std::vector<std::string>& names);

/// A boundary specification parseBoundaries() accepts.
CLI::Validator boundaryNames();
void finishDistributionSpec(DistributionSpec& spec, const std::string& fractionKind);

/// "periodic", "walls", or three comma-separated entries of periodic|wall. Throws ConfigError.
std::array<Boundary, 3> parseBoundaries(const std::string& text);

/// Wall-clock seconds since construction.
class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  double seconds() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }

 private:
  std::chrono::steady_clock::time_point start_;
};

/// CPU seconds of the calling thread since construction: less sensitive than wall time to other jobs
/// on a shared machine (benchmarks report it).
class CpuStopwatch {
 public:
  CpuStopwatch() : start_(now()) {}
  double seconds() const { return now() - start_; }

 private:
  static double now() {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
  }
  double start_;
};

double median(std::vector<double> values);

}  // namespace polydem::app
