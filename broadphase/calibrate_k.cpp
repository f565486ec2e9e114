// Micro-benchmark for K = t_cell / t_pair (see calibrate_k.hpp; thesis eq. 2.35).
//
// Both kernels mimic the HGrid's inner loops rather than an idealised version of them: the pair loop
// runs over slot ranges of packed x, y, z, r of nearby spheres and pushes hits into a pair buffer; the cell
// loop walks 3 x 3 x 3 search boxes with periodic wrapping, builds the index of each cell and reads
// its slot range (empty or one sphere: 8% of the cells are occupied). The kernels are timed in
// interleaved rounds and each keeps its fastest round (the usual estimate of the undisturbed cost). Rejected: timing a
// whole HGrid build and search, which would measure both kernels mixed with everything else and need a regression to
// split.
#include "broadphase/calibrate_k.hpp"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cstdint>
#include <functional>
#include <random>
#include <span>
#include <vector>

#include "broadphase/broad_phase.hpp"
#include "core/box.hpp"

namespace polydem::broadphase {

namespace {

using Clock = std::chrono::steady_clock;

volatile std::uint64_t gSink = 0;  // keeps results alive

constexpr int kCellsPerAxis = 48;  // hash table of 512 kB: beyond L1, like a real level's
constexpr std::uint64_t kEmptyKey = ~std::uint64_t{0};

struct HashSlot {
  std::uint64_t key;
  Index begin, end;
};

struct CellBench {
  std::vector<HashSlot> table;
  std::uint64_t mask = 0;
  int shift = 64;
  std::vector<Index> cellStart;       // dense: n^3 + 1
  std::vector<std::int32_t> centres;  // query cell coordinates, 3 per query
};

std::uint64_t cellKey(std::int64_t x, std::int64_t y, std::int64_t z, std::uint64_t level) {
  return static_cast<std::uint64_t>(x) | (static_cast<std::uint64_t>(y) << 20) | (static_cast<std::uint64_t>(z) << 40) |
         (level << 60);
}

std::uint64_t hashOf(std::uint64_t key, int shift) { return (key * 0x9E3779B97F4A7C15ull) >> shift; }

CellBench makeCellBench(std::mt19937_64& rng) {
  CellBench b;
  const int n = kCellsPerAxis;
  const std::size_t cells = static_cast<std::size_t>(n) * n * n;
  const std::size_t spheres = cells / 12;  // ~8% of cells occupied, a few of them twice
  std::uniform_int_distribution<int> coordinate(0, n - 1);
  std::vector<std::uint64_t> keys(spheres);
  for (auto& k : keys) k = cellKey(coordinate(rng), coordinate(rng), coordinate(rng), 3);
  std::sort(keys.begin(), keys.end());
  std::size_t capacity = 1;
  while (capacity < 2 * spheres) capacity *= 2;
  b.table.assign(capacity, {kEmptyKey, 0, 0});
  b.mask = capacity - 1;
  b.shift = 64 - std::countr_zero(capacity);
  b.cellStart.assign(cells + 1, 0);
  for (std::size_t i = 0; i < keys.size();) {
    std::size_t j = i;
    while (j < keys.size() && keys[j] == keys[i]) ++j;
    std::uint64_t slot = hashOf(keys[i], b.shift);
    while (b.table[slot].key != kEmptyKey) slot = (slot + 1) & b.mask;
    b.table[slot] = {keys[i], static_cast<Index>(i), static_cast<Index>(j)};
    const std::uint64_t k = keys[i];
    const std::size_t dense = (k & 0xFFFFF) + n * (((k >> 20) & 0xFFFFF) + n * ((k >> 40) & 0xFFFFF));
    b.cellStart[dense + 1] = static_cast<Index>(j - i);
    i = j;
  }
  for (std::size_t c = 0; c < cells; ++c) b.cellStart[c + 1] += b.cellStart[c];
  const int queries = 4096;
  b.centres.resize(3 * queries);
  for (auto& c : b.centres) c = coordinate(rng);
  return b;
}

/// One pass over all 3x3x3 search boxes through the hash table; returns the spheres found.
[[gnu::noinline]] std::uint64_t hashedPass(const CellBench& b) {
  const int n = kCellsPerAxis;
  std::uint64_t found = 0;
  for (std::size_t q = 0; q < b.centres.size(); q += 3) {
    for (int dz = -1; dz <= 1; ++dz) {
      int z = b.centres[q + 2] + dz;
      z = z < 0 ? z + n : (z >= n ? z - n : z);
      for (int dy = -1; dy <= 1; ++dy) {
        int y = b.centres[q + 1] + dy;
        y = y < 0 ? y + n : (y >= n ? y - n : y);
        for (int dx = -1; dx <= 1; ++dx) {
          int x = b.centres[q] + dx;
          x = x < 0 ? x + n : (x >= n ? x - n : x);
          const std::uint64_t key = cellKey(x, y, z, 3);
          std::uint64_t slot = hashOf(key, b.shift);
          for (;;) {
            const HashSlot& s = b.table[slot];
            if (s.key == key) {
              found += static_cast<std::uint64_t>(s.end - s.begin);
              break;
            }
            if (s.key == kEmptyKey) break;
            slot = (slot + 1) & b.mask;
          }
        }
      }
    }
  }
  return found;
}

/// The same through the dense cell-start array.
[[gnu::noinline]] std::uint64_t densePass(const CellBench& b) {
  const int n = kCellsPerAxis;
  std::uint64_t found = 0;
  const Index* start = b.cellStart.data();
  for (std::size_t q = 0; q < b.centres.size(); q += 3) {
    for (int dz = -1; dz <= 1; ++dz) {
      int z = b.centres[q + 2] + dz;
      z = z < 0 ? z + n : (z >= n ? z - n : z);
      for (int dy = -1; dy <= 1; ++dy) {
        int y = b.centres[q + 1] + dy;
        y = y < 0 ? y + n : (y >= n ? y - n : y);
        for (int dx = -1; dx <= 1; ++dx) {
          int x = b.centres[q] + dx;
          x = x < 0 ? x + n : (x >= n ? x - n : x);
          const std::size_t c =
              static_cast<std::size_t>(x) + n * (static_cast<std::size_t>(y) + n * static_cast<std::size_t>(z));
          found += static_cast<std::uint64_t>(start[c + 1] - start[c]);
        }
      }
    }
  }
  return found;
}

struct PairBench {
  Box box = Box::cubic(1.0, Boundary::Periodic);
  std::vector<double> packed;  // x, y, z, r per slot; kCluster consecutive slots are close together
  Index clusters = 0;
  std::vector<Pair> out;
};
constexpr Index kCluster = 8;

PairBench makePairBench(std::mt19937_64& rng) {
  // Candidates of a real search are neighbours (no periodic wrap, predictable branches in the minimum
  // image), with a fair fraction of hits: clusters of 8 spheres in cubes of edge 0.1, all pairs tested.
  PairBench b;
  b.clusters = 256;
  std::uniform_real_distribution<double> centre(0.1, 0.9), offset(-0.05, 0.05), radius(0.005, 0.02);
  b.packed.resize(4 * static_cast<std::size_t>(b.clusters * kCluster));
  for (Index c = 0; c < b.clusters; ++c) {
    const double x = centre(rng), y = centre(rng), z = centre(rng);
    for (Index i = c * kCluster; i < (c + 1) * kCluster; ++i) {
      b.packed[4 * i + 0] = x + offset(rng);
      b.packed[4 * i + 1] = y + offset(rng);
      b.packed[4 * i + 2] = z + offset(rng);
      b.packed[4 * i + 3] = radius(rng);
    }
  }
  b.out.reserve(static_cast<std::size_t>(b.clusters) * kCluster * kCluster);
  return b;
}

constexpr double kPairsPerCluster = kCluster * (kCluster - 1) / 2;

/// All pairs within every cluster, hits pushed to a buffer as in the real candidate loops.
[[gnu::noinline]] std::uint64_t pairPass(PairBench& b) {
  b.out.clear();
  const double* p = b.packed.data();
  for (Index c = 0; c < b.clusters; ++c) {
    const Index end = (c + 1) * kCluster;
    for (Index s = c * kCluster; s < end; ++s) {
      const double* ps = p + 4 * s;
      for (Index t = s + 1; t < end; ++t) {
        const double* pt = p + 4 * t;
        if (spheresWithinReach(b.box, ps, ps[3], pt, pt[3], 0.01)) b.out.push_back({s, t});
      }
    }
  }
  return b.out.size();
}

/// A kernel under test: one pass and the operations it performs.
struct Kernel {
  std::function<std::uint64_t()> pass;
  double operationsPerPass = 1.0;
  int passes = 1;
  double best = 1e300;  // seconds per operation
};

/// Time the kernels in interleaved rounds (so a busy machine disturbs them alike) and keep each one's
/// fastest round: an estimate of the undisturbed cost.
void timeKernels(std::span<Kernel> kernels, int rounds, double roundSeconds) {
  for (Kernel& k : kernels) {  // warm up, and size a round from one pass
    const auto t = Clock::now();
    gSink = gSink + k.pass();
    const double one = std::max(1e-7, std::chrono::duration<double>(Clock::now() - t).count());
    k.passes = std::max(1, static_cast<int>(roundSeconds / one));
  }
  for (int r = 0; r < rounds; ++r) {
    for (Kernel& k : kernels) {
      const auto t = Clock::now();
      std::uint64_t sum = 0;
      for (int i = 0; i < k.passes; ++i) sum += k.pass();
      const double seconds = std::chrono::duration<double>(Clock::now() - t).count();
      gSink = gSink + sum;
      k.best = std::min(k.best, seconds / (k.passes * k.operationsPerPass));
    }
  }
}

}  // namespace

KCalibration defaultKCalibration() { return {}; }

KCalibration measureK() {
  std::mt19937_64 rng(20240607);
  PairBench pairs = makePairBench(rng);
  const CellBench cells = makeCellBench(rng);
  const double lookups = static_cast<double>(cells.centres.size() / 3) * 27.0;
  Kernel kernels[3] = {
      {[&] { return pairPass(pairs); }, pairs.clusters * kPairsPerCluster},
      {[&] { return hashedPass(cells); }, lookups},
      {[&] { return densePass(cells); }, lookups},
  };
  timeKernels(kernels, 10, 0.0025);  // 3 kernels x 10 rounds x 2.5 ms + set-up: about 0.1 s
  KCalibration k;
  k.pairTestSeconds = kernels[0].best;
  k.hashedCellAccessSeconds = kernels[1].best;
  k.cellAccessSeconds = kernels[2].best;
  k.K = k.cellAccessSeconds > 0.0 && k.pairTestSeconds > 0.0 ? k.cellAccessSeconds / k.pairTestSeconds
                                                             : kDefaultCellOverPairCost;
  k.calibrated = true;
  return k;
}

const KCalibration& calibratedK() {
  static const KCalibration cached = measureK();  // thread-safe initialisation
  return cached;
}

double modelCostRatio() { return calibratedK().K; }

}  // namespace polydem::broadphase
