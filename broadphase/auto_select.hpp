#pragma once
// `auto`: asks the HGrid cost model (seed 000 eq. 2.35, hgrid_cost_model.hpp) which structure is
// cheapest for the spheres it is built on — plain linked cell, Top-Down or Bottom-Up HGrid with
// optimised levels and cell sizes — then forwards every call to that backend. The optimisation
// (about 0.1 s for 10^5 spheres) is redone only when the radii, the box or the skin change, so a DEM
// run that rebuilds its neighbour list every few steps pays for it once.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "broadphase/broad_phase.hpp"
#include "broadphase/hgrid_config.hpp"

namespace polydem::broadphase {

/// K for the cost model on this machine: one cell look-up over one pair test, measured once per process
/// (calibrate_k.hpp). The HGrid keeps most levels in dense or bitmap-ranked cell arrays, so the dense
/// look-up time is the representative one (a hashed look-up is 3-5x slower; the HGrid uses hashing
/// only for very sparse levels, whose cells are rarely visited).
double modelCostRatio();

/// Optimiser-backed HGrid configurator (HGrid::setConfigurator) that caches its answer: the optimiser
/// runs again only when the radii, the box or the skin change.
class CachedGridOptimiser {
 public:
  HGridConfig operator()(const SphereView& spheres, const Box& box, double skin, CrossLevel mode);

 private:
  std::vector<double> radii_;
  Box box_;
  double skin_ = -1.0;
  CrossLevel mode_ = CrossLevel::TopDown;
  HGridConfig config_;
};

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
  /// The optimiser's summary: choice, predicted cost per particle, runner-up.
  const std::string& reason() const { return reason_; }
  /// Cell-access over pair-test cost ratio for the model; default: measured on this machine once per
  /// process (calibrate_k.hpp).
  void setCostRatio(double K) { costRatio_ = K; }
  /// Linked cell is kept unless the best HGrid's predicted work is below the linked cell's by more than
  /// this factor (>= 1). A unit of HGrid work (pair test or cell access, eq. 2.35) costs about twice a
  /// unit of one-level work here: `polydem bench model` (docs/benchmarks/model) measured 1.9-2.8x at
  /// power-law alpha = 0, where the model predicts 1.8-1.9x less work for the HGrid but linked cell ran
  /// 10-30% faster; at alpha <= -1 the predicted gap is 3.4x or more and the HGrid wins.
  void setHierarchyOverhead(double factor);
  static constexpr double kDefaultHierarchyOverhead = 2.0;

 protected:
  void doBuild(const SphereView& spheres) override;
  void doUpdate(const SphereView& spheres, std::span<const Index> moved) override;

 private:
  bool sameInputs(const SphereView& spheres) const;

  std::unique_ptr<BroadPhase> chosen_;
  std::string reason_;
  std::optional<double> costRatio_;
  double hierarchyOverhead_ = kDefaultHierarchyOverhead;
  // Inputs of the last optimisation.
  std::vector<double> radii_;
  Box lastBox_;
  double lastSkin_ = -1.0;
};

}  // namespace polydem::broadphase
