#include "broadphase/broad_phase.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "broadphase/pair_chunks.hpp"
#include "broadphase/parallel.hpp"
#include "core/errors.hpp"

namespace polydem::broadphase {

namespace {

/// The checks of validateSpheres() without messages and without branches: {all good, r_min, r_max}. A
/// radius is good when 0 < r < inf, a centre when 0 <= x_k < L_k (periodic) or <= L_k (walls), which also
/// rejects NaN and inf. Threaded with OpenMP for many spheres. When something is bad, the serial scan
/// of validateSpheres() names the first bad particle, so the error is the same for any thread count.
struct QuickScan {
  bool good = true;
  double rmin = 0.0, rmax = 0.0;
};

QuickScan scanSpheres(const SphereView& spheres, const Box& box, [[maybe_unused]] int threads) {
  QuickScan q;
  const Index n = spheres.count();
  if (n == 0) return q;
  double limit[3];  // x_k < limit_k: L on periodic axes, the next double above L on walled ones
  for (int k = 0; k < 3; ++k) {
    limit[k] = box.periodic(k) ? box.length(k) : std::nextafter(box.length(k), std::numeric_limits<double>::infinity());
  }
  const double* r = spheres.radius.data();
  const double* x = spheres.centre.data();
  const double inf = std::numeric_limits<double>::infinity();
  bool good = true;
  double rmin = r[0], rmax = r[0];
#if POLYDEM_WITH_OPENMP
#pragma omp parallel for num_threads(threads) schedule(static) reduction(&& : good) reduction(min : rmin) \
    reduction(max : rmax) if (parallel::usable(threads) > 1 && n >= 4096)
#endif
  for (Index i = 0; i < n; ++i) {
    const double* c = x + 3 * i;
    const bool ok = (r[i] > 0.0) & (r[i] < inf) & (c[0] >= 0.0) & (c[0] < limit[0]) & (c[1] >= 0.0) &
                    (c[1] < limit[1]) & (c[2] >= 0.0) & (c[2] < limit[2]);
    good = good && ok;
    rmin = std::min(rmin, r[i]);
    rmax = std::max(rmax, r[i]);
  }
  q.good = good;
  q.rmin = rmin;
  q.rmax = rmax;
  return q;
}

}  // namespace

std::pair<double, double> validateSpheres(const SphereView& spheres, const Box& box, double skin, int threads) {
  if (!(std::isfinite(skin) && skin >= 0.0)) {
    throw ConfigError(fmt::format("skin must be a finite number >= 0, got {}", skin));
  }
  if (spheres.centre.cols() != spheres.radius.size()) {
    throw ConfigError(fmt::format("{} centres but {} radii", spheres.centre.cols(), spheres.radius.size()));
  }
  const Index n = spheres.count();
  double rmin = n > 0 ? spheres.radius[0] : 0.0;
  double rmax = rmin;
  bool scanned = false;
  if (spheres.centre.outerStride() == 3) {
    const QuickScan q = scanSpheres(spheres, box, threads);
    if (q.good) {
      rmin = q.rmin;
      rmax = q.rmax;
      scanned = true;
    }
  }
  for (Index i = 0; i < n && !scanned; ++i) {
    const double r = spheres.radius[i];
    if (!(std::isfinite(r) && r > 0.0)) {
      throw ConfigError(fmt::format("particle {}: radius must be positive and finite, got {}", i, r));
    }
    const Eigen::Vector3d x = spheres.centre.col(i);
    if (!x.allFinite()) {
      throw ConfigError(fmt::format("particle {}: non-finite centre ({}, {}, {})", i, x[0], x[1], x[2]));
    }
    if (!box.contains(x)) {
      throw ConfigError(
          fmt::format("particle {}: centre ({}, {}, {}) outside the box {} (wrap periodic "
                      "coordinates into [0, L))",
                      i, x[0], x[1], x[2], box.describe()));
    }
    rmin = std::min(rmin, r);
    rmax = std::max(rmax, r);
  }
  const double cutoff = 2.0 * rmax + skin;
  for (int k = 0; k < 3; ++k) {
    if (box.periodic(k) && n > 0 && box.length(k) < 2.0 * cutoff) {
      throw ConfigError(
          fmt::format("box length {} along {} is below 2 * max cutoff ({} = 2 r_max + skin): "
                      "enlarge the box or make {} non-periodic",
                      box.length(k), "xyz"[k], cutoff, "xyz"[k]));
    }
  }
  return {rmin, rmax};
}

void BroadPhase::setThreads(int threads) {
  if (threads < 1) throw ConfigError(fmt::format("broad phase threads must be >= 1, got {}", threads));
  threads_ = threads;
}

void BroadPhase::findPairChunks(const SphereView& spheres, PairChunks& out) const {
  out.reset(1);
  findPairs(spheres, out[0]);
}

void BroadPhase::build(const SphereView& spheres, const Box& box, double skin) {
  const auto [rmin, rmax] = validateSpheres(spheres, box, skin, threads_);
  box_ = box;
  skin_ = skin;
  minRadius_ = rmin;
  maxRadius_ = rmax;
  doBuild(spheres);
}

void sortPairs(std::vector<Pair>& pairs) { std::sort(pairs.begin(), pairs.end()); }

}  // namespace polydem::broadphase
