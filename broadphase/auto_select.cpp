#include "broadphase/auto_select.hpp"

#include <fmt/format.h>

#include "broadphase/calibrate_k.hpp"
#include "broadphase/hgrid.hpp"
#include "broadphase/hgrid_cost_model.hpp"
#include "broadphase/linked_cell.hpp"

namespace polydem::broadphase {

Capabilities AutoSelect::capabilities() const { return chosen_ ? chosen_->capabilities() : Capabilities{}; }

bool AutoSelect::sameInputs(const SphereView& spheres) const {
  if (!chosen_ || !(lastBox_ == box_) || lastSkin_ != skin_) return false;
  if (static_cast<Index>(radii_.size()) != spheres.count()) return false;
  for (Index i = 0; i < spheres.count(); ++i) {
    if (radii_[static_cast<std::size_t>(i)] != spheres.radius[i]) return false;
  }
  return true;
}

void AutoSelect::doBuild(const SphereView& spheres) {
  if (!sameInputs(spheres)) {
    radii_.assign(spheres.radius.data(), spheres.radius.data() + spheres.count());
    lastBox_ = box_;
    lastSkin_ = skin_;
    if (spheres.count() < 2) {
      chosen_ = std::make_unique<LinkedCell>();
      reason_ = "linked-cell (fewer than two spheres)";
    } else {
      OptimiserOptions options;
      options.K = costRatio_ ? *costRatio_ : calibratedK().K;
      const OptimiserResult result = optimiseHGrid(CostModelPsd::sample(radii_, box_.volume(), skin_), options);
      if (result.chosen.linkedCell) {
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
      reason_ = fmt::format("{} [K = {:.3g}]", result.summary(), options.K);
    }
  }
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
  return chosen_ ? fmt::format("auto -> {}; {}", chosen_->describe(), reason_) : std::string("auto (not built)");
}

}  // namespace polydem::broadphase
