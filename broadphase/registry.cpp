#include "broadphase/registry.hpp"

#include <fmt/format.h>

#include <array>

#include "broadphase/aabb_tree.hpp"
#include "broadphase/auto_select.hpp"
#include "broadphase/brute_force.hpp"
#include "broadphase/hgrid.hpp"
#include "broadphase/hgrid_dynamic.hpp"
#include "broadphase/hgrid_optimiser.hpp"
#include "broadphase/lbvh.hpp"
#include "broadphase/linked_cell.hpp"
#include "broadphase/sweep_and_prune.hpp"
#include "core/errors.hpp"
#include "polydem/config.hpp"

#if POLYDEM_WITH_CGAL
#include "broadphase/cgal_box.hpp"
#include "broadphase/delaunay.hpp"
#endif

namespace polydem::broadphase {
namespace {

template <class T>
std::unique_ptr<BroadPhase> make() {
  return std::make_unique<T>();
}

// HGrid variants configure themselves with the cost-model optimiser (cached across rebuilds) unless
// the caller sets cell sizes by hand with setConfig().
template <class Grid>
std::unique_ptr<BroadPhase> makeOptimisedGrid() {
  auto grid = std::make_unique<Grid>();
  grid->setConfigurator(CachedGridOptimiser{});
  return grid;
}

struct Entry {
  std::string_view name;
  std::unique_ptr<BroadPhase> (*create)();
};

// No self-registering statics: static libraries drop them.
constexpr Entry kBackends[] = {
    {"brute", &make<BruteForce>},
    {"linked-cell", &make<LinkedCell>},
    {"hgrid-td", &makeOptimisedGrid<HGridTopDown>},
    {"hgrid-bu", &makeOptimisedGrid<HGridBottomUp>},
    {"sap", &make<SweepAndPrune>},
    {"lbvh", &make<Lbvh>},
    {"aabb-tree", &make<AabbTree>},
    {"hgrid-dynamic", &make<HGridDynamic>},
#if POLYDEM_WITH_CGAL
    {"cgal-box", &make<CgalBox>},
    {"delaunay", &make<Delaunay>},
#endif
};

// Backends left out of this build (optional dependency off), so the error can say why they are missing.
#if POLYDEM_WITH_CGAL
constexpr std::array<std::string_view, 0> kPlanned{};
#else
constexpr std::array<std::string_view, 2> kPlanned{"delaunay", "cgal-box"};
#endif

}  // namespace

std::vector<std::string> backendNames() {
  std::vector<std::string> names;
  for (const Entry& e : kBackends) names.emplace_back(e.name);
  return names;
}

std::unique_ptr<BroadPhase> makeBroadPhase(std::string_view name) {
  if (name == "auto") return std::make_unique<AutoSelect>();
  for (const Entry& e : kBackends) {
    if (e.name == name) return e.create();
  }
  std::string valid = "auto";
  for (const Entry& e : kBackends) valid += fmt::format(", {}", e.name);
  for (std::string_view planned : kPlanned) {
    if (planned == name) {
      throw ConfigError(fmt::format("broad phase '{}' is not available in this build; available: {}", name, valid));
    }
  }
  throw ConfigError(fmt::format("unknown broad phase '{}'; valid names: {}", name, valid));
}

}  // namespace polydem::broadphase
