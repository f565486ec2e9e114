#pragma once
// `auto`: picks a backend for the spheres it is built on, then forwards every call to it.
// Until the HGrid cost model exists the choice is always linked-cell.
#include <memory>
#include <string>

#include "broadphase/broad_phase.hpp"

namespace polydem::broadphase {

class AutoSelect final : public BroadPhase {
 public:
  std::string_view name() const override { return "auto"; }
  Capabilities capabilities() const override;
  void findPairs(const SphereView& spheres, std::vector<Pair>& out) const override;
  void findNeighbours(const SphereView& spheres, Index i, double reach, std::vector<Index>& out) const override;
  std::size_t memoryBytes() const override;
  std::string describe() const override;
  /// The backend chosen at the last build (nullptr before the first build).
  const BroadPhase* chosen() const { return chosen_.get(); }
  /// Why the last choice was made, e.g. predicted costs of the candidates.
  const std::string& reason() const { return reason_; }

 protected:
  void doBuild(const SphereView& spheres) override;
  void doUpdate(const SphereView& spheres, std::span<const Index> moved) override;

 private:
  std::unique_ptr<BroadPhase> chosen_;
  std::string reason_;
};

}  // namespace polydem::broadphase
