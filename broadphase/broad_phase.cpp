#include "broadphase/broad_phase.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "broadphase/pair_chunks.hpp"
#include "broadphase/parallel.hpp"
#include "core/errors.hpp"

namespace polydem::broadphase {

namespace {

/// The checks of validateSpheres() without messages, in parallel: {all good, r_min, r_max}. The serial
/// scan then names the first bad particle, so the error is the serial one.
struct QuickScan {
  bool good = true;
  double rmin = 0.0, rmax = 0.0;
};

QuickScan scanSpheres([[maybe_unused]] const SphereView& spheres, [[maybe_unused]] const Box& box,
                      [[maybe_unused]] int threads) {
  QuickScan q;
#if POLYDEM_WITH_OPENMP
  const Index n = spheres.count();
  q.rmin = spheres.radius[0];
  q.rmax = q.rmin;
  bool good = true;
  double rmin = q.rmin, rmax = q.rmax;
#pragma omp parallel for num_threads(threads) schedule(static) reduction(&& : good) reduction(min : rmin) \
    reduction(max : rmax)
  for (Index i = 0; i < n; ++i) {
    const double r = spheres.radius[i];
    const Eigen::Vector3d x = spheres.centre.col(i);
    good = good && std::isfinite(r) && r > 0.0 && x.allFinite() && box.contains(x);
    rmin = std::min(rmin, r);
    rmax = std::max(rmax, r);
  }
  q.good = good;
  q.rmin = rmin;
  q.rmax = rmax;
#endif
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
  if (parallel::usable(threads) > 1 && n >= 4096) {
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
