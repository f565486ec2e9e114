// A STREAM-like copy bandwidth (McCalpin's STREAM "Copy" kernel, b[i] = a[i]) measured on this machine, so
// that phase timings can be set against the memory bandwidth of the same run (scripts/dem_scaling.sh).
// Counts 16 bytes per element (one read, one write) as STREAM does; write-allocate traffic is not
// counted. Arrays are first touched by the threads that copy them (static schedule), as STREAM does.
//
//   polydem_stream_copy [--mib 512] [--repeat 20] [--threads 1] [--json FILE]
//
// Prints "stream copy: T threads, 2 x M MiB, best B GB/s, median D GB/s" and, with --json, the same as
// {"threads": T, "array_mib": M, "best_gb_per_s": B, "median_gb_per_s": D, "repeat": R}.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <fstream>
#include <memory>
#include <vector>

#include "polydem/config.hpp"

namespace {

/// b[i] = a[i] for i in [0, n) on `threads` threads (static split, the same as the first touch).
[[gnu::noinline]] void copyArrays(const double* a, double* b, std::int64_t n, [[maybe_unused]] int threads) {
#if POLYDEM_WITH_OPENMP
#pragma omp parallel for num_threads(threads) schedule(static)
#endif
  for (std::int64_t i = 0; i < n; ++i) b[i] = a[i];
}

[[gnu::noinline]] void fillArrays(double* a, double* b, std::int64_t n, [[maybe_unused]] int threads) {
#if POLYDEM_WITH_OPENMP
#pragma omp parallel for num_threads(threads) schedule(static)
#endif
  for (std::int64_t i = 0; i < n; ++i) {
    a[i] = 1.0 + static_cast<double>(i % 7);
    b[i] = 0.0;
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("STREAM-like copy bandwidth (b[i] = a[i], 16 bytes per element)");
  double mib = 512.0;
  int repeat = 20;
  int threads = 1;
  std::string json;
  app.add_option("--mib", mib, "MiB per array (well above the last-level cache)")
      ->check(CLI::Range(1.0, 65536.0))
      ->capture_default_str();
  app.add_option("--repeat", repeat, "timed copies (best and median reported)")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  app.add_option("--threads", threads, "OpenMP threads")->check(CLI::Range(1, 1024))->capture_default_str();
  app.add_option("--json", json, "also write the figures to this JSON file");
  CLI11_PARSE(app, argc, argv);
  if (threads > 1 && !POLYDEM_WITH_OPENMP) {
    fmt::print(stderr, "--threads {} needs a build with POLYDEM_WITH_OPENMP=ON\n", threads);
    return 2;
  }

  const auto n = static_cast<std::int64_t>(mib * 1024.0 * 1024.0 / sizeof(double));
  // Not std::vector: its value-initialisation would touch every page on the main thread.
  std::unique_ptr<double[]> a(new double[static_cast<std::size_t>(n)]);
  std::unique_ptr<double[]> b(new double[static_cast<std::size_t>(n)]);
  fillArrays(a.get(), b.get(), n, threads);
  copyArrays(a.get(), b.get(), n, threads);  // warm-up
  std::vector<double> rates;
  for (int r = 0; r < repeat; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    copyArrays(a.get(), b.get(), n, threads);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    rates.push_back(16.0 * static_cast<double>(n) / s / 1e9);
  }
  if (b[static_cast<std::size_t>(n - 1)] != a[static_cast<std::size_t>(n - 1)]) return 1;  // keeps the copies
  std::sort(rates.begin(), rates.end());
  const double best = rates.back();
  const double median = rates[rates.size() / 2];
  fmt::print("stream copy: {} threads, 2 x {:g} MiB, best {:.2f} GB/s, median {:.2f} GB/s\n", threads, mib, best,
             median);
  if (!json.empty()) {
    std::ofstream out(json);
    out << fmt::format(
        "{{\"threads\": {}, \"array_mib\": {}, \"best_gb_per_s\": {:.6g}, \"median_gb_per_s\": {:.6g}, "
        "\"repeat\": {}}}\n",
        threads, mib, best, median, repeat);
    if (!out) {
      fmt::print(stderr, "{}: cannot be written\n", json);
      return 2;
    }
  }
  return 0;
}
