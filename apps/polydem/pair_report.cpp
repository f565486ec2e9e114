#include "apps/polydem/pair_report.hpp"

#include <fmt/format.h>

#include "apps/polydem/common.hpp"
#include "broadphase/registry.hpp"

namespace polydem::app {

PairReport measurePairs(const std::string& backend, const SphereView& spheres, const Box& box, double skin,
                        int repeat) {
  auto bp = broadphase::makeBroadPhase(backend);
  return measurePairs(*bp, spheres, box, skin, repeat);
}

PairReport measurePairs(broadphase::BroadPhase& backend, const SphereView& spheres, const Box& box, double skin,
                        int repeat) {
  PairReport r;
  r.backend = std::string(backend.name());
  broadphase::BroadPhase* bp = &backend;
  std::vector<double> build, find;
  for (int k = 0; k <= repeat; ++k) {
    Stopwatch b;
    bp->build(spheres, box, skin);
    const double tb = b.seconds();
    Stopwatch f;
    bp->findPairs(spheres, r.pairs);
    const double tf = f.seconds();
    if (k > 0) {  // the first run warms caches and sizes buffers
      build.push_back(tb);
      find.push_back(tf);
    }
  }
  r.buildSeconds = median(build);
  r.findSeconds = median(find);
  r.description = bp->describe();
  r.memoryBytes = bp->memoryBytes();
  broadphase::sortPairs(r.pairs);
  r.candidatePairs = r.pairs.size();
  for (const auto& p : r.pairs) {
    const Eigen::Vector3d d = box.minimumImage(spheres.centre.col(p.i) - spheres.centre.col(p.j));
    const double contact = spheres.radius[p.i] + spheres.radius[p.j];
    if (d.squaredNorm() < contact * contact) ++r.overlappingPairs;
  }
  std::uint64_t sum = 0;
  for (const auto& p : r.pairs) sum = sum * 1000003u + static_cast<std::uint64_t>(p.i) * 7919u + p.j;
  r.checksum = sum;
  return r;
}

void printPairReport(const PairReport& r, Index count) {
  const double n = count > 0 ? static_cast<double>(count) : 1.0;
  fmt::print("broad phase: {}\n", r.description);
  fmt::print("candidate pairs: {}\n", r.candidatePairs);
  fmt::print("overlapping pairs: {}\n", r.overlappingPairs);
  fmt::print("time per particle: {:.4f} us (build {:.4f} us + find {:.4f} us, median)\n",
             1e6 * (r.buildSeconds + r.findSeconds) / n, 1e6 * r.buildSeconds / n, 1e6 * r.findSeconds / n);
  fmt::print("memory: {:.1f} bytes per particle\n", static_cast<double>(r.memoryBytes) / n);
}

}  // namespace polydem::app
