// Broad phases (broadphase/registry.hpp) and the HGrid cost model (broadphase/hgrid_optimiser.hpp).
//
// A BroadPhase keeps the arrays of its last build: a build on a C-contiguous (N, 3) float64 array (or a
// Fortran-ordered (3, N) one) reads the caller's memory, so update() after moving the spheres in place sees
// the new centres; other layouts are copied once per build (or per update(positions=...)).
#include <fmt/format.h>
#include <pybind11/stl.h>

#include <memory>
#include <optional>

#include "broadphase/auto_select.hpp"
#include "broadphase/hgrid.hpp"
#include "broadphase/hgrid_cost_evaluation.hpp"
#include "broadphase/hgrid_cost_psd.hpp"
#include "broadphase/hgrid_optimiser.hpp"
#include "broadphase/registry.hpp"
#include "core/errors.hpp"
#include "python/convert.hpp"
#include "python/distributions.hpp"

namespace polydem::python {

namespace {

using broadphase::CrossLevel;

CrossLevel modeFrom(const std::string& name) {
  if (name == "top-down" || name == "td") return CrossLevel::TopDown;
  if (name == "bottom-up" || name == "bu") return CrossLevel::BottomUp;
  throw ConfigError(fmt::format("mode '{}': expected top-down or bottom-up", name));
}

const char* modeName(CrossLevel mode) { return mode == CrossLevel::TopDown ? "top-down" : "bottom-up"; }

/// One backend of the registry plus the arrays of its last build.
class PyBroadPhase {
 public:
  PyBroadPhase(const std::string& name, int levels, std::vector<double> cellSizes, std::optional<double> costRatio,
               std::optional<double> hierarchyOverhead, bool counting)
      : name_(name), levels_(levels), cellSizes_(std::move(cellSizes)), counting_(counting) {
    backend_ = broadphase::makeBroadPhase(name);  // ConfigError listing the valid names
    const bool handSet = levels_ != 0 || !cellSizes_.empty();
    if (handSet && name != "hgrid-td" && name != "hgrid-bu") {
      throw ConfigError(fmt::format("levels and cell_sizes apply to hgrid-td and hgrid-bu, not '{}'", name));
    }
    if (levels_ < 0) throw ConfigError(fmt::format("levels must be >= 1, got {}", levels_));
    if (levels_ != 0 && !cellSizes_.empty() && levels_ != static_cast<int>(cellSizes_.size())) {
      throw ConfigError(fmt::format("levels {} but cell_sizes lists {} sizes", levels_, cellSizes_.size()));
    }
    if ((costRatio || hierarchyOverhead) && name != "auto") {
      throw ConfigError(fmt::format("cost_ratio and hierarchy_overhead apply to auto, not '{}'", name));
    }
    if (auto* a = dynamic_cast<broadphase::AutoSelect*>(backend_.get())) {
      if (costRatio) a->setCostRatio(*costRatio);
      if (hierarchyOverhead) a->setHierarchyOverhead(*hierarchyOverhead);
    }
    backend_->setCounting(counting_);
  }

  /// Index the spheres; the GIL is released during the build.
  void build(const py::handle& positions, const py::handle& radii, const py::handle& box, const py::handle& boundaries,
             double skin) {
    auto centres = std::make_unique<Centres>(positions, "positions");
    auto r = std::make_unique<Radii>(radii, "radii", centres->count());
    box_ = boxFrom(box, boundaries);
    centres_ = std::move(centres);
    radii_ = std::move(r);
    const SphereView spheres = view();
    if (levels_ != 0 || !cellSizes_.empty()) configureHandSet(spheres, skin);
    py::gil_scoped_release release;
    backend_->build(spheres, box_, skin);
    built_ = true;
  }

  /// The spheres moved (all, or those listed in `moved`); new centres may be given (same count).
  void update(const py::object& moved, const py::object& positions) {
    requireBuilt("update");
    if (!positions.is_none()) {
      auto centres = std::make_unique<Centres>(positions, "positions");
      if (centres->count() != radii_->count()) {
        throw ConfigError(fmt::format("positions: {} centres, but the broad phase was built on {}", centres->count(),
                                      radii_->count()));
      }
      centres_ = std::move(centres);
    }
    std::vector<Index> list;
    if (moved.is_none()) {
      list.resize(static_cast<std::size_t>(radii_->count()));
      for (Index i = 0; i < radii_->count(); ++i) list[static_cast<std::size_t>(i)] = i;
    } else {
      list = toIndices(moved, "moved");
      for (Index i : list) {
        if (i < 0 || i >= radii_->count()) {
          throw ConfigError(fmt::format("moved: index {} outside 0..{}", i, radii_->count() - 1));
        }
      }
    }
    const SphereView spheres = view();
    py::gil_scoped_release release;
    backend_->update(spheres, list);
  }

