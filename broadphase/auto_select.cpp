#include "broadphase/auto_select.hpp"

#include <fmt/format.h>

#include <cmath>

#include "broadphase/calibrate_k.hpp"
#include "core/errors.hpp"
#include "broadphase/hgrid.hpp"
#include "broadphase/hgrid_cost_model.hpp"
#include "broadphase/linked_cell.hpp"

namespace polydem::broadphase {

double modelCostRatio() {
  const KCalibration& k = calibratedK();
  return k.denseCellAccessSeconds > 0.0 && k.pairTestSeconds > 0.0 ? k.denseCellAccessSeconds / k.pairTestSeconds
                                                                   : kDefaultCellOverPairCost;
}

namespace {
bool sameRadii(const std::vector<double>& stored, const SphereView& spheres) {
  if (static_cast<Index>(stored.size()) != spheres.count()) return false;
  for (Index i = 0; i < spheres.count(); ++i) {
    if (stored[static_cast<std::size_t>(i)] != spheres.radius[i]) return false;
  }
  return true;
}
}  // namespace

HGridConfig CachedGridOptimiser::operator()(const SphereView& spheres, const Box& box, double skin, CrossLevel mode) {
  if (!(box == box_) || skin != skin_ || mode != mode_ || !sameRadii(radii_, spheres)) {
    radii_.assign(spheres.radius.data(), spheres.radius.data() + spheres.count());
    box_ = box;
    skin_ = skin;
    mode_ = mode;
    config_ = optimiseForSpheres(radii_, box.volume(), skin, mode, modelCostRatio());
  }
  return config_;
}

Capabilities AutoSelect::capabilities() const { return chosen_ ? chosen_->capabilities() : Capabilities{}; }

void AutoSelect::setHierarchyOverhead(double factor) {
  if (!(factor >= 1.0) || !std::isfinite(factor)) {
    throw ConfigError(fmt::format("auto: hierarchy overhead must be a finite factor >= 1, got {}", factor));
  }
  hierarchyOverhead_ = factor;
  chosen_.reset();  // choose again at the next build
}

bool AutoSelect::sameInputs(const SphereView& spheres) const {
  return chosen_ && lastBox_ == box_ && lastSkin_ == skin_ && sameRadii(radii_, spheres);
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
      options.K = costRatio_ ? *costRatio_ : modelCostRatio();
      const OptimiserResult result = optimiseHGrid(CostModelPsd::sample(radii_, box_.volume(), skin_), options);
      const double linkedPredicted = result.table.front().topDown.predicted;  // L = 1: cells of the largest reach
      const bool keepLinked =
          !result.chosen.linkedCell && linkedPredicted <= hierarchyOverhead_ * result.chosen.predicted;
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
      reason_ = fmt::format("{} [K = {:.3g}]", result.summary(), options.K);
      if (keepLinked) {
        reason_ = fmt::format("linked-cell T/N={:.4g}, within {:g}x of the best HGrid's (the measured cost of "
                              "HGrid work, docs/benchmarks/model); {}",
                              linkedPredicted, hierarchyOverhead_, reason_);
      }
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
  if (!chosen_) return "auto (not built)";
  // An HGrid's description already carries the optimiser's summary (its config origin).
  if (chosen_->name() == "linked-cell") return fmt::format("auto -> {}; {}", chosen_->describe(), reason_);
  return fmt::format("auto -> {}", chosen_->describe());
}

}  // namespace polydem::broadphase
