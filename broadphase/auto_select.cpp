#include "broadphase/auto_select.hpp"

#include "broadphase/linked_cell.hpp"

namespace polydem::broadphase {

Capabilities AutoSelect::capabilities() const { return chosen_ ? chosen_->capabilities() : Capabilities{}; }

void AutoSelect::doBuild(const SphereView& spheres) {
  if (!chosen_) chosen_ = std::make_unique<LinkedCell>();
  reason_ = "linked-cell (no cost model in this build)";
  chosen_->setCounting(counting_);
  chosen_->build(spheres, box_, skin_);
}

void AutoSelect::doUpdate(const SphereView& spheres, std::span<const Index> moved) { chosen_->update(spheres, moved); }

void AutoSelect::findPairs(const SphereView& spheres, std::vector<Pair>& out) const {
  chosen_->resetCounters();
  chosen_->findPairs(spheres, out);
  counters_.pairTests += chosen_->counters().pairTests;
  counters_.cellAccesses += chosen_->counters().cellAccesses;
}

void AutoSelect::findNeighbours(const SphereView& spheres, Index i, double reach, std::vector<Index>& out) const {
  chosen_->findNeighbours(spheres, i, reach, out);
}

std::size_t AutoSelect::memoryBytes() const { return chosen_ ? chosen_->memoryBytes() : 0; }

std::string AutoSelect::describe() const {
  return chosen_ ? "auto -> " + chosen_->describe() : std::string("auto (not built)");
}

}  // namespace polydem::broadphase
