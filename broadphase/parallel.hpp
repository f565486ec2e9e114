#pragma once
// OpenMP building blocks of the threaded broad-phase builds and searches and of the Verlet-list build.
// Include only from .cpp files of targets that link OpenMP::OpenMP_CXX under POLYDEM_WITH_OPENMP
// (broadphase/, integrators/): the pragmas must not reach translation units compiled without -fopenmp.
//
// Determinism: every helper produces a result that does not depend on the thread count or on which
// thread ran what. Tasks write disjoint outputs; the counting sort is stable, so its output is the unique
// stable order whatever the split. Bodies must not throw (an exception cannot leave an OpenMP region):
// callers validate first and throw outside.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/types.hpp"
#include "polydem/config.hpp"

namespace polydem::broadphase::parallel {

/// Threads actually used: `threads` in an OpenMP build (>= 1), 1 otherwise.
inline int usable(int threads) { return POLYDEM_WITH_OPENMP && threads > 1 ? threads : 1; }

/// Chunks of work for `threads` threads over `n` items: 1 for one thread or few items, else about 8 per
/// thread (dynamic scheduling then evens out uneven chunks and a thread that loses its core on a shared
/// machine), each at least `minItems` items.
inline std::size_t chunkCount(int threads, std::size_t n, std::size_t minItems = 1024) {
  const int t = usable(threads);
  if (t == 1 || n < 2 * minItems) return 1;
  return std::clamp<std::size_t>(n / minItems, 1, static_cast<std::size_t>(8 * t));
}

/// body(k) for k in [0, count): on `threads` threads, one task at a time (dynamic schedule).
template <class Body>
void forEachTask([[maybe_unused]] int threads, std::size_t count, Body&& body) {
#if POLYDEM_WITH_OPENMP
  if (usable(threads) > 1 && count > 1) {
    const auto n = static_cast<std::int64_t>(count);
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
    for (std::int64_t k = 0; k < n; ++k) body(static_cast<std::size_t>(k));
    return;
  }
#endif
  for (std::size_t k = 0; k < count; ++k) body(k);
}

/// body(begin, end) for `parts` contiguous ranges [n p / parts, n (p + 1) / parts) of [0, n), in parallel.
template <class Body>
void forEachRange(int threads, std::size_t n, std::size_t parts, Body&& body) {
  parts = std::max<std::size_t>(parts, 1);
  forEachTask(threads, parts, [&](std::size_t p) { body(n * p / parts, n * (p + 1) / parts); });
}

/// Stable counting sort of the items [0, n) by bucketOf(item) in [0, buckets). On return start[b] is
/// `base` plus the first position of bucket b (start holds buckets + 1 entries; start[buckets] = base + n)
/// and place(item, position) has been called once per item, position in [base, base + n). Items of one
/// bucket keep their order (stable), so the result is the same for any thread count. With several threads
/// the items are cut into contiguous parts, one histogram each in `scratch` (parts x buckets entries,
/// grown only); parts are capped so that the histograms hold at most about 4 n + 4096 entries.
/// bucketOf is called twice per item.
template <class BucketOf, class Place>
void stableCountingSort(int threads, std::size_t n, std::size_t buckets, Index base, BucketOf&& bucketOf, Index* start,
                        [[maybe_unused]] std::vector<Index>& scratch, Place&& place) {
  constexpr std::size_t kMaxParts = 64;
  std::size_t parts = static_cast<std::size_t>(usable(threads));
  if (n < 4096) parts = 1;
  parts = std::min({parts, kMaxParts, std::max<std::size_t>(1, (4 * n + 4096) / std::max<std::size_t>(buckets, 1))});
  if (parts <= 1) {
    std::fill(start, start + buckets + 1, Index{0});
    for (std::size_t i = 0; i < n; ++i) ++start[static_cast<std::size_t>(bucketOf(i)) + 1];
    start[0] = base;
    for (std::size_t b = 0; b < buckets; ++b) start[b + 1] += start[b];
    // start[b + 1] is now the end of bucket b; make it bucket b's first slot (the end of bucket b - 1).
    std::copy_backward(start, start + buckets, start + buckets + 1);
    for (std::size_t i = 0; i < n; ++i) place(i, start[static_cast<std::size_t>(bucketOf(i)) + 1]++);
    return;
  }
#if POLYDEM_WITH_OPENMP
  if (scratch.size() < parts * buckets) scratch.resize(parts * buckets);
  Index* hist = scratch.data();
  std::array<Index, kMaxParts + 1> rangeBase{};
  const auto np = static_cast<std::int64_t>(parts);
#pragma omp parallel num_threads(threads)
  {
    // 1. One histogram per contiguous part of the items.
#pragma omp for schedule(static)
    for (std::int64_t p = 0; p < np; ++p) {
      Index* h = hist + static_cast<std::size_t>(p) * buckets;
      std::fill(h, h + buckets, Index{0});
      const std::size_t end = n * static_cast<std::size_t>(p + 1) / parts;
      for (std::size_t i = n * static_cast<std::size_t>(p) / parts; i < end; ++i) {
        ++h[static_cast<std::size_t>(bucketOf(i))];
      }
    }
    // 2. Items per contiguous range of buckets, then the ranges' first positions.
#pragma omp for schedule(static)
    for (std::int64_t q = 0; q < np; ++q) {
      Index total = 0;
      const std::size_t end = buckets * static_cast<std::size_t>(q + 1) / parts;
      for (std::size_t b = buckets * static_cast<std::size_t>(q) / parts; b < end; ++b) {
        for (std::size_t p = 0; p < parts; ++p) total += hist[p * buckets + b];
      }
      rangeBase[static_cast<std::size_t>(q) + 1] = total;
    }
#pragma omp single
    {
      rangeBase[0] = base;
      for (std::size_t q = 0; q < parts; ++q) rangeBase[q + 1] += rangeBase[q];
    }
    // 3. Bucket starts, and each part's first position in each bucket (in place of its histogram):
    // bucket b holds the items of part 0, then part 1, ...: the serial stable order.
#pragma omp for schedule(static)
    for (std::int64_t q = 0; q < np; ++q) {
      Index running = rangeBase[static_cast<std::size_t>(q)];
      const std::size_t end = buckets * static_cast<std::size_t>(q + 1) / parts;
      for (std::size_t b = buckets * static_cast<std::size_t>(q) / parts; b < end; ++b) {
        start[b] = running;
        for (std::size_t p = 0; p < parts; ++p) {
          const Index count = hist[p * buckets + b];
          hist[p * buckets + b] = running;
          running += count;
        }
      }
    }
    // 4. Scatter, each part in item order.
#pragma omp for schedule(static)
    for (std::int64_t p = 0; p < np; ++p) {
      Index* h = hist + static_cast<std::size_t>(p) * buckets;
      const std::size_t end = n * static_cast<std::size_t>(p + 1) / parts;
      for (std::size_t i = n * static_cast<std::size_t>(p) / parts; i < end; ++i) {
        place(i, h[static_cast<std::size_t>(bucketOf(i))]++);
      }
    }
  }
  start[buckets] = base + static_cast<Index>(n);
#endif
}

}  // namespace polydem::broadphase::parallel