  /// (i, j) int32 arrays, i < j; sorted by (i, j) unless sort=False (backend order).
  py::tuple findPairs(bool sort) {
    requireBuilt("find_pairs");
    {
      py::gil_scoped_release release;
      backend_->findPairs(view(), pairs_);
      if (sort) broadphase::sortPairs(pairs_);
    }
    const auto n = static_cast<py::ssize_t>(pairs_.size());
    py::array_t<Index> i(n), j(n);
    Index* pi = i.mutable_data();
    Index* pj = j.mutable_data();
    for (py::ssize_t k = 0; k < n; ++k) {
      pi[k] = pairs_[static_cast<std::size_t>(k)].i;
      pj[k] = pairs_[static_cast<std::size_t>(k)].j;
    }
    return py::make_tuple(i, j);
  }

  py::array_t<Index> findNeighbours(Index k, std::optional<double> reach) {
    requireBuilt("find_neighbours");
    if (k < 0 || k >= radii_->count())
      throw ConfigError(fmt::format("sphere {} outside 0..{}", k, radii_->count() - 1));
    const double r = reach.value_or(backend_->skin());
    if (!(r >= 0.0 && r <= backend_->skin())) {
      throw ConfigError(fmt::format("reach {} outside [0, skin = {}]", r, backend_->skin()));
    }
    std::vector<Index> out;
    backend_->findNeighbours(view(), k, r, out);
    return copyOut(out);
  }

  py::dict counters() const {
    py::dict d;
    d["pair_tests"] = backend_->counters().pairTests;
    d["cell_accesses"] = backend_->counters().cellAccesses;
    return d;
  }
  void setCounting(bool on) { backend_->setCounting(on); }
  void resetCounters() const { backend_->resetCounters(); }
  const broadphase::BroadPhase& backend() const { return *backend_; }
  bool zeroCopy() const { return centres_ && centres_->zeroCopy(); }

  /// auto: the chosen backend's name (None before the first build); others: their own name.
  py::object chosen() const {
    if (const auto* a = dynamic_cast<const broadphase::AutoSelect*>(backend_.get())) {
      return a->chosen() ? py::object(py::str(std::string(a->chosen()->name()))) : py::object(py::none());
    }
    return py::str(std::string(backend_->name()));
  }
  py::object reason() const {
    if (const auto* a = dynamic_cast<const broadphase::AutoSelect*>(backend_.get())) return py::str(a->reason());
    return py::none();
  }
  /// The cell sizes of an HGrid (or of auto's HGrid choice) after the last build; None otherwise.
  py::object cellSizes() const {
    const broadphase::BroadPhase* bp = backend_.get();
    if (const auto* a = dynamic_cast<const broadphase::AutoSelect*>(bp)) bp = a->chosen();
    if (const auto* td = dynamic_cast<const broadphase::HGrid<CrossLevel::TopDown>*>(bp)) {
      return py::cast(td->config().cellSizes);
    }
    if (const auto* bu = dynamic_cast<const broadphase::HGrid<CrossLevel::BottomUp>*>(bp)) {
      return py::cast(bu->config().cellSizes);
    }
    return py::none();
  }

 private:
  SphereView view() const { return {centres_->matrix(), radii_->vector()}; }
  void requireBuilt(const char* what) const {
    if (!built_) throw ConfigError(fmt::format("{}: call build(positions, radii, box) first", what));
  }

  /// As `polydem pairs --levels L` / `--cell-sizes`: given sizes, or the cost model's optimal sizes for L.
  void configureHandSet(const SphereView& spheres, double skin) {
    broadphase::HGridConfig config;
    config.mode = name_ == "hgrid-td" ? CrossLevel::TopDown : CrossLevel::BottomUp;
    if (!cellSizes_.empty()) {
      config.cellSizes = cellSizes_;
      config.origin = "set by hand (cell_sizes)";
    } else {
      std::vector<double> radii(spheres.radius.data(), spheres.radius.data() + spheres.count());
      const auto psd = broadphase::CostModelPsd::sample(radii, box_.volume(), skin);
      const double K = broadphase::modelCostRatio();
      std::vector<double> sizes = broadphase::optimalCellSizes(psd, levels_, config.mode, K);
      for (double s : sizes) {  // collapsed levels are empty: keep strictly increasing sizes
        if (config.cellSizes.empty() || s > config.cellSizes.back()) config.cellSizes.push_back(s);
      }
      config.origin = fmt::format("levels {}: optimal sizes of the cost model (K = {:.3g}), predicted T/N = {:.3g}",
                                  levels_, K, broadphase::costPerParticle(psd, config.cellSizes, config.mode, K));
    }
    if (config.mode == CrossLevel::TopDown) {
      auto grid = std::make_unique<broadphase::HGrid<CrossLevel::TopDown>>();
      grid->setConfig(config);
      backend_ = std::move(grid);
    } else {
      auto grid = std::make_unique<broadphase::HGrid<CrossLevel::BottomUp>>();
      grid->setConfig(config);
      backend_ = std::move(grid);
    }
    backend_->setCounting(counting_);
  }

