#pragma once
// The reference backend: tests all N(N-1)/2 pairs. O(N^2); use it to check the others.
#include "broadphase/broad_phase.hpp"

namespace polydem::broadphase {

class BruteForce final : public BroadPhase {
 public:
  std::string_view name() const override { return "brute"; }
  void findPairs(const SphereView& spheres, std::vector<Pair>& out) const override;
  void findNeighbours(const SphereView& spheres, Index i, double reach, std::vector<Index>& out) const override;

 protected:
  void doBuild(const SphereView&) override {}
  void doUpdate(const SphereView&, std::span<const Index>) override {}
};

}  // namespace polydem::broadphase
