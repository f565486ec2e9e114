#pragma once
// `auto`: asks the HGrid cost model (thesis eq. 2.35, hgrid_cost_model.hpp) which structure is
// cheapest for the spheres it is built on — plain linked cell, Top-Down or Bottom-Up HGrid with
// optimised levels and cell sizes — then forwards every call to that backend. The optimisation
// (about 0.1 s for 10^5 spheres) is redone only when the radii, the box, the skin or K change
// (OptimiserCache, hgrid_optimiser.hpp), so a DEM run that rebuilds its neighbour list every few steps
// pays for it once. K is the calibrated one (modelCostRatio(), calibrate_k.hpp) unless setCostRatio().
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "broadphase/broad_phase.hpp"
#include "broadphase/calibrate_k.hpp"  // modelCostRatio(), for users of this header
#include "broadphase/hgrid_config.hpp"
#include "broadphase/hgrid_optimiser.hpp"

namespace polydem::broadphase {

class AutoSelect final : public BroadPhase {
 public:
  std::string_view name() const override { return "auto"; }
  Capabilities capabilities() const override;
  void findPairs(const SphereView& spheres, std::vector<Pair>& out) const override;
  void findPairChunks(const SphereView& spheres, PairChunks& out) const override;
  void findNeighbours(const SphereView& spheres, Index i, double reach, std::vector<Index>& out) const override;
  std::size_t memoryBytes() const override;
  std::string describe() const override;
  /// The backend chosen at the last build (nullptr before the first build).
  const BroadPhase* chosen() const { return chosen_.get(); }
  /// The optimiser's summary: choice, predicted cost per particle, runner-up.
  const std::string& reason() const { return reason_; }
  /// Cell-access over pair-test cost ratio K for the model; default: modelCostRatio(), measured on this
  /// machine once per process (calibrate_k.hpp). A different K optimises again at the next build.
  void setCostRatio(double K) { costRatio_ = K; }
  /// Linked cell is kept unless the best HGrid's predicted work is below the linked cell's by more than
  /// this factor (>= 1). A unit of HGrid work (pair test or cell access, eq. 2.35) costs about twice a
  /// unit of one-level work here: `polydem bench model` (docs/benchmarks/model) measured 1.9-2.8x at
  /// power-law alpha = 0, where the model predicts 1.8-1.9x less work for the HGrid but linked cell ran
  /// 10-30% faster; at alpha <= -1 the predicted gap is 3.4x or more and the HGrid wins.
  void setHierarchyOverhead(double factor);
  /// Optimise now for these radii in `box` with `skin` (the whole system's, in a distributed run where
  /// every rank builds on its own changing share of particles and ghosts) and keep that choice at every
  /// build in the same box with the same skin and K, instead of optimising for each build's spheres
  /// (which re-ran the optimiser at every neighbour-list build of every rank: a third of the run time at
  /// 2 ranks, docs/parallel.md). Only the optimiser's result is kept, not the radii. Its top level holds
  /// the sample's largest sphere, so a build's spheres must lie within the sample's radius range
  /// (ConfigError otherwise). A build in another box or with another skin or K optimises for its own
  /// spheres as before. Throws ConfigError for an empty sample or a radius that is not positive and finite.
  void setSample(std::span<const double> radii, const Box& box, double skin);
  static constexpr double kDefaultHierarchyOverhead = 2.0;

 protected:
  void doBuild(const SphereView& spheres) override;
  void doUpdate(const SphereView& spheres, std::span<const Index> moved) override;

 private:
  /// Make chosen_ the backend the optimiser's result and the hierarchy overhead pick.
  void choose(const OptimiserResult& result, double K);

  std::unique_ptr<BroadPhase> chosen_;
  std::string reason_;
  std::optional<double> costRatio_;
  double hierarchyOverhead_ = kDefaultHierarchyOverhead;
  OptimiserCache optimiser_;
  struct FixedChoice {  // setSample(): the choice for the system, valid in this box with this skin and K
    OptimiserResult result;
    Box box;
    double skin = 0.0;
    double K = 0.0;
  };
  std::optional<FixedChoice> fixed_;
  bool chosenFromFixed_ = false;  // chosen_ came from fixed_ (else from a build's own spheres)
};

}  // namespace polydem::broadphase