  std::string name_;
  int levels_ = 0;
  std::vector<double> cellSizes_;
  bool counting_ = false;
  std::unique_ptr<broadphase::BroadPhase> backend_;
  std::unique_ptr<Centres> centres_;
  std::unique_ptr<Radii> radii_;
  Box box_;
  bool built_ = false;
  std::vector<broadphase::Pair> pairs_;  // reused: steady-state find_pairs calls do not grow it
};

py::dict choiceDict(const broadphase::GridChoice& c) {
  py::dict d;
  d["linked_cell"] = c.linkedCell;
  d["levels"] = c.levels;
  d["predicted"] = c.predicted;
  d["mode"] = modeName(c.config.mode);
  d["cell_sizes"] = c.config.cellSizes;
  return d;
}

py::object predictedOrNone(const broadphase::LevelChoice& c) {
  return std::isfinite(c.predicted) ? py::object(py::float_(c.predicted)) : py::object(py::none());
}

broadphase::CostModelPsd psdFrom(const std::shared_ptr<Distribution>& distribution, const py::object& radii,
                                 std::optional<double> packingFraction, std::optional<double> boxVolume, double skin) {
  if ((distribution == nullptr) == radii.is_none()) {
    throw ConfigError("cost model: give either a distribution (with packing_fraction) or radii (with box_volume)");
  }
  if (distribution) {
    if (!packingFraction) throw ConfigError("cost model: a distribution needs packing_fraction");
    return broadphase::CostModelPsd::analytic(distribution->get(), *packingFraction, skin);
  }
  if (!boxVolume) throw ConfigError("cost model: radii need box_volume");
  const Eigen::VectorXd r = toVector(radii, "radii");
  return broadphase::CostModelPsd::sample(std::span<const double>(r.data(), static_cast<std::size_t>(r.size())),
                                          *boxVolume, skin);
}

}  // namespace

void bindBroadPhase(py::module_& m) {
  m.def("backend_names", &broadphase::backendNames, "the broad-phase backends compiled in (without auto)");
  py::class_<PyBroadPhase>(m, "BroadPhase",
                           "A contact-detection backend of the registry: build, update, find_pairs, find_neighbours.")
      .def(py::init<const std::string&, int, std::vector<double>, std::optional<double>, std::optional<double>, bool>(),
           py::arg("name") = "auto", py::arg("levels") = 0, py::arg("cell_sizes") = std::vector<double>{},
           py::arg("cost_ratio") = py::none(), py::arg("hierarchy_overhead") = py::none(), py::arg("counting") = false,
           "name: a backend_names() entry or auto. hgrid-td/-bu: levels (sizes from the cost model) or cell_sizes. "
           "auto: cost_ratio K, hierarchy_overhead. counting: count pair tests and cell accesses")
      .def("build", &PyBroadPhase::build, py::arg("positions"), py::arg("radii"), py::arg("box"),
           py::arg("boundaries") = py::none(), py::arg("skin") = 0.0,
           "positions (N, 3) or (3, N) float64, radii (N,), box a Box or three lengths (+ boundaries); pairs count "
           "when the gap is <= skin")
      .def("update", &PyBroadPhase::update, py::arg("moved") = py::none(), py::arg("positions") = py::none(),
           "the spheres in `moved` (default all) changed position; optionally new positions")
      .def("find_pairs", &PyBroadPhase::findPairs, py::arg("sort") = true,
           "every pair with gap <= skin as (i, j) int32 arrays, i < j, sorted unless sort=False")
      .def("find_neighbours", &PyBroadPhase::findNeighbours, py::arg("k"), py::arg("reach") = py::none(),
           "every j != k with gap <= reach (default skin), ascending int32")
      .def_property_readonly("name", [](const PyBroadPhase& b) { return std::string(b.backend().name()); })
      .def("describe", [](const PyBroadPhase& b) { return b.backend().describe(); })
      .def_property_readonly("memory_bytes", [](const PyBroadPhase& b) { return b.backend().memoryBytes(); })
      .def_property_readonly("complete", [](const PyBroadPhase& b) { return b.backend().capabilities().complete; })
      .def_property_readonly("incremental",
                             [](const PyBroadPhase& b) { return b.backend().capabilities().incremental; })
      .def_property_readonly("skin", [](const PyBroadPhase& b) { return b.backend().skin(); })
      .def_property_readonly("counters", &PyBroadPhase::counters)
      .def("set_counting", &PyBroadPhase::setCounting, py::arg("on"))
      .def("reset_counters", &PyBroadPhase::resetCounters)
      .def_property_readonly("zero_copy", &PyBroadPhase::zeroCopy,
                             "True when the last build reads the caller's positions array without a copy")
      .def_property_readonly("chosen", &PyBroadPhase::chosen, "auto: the backend it chose at the last build")
      .def_property_readonly("reason", &PyBroadPhase::reason, "auto: the optimiser's summary")
      .def_property_readonly("cell_sizes", &PyBroadPhase::cellSizes, "HGrid (or auto's HGrid): nominal cell sizes");

  m.def("model_cost_ratio", &broadphase::modelCostRatio,
        "K = cell access / pair test cost, calibrated once per process (what auto uses)");
  m.def(
      "cost_model",
      [](const std::shared_ptr<Distribution>& distribution, const py::object& radii, std::optional<double> phi,
         std::optional<double> boxVolume, double skin, int maxLevels, std::optional<double> K,
         std::optional<std::string> mode) {
        const broadphase::CostModelPsd psd = psdFrom(distribution, radii, phi, boxVolume, skin);
        broadphase::OptimiserOptions options;
        options.maxLevels = maxLevels;
        options.K = K ? *K : broadphase::modelCostRatio();
        if (mode) options.mode = modeFrom(*mode);
        broadphase::OptimiserResult r;
        {
          py::gil_scoped_release release;
          r = broadphase::optimiseHGrid(psd, options);
        }
        py::dict out;
        out["K"] = options.K;
        out["chosen"] = choiceDict(r.chosen);
        out["runner_up"] = choiceDict(r.runnerUp);
        out["summary"] = r.summary();
        py::dict table;
        std::vector<int> levels;
        py::list td, bu, tdConstant, buConstant, tdSizes, buSizes;
        for (const broadphase::LevelsRow& row : r.table) {
          levels.push_back(row.levels);
          td.append(predictedOrNone(row.topDown));
          bu.append(predictedOrNone(row.bottomUp));
          tdConstant.append(predictedOrNone(row.constantMTopDown));
          buConstant.append(predictedOrNone(row.constantMBottomUp));
          tdSizes.append(row.topDown.cellSizes);
          buSizes.append(row.bottomUp.cellSizes);
        }
        table["levels"] = levels;
        table["top_down"] = td;
        table["bottom_up"] = bu;
        table["constant_m_top_down"] = tdConstant;
        table["constant_m_bottom_up"] = buConstant;
        table["top_down_sizes"] = tdSizes;
        table["bottom_up_sizes"] = buSizes;
        out["table"] = table;
        return out;
      },
      py::arg("distribution") = nullptr, py::arg("radii") = py::none(), py::arg("packing_fraction") = py::none(),
      py::arg("box_volume") = py::none(), py::arg("skin") = 0.0, py::arg("max_levels") = 30, py::arg("K") = py::none(),
      py::arg("mode") = py::none(),
      "The HGrid cost model (thesis eq. 2.35) and its optimiser: predicted cost per particle T/N for every level "
      "count (None where not evaluated), the chosen grid (what auto builds) and the runner-up");
  m.def(
      "cost_per_particle",
      [](const std::vector<double>& cellSizes, const std::string& mode,
         const std::shared_ptr<Distribution>& distribution, const py::object& radii, std::optional<double> phi,
         std::optional<double> boxVolume, double skin, std::optional<double> K) {
        const broadphase::CostModelPsd psd = psdFrom(distribution, radii, phi, boxVolume, skin);
        return broadphase::costPerParticle(psd, cellSizes, modeFrom(mode), K ? *K : broadphase::modelCostRatio());
      },
      py::arg("cell_sizes"), py::arg("mode") = "top-down", py::arg("distribution") = nullptr,
      py::arg("radii") = py::none(), py::arg("packing_fraction") = py::none(), py::arg("box_volume") = py::none(),
      py::arg("skin") = 0.0, py::arg("K") = py::none(), "predicted T/N of given nominal cell sizes");
}

}  // namespace polydem::python
