#include "broadphase/auto_select.hpp"

#include <fmt/format.h>

#include <cmath>

#include "broadphase/hgrid.hpp"
#include "broadphase/linked_cell.hpp"
#include "core/errors.hpp"

namespace polydem::broadphase {

Capabilities AutoSelect::capabilities() const { return chosen_ ? chosen_->capabilities() : Capabilities{}; }

void AutoSelect::setHierarchyOverhead(double factor) {
  if (!(factor >= 1.0) || !std::isfinite(factor)) {
    throw ConfigError(fmt::format("auto: hierarchy overhead must be a finite factor >= 1, got {}", factor));
  }
  hierarchyOverhead_ = factor;
  chosen_.reset();  // choose again at the next build
}

void AutoSelect::setSample(std::span<const double> radii, const Box& box, double skin) {
  for (double r : radii) {
    if (!(r > 0.0) || !std::isfinite(r)) {
      throw ConfigError(
          fmt::format("auto: the optimiser's sample holds a radius {} (expected positive and finite)", r));
    }
  }
  const double K = costRatio_ ? *costRatio_ : modelCostRatio();
  OptimiserCache once;  // the optimisation a build on these radii would run, without keeping the radii
  fixed_ = FixedChoice{once.result(radii, box, skin, std::nullopt, K), box, skin, K};
  chosen_.reset();  // choose again at the next build
}

namespace {
constexpr const char* kFewSpheres = "linked-cell (fewer than two spheres)";
}  // namespace

void AutoSelect::choose(const OptimiserResult& result, double K) {
  const double linkedPredicted = result.table.front().topDown.predicted;  // L = 1: cells of the largest reach
  const bool keepLinked = !result.chosen.linkedCell && linkedPredicted <= hierarchyOverhead_ * result.chosen.predicted;
  if (result.chosen.linkedCell || keepLinked) {
    chosen_ = std::make_unique<LinkedCell>();
  } else if (result.chosen.config.mode == CrossLevel::TopDown) {
    auto grid = std::make_unique<HGridTopDown>();
    grid->setConfig(result.chosen.config);
    chosen_ = std::move(grid);
  } else {
    auto grid = std::make_unique<HGridBottomUp>();
    grid->setConfig(result.chosen.config);
    chosen_ = std::move(grid);
  }
  reason_ = fmt::format("{} [K = {:.3g}]", result.summary(), K);
  if (keepLinked) {
    reason_ = fmt::format(
        "linked-cell T/N={:.4g}, within {:g}x of the best HGrid's (the measured cost of "
        "HGrid work, docs/benchmarks/model); {}",
        linkedPredicted, hierarchyOverhead_, reason_);
  }
}

void AutoSelect::doBuild(const SphereView& spheres) {
  if (spheres.count() < 2) {
    optimiser_.clear();
    chosenFromFixed_ = false;
    if (!chosen_ || reason_ != kFewSpheres) {
      chosen_ = std::make_unique<LinkedCell>();
      reason_ = kFewSpheres;
    }
  } else {
    const double K = costRatio_ ? *costRatio_ : modelCostRatio();
    if (fixed_ && fixed_->box == box_ && fixed_->skin == skin_ && fixed_->K == K) {
      if (!chosen_ || !chosenFromFixed_) choose(fixed_->result, K);
      chosenFromFixed_ = true;
    } else {
      const OptimiserResult& result = optimiser_.result(spheres, box_, skin_, std::nullopt, K);
      if (!chosen_ || chosenFromFixed_ || optimiser_.recomputed()) choose(result, K);
      chosenFromFixed_ = false;
    }
  }
  chosen_->setCounting(counting_);
  chosen_->setThreads(threads_);
  chosen_->build(spheres, box_, skin_);
}

void AutoSelect::doUpdate(const SphereView& spheres, std::span<const Index> moved) { chosen_->update(spheres, moved); }

void AutoSelect::findPairs(const SphereView& spheres, std::vector<Pair>& out) const {
  chosen_->resetCounters();
  chosen_->findPairs(spheres, out);
  counters_.pairTests += chosen_->counters().pairTests;
  counters_.cellAccesses += chosen_->counters().cellAccesses;
}

void AutoSelect::findPairChunks(const SphereView& spheres, PairChunks& out) const {
  chosen_->resetCounters();
  chosen_->findPairChunks(spheres, out);
  counters_.pairTests += chosen_->counters().pairTests;
  counters_.cellAccesses += chosen_->counters().cellAccesses;
}

void AutoSelect::findNeighbours(const SphereView& spheres, Index i, double reach, std::vector<Index>& out) const {
  chosen_->findNeighbours(spheres, i, reach, out);
}

std::size_t AutoSelect::memoryBytes() const { return chosen_ ? chosen_->memoryBytes() : 0; }

std::string AutoSelect::describe() const {
  if (!chosen_) return "auto (not built)";
  // An HGrid's description already carries the optimiser's summary (its config origin).
  if (chosen_->name() == "linked-cell") return fmt::format("auto -> {}; {}", chosen_->describe(), reason_);
  return fmt::format("auto -> {}", chosen_->describe());
}

}  // namespace polydem::broadphase
