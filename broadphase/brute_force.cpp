#include "broadphase/brute_force.hpp"

namespace polydem::broadphase {

void BruteForce::findPairs(const SphereView& spheres, std::vector<Pair>& out) const {
  out.clear();
  const Index n = spheres.count();
  for (Index i = 0; i < n; ++i) {
    for (Index j = i + 1; j < n; ++j) {
      if (withinReach(spheres, box_, i, j, skin_)) out.push_back({i, j});
    }
  }
  if (counting_) counters_.pairTests += static_cast<std::uint64_t>(n) * (n > 0 ? n - 1 : 0) / 2;
}

void BruteForce::findNeighbours(const SphereView& spheres, Index i, double reach, std::vector<Index>& out) const {
  out.clear();
  const Index n = spheres.count();
  for (Index j = 0; j < n; ++j) {
    if (j != i && withinReach(spheres, box_, i, j, reach)) out.push_back(j);
  }
}

}  // namespace polydem::broadphase
