// HardSphereSystem, part: bounding neighbourhoods and near-neighbour lists (Donev 2006, thesis, §3.2.4):
// global rebuilds through the shared broad phase, Morton renumbering, the skin rule and its adaptation,
// the flat list storage, and neighbourhood exits answered by the exit index (SystemOptions::exitIndex).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/errors.hpp"
#include "core/morton.hpp"
#include "edmd/hard_sphere_system.hpp"

namespace polydem::edmd {

// ---------------------------------------------------------------------------------------------------
// Neighbourhoods

void HardSphereSystem::sortSpatially() {
  // Precondition: every particle advanced to clock_ (events are reset by the caller).
  const Index n = count();
  std::vector<std::pair<std::uint64_t, Index>> keys(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) {
    const State& s = state_[static_cast<std::size_t>(i)];
    keys[static_cast<std::size_t>(i)] = {mortonKey(s.x, box_, 10), i};
  }
  std::sort(keys.begin(), keys.end());
  LargeVector<State> state(state_.size());
  std::vector<Index> external(external_.size());
  std::vector<std::int64_t> runCounts(collisionsInRun_.size());
  Eigen::VectorXd mass(n), inverseMass(n);
  for (Index k = 0; k < n; ++k) {
    const std::size_t from = static_cast<std::size_t>(keys[static_cast<std::size_t>(k)].second);
    const std::size_t to = static_cast<std::size_t>(k);
    state[to] = state_[from];
    external[to] = external_[from];
    runCounts[to] = collisionsInRun_[from];
    mass[k] = mass_[static_cast<Index>(from)];
    inverseMass[k] = inverseMass_[static_cast<Index>(from)];
  }
  state_.swap(state);
  external_.swap(external);
  collisionsInRun_.swap(runCounts);
  mass_.swap(mass);
  inverseMass_.swap(inverseMass);
  collisionsAtSort_ = total_.collisions;
  recent_ = {};
}

void HardSphereSystem::rebuildNeighbourhoods() {
  // Precondition: every particle advanced to clock_.
  const Index n = count();
  if (n == 0) return;
  sortSpatially();
  assignClasses();
  double rmin = kInfinity;
  for (const State& s : state_) rmin = std::min(rmin, radiusAt(s));
  nbCentre_.resize(3, n);
  nbRadius_.resize(n);
  if (options_.adaptiveSkin &&
      (total_.collisions - collisionsAtRebuild_) + (total_.exits - exitsAtRebuild_) >= std::int64_t{n}) {
    if (classSkins()) {
      // Decided from the statistics of the epoch that ends here, all classes at once. Growth starts from
      // the floor at which the class's skins begin to move (classFloorMin), doubling when far off.
      std::vector<int> trend(classFloor_.size());
      for (std::size_t c = 0; c < classFloor_.size(); ++c) trend[c] = classTrend(c);
      for (std::size_t c = 0; c < classFloor_.size(); ++c) {
        double& f = classFloor_[c];
        const double lowest = classFloorMin(c);
        if (trend[c] > 0) f = std::min(std::max(f, lowest) * (trend[c] > 1 ? 2.0 : 1.3), std::max(1e3, lowest));
        if (trend[c] < 0) f = std::max(f / 1.15, lowest);
      }
    } else {
      const int trend = skinTrend();
      if (trend > 0) skinFloor_ = std::min(skinFloor_ * 1.3, 1e3);
      if (trend < 0) skinFloor_ = std::max(skinFloor_ / 1.15, options_.skinFloor);
    }
  }
  collisionsAtRebuild_ = total_.collisions;
  exitsAtRebuild_ = total_.exits;
  pairsAtRebuild_ = pairWork_;
  classAtRebuild_ = classTotal_;
  const double mu1 = options_.neighbourhoodScale - 1.0;
  const double floor = skinFloor_ * rmin;
  // The broad phase needs periodic edges of at least 4 neighbourhood radii.
  double rmax = 0.0;
  for (const State& s : state_) rmax = std::max(rmax, radiusAt(s));
  const double skinLimit = 0.25 * periodicLength() * (1.0 - 1e-9) - rmax;
  // Skins squeezed far below normal would make every sphere exit at once, rebuild after rebuild.
  if (!(skinLimit > 0.1 * mu1 * rmin)) {
    const std::string what = fmt::format(
        "at t = {} the largest sphere (radius {}) leaves no room for its neighbourhood: 4 neighbourhood radii "
        "must fit into the shortest periodic box edge {}; use more particles",
        time(), rmax, periodicLength());
    if (total_.rebuilds == 0) throw ConfigError(what);
    throw SimulationError(what);
  }
  for (Index i = 0; i < n; ++i) {
    const State& s = state_[static_cast<std::size_t>(i)];
    Hood& h = hood_[static_cast<std::size_t>(i)];
    const double r = radiusAt(s);
    double skin;
    if (classSkins()) {
      const std::size_t c = static_cast<std::size_t>(h.cls);
      const double lower = rmin * std::ldexp(1.0, static_cast<int>(c));  // the class's smallest radius
      skin = std::max(std::min(r, options_.skinCap * rmin), classFloor_[c] * rmin * std::pow(lower / r, 1.5));
    } else {
      skin = std::max(std::min(r, options_.skinCap * rmin), floor * std::pow(rmin / r, 1.5));
    }
    h.skin = std::min(mu1 * skin, skinLimit);
    h.radius = r + h.skin;
    for (int k = 0; k < 3; ++k) h.centre[k] = s.x[k];
    nbRadius_[i] = h.radius;
    nbCentre_.col(i) = Eigen::Vector3d(s.x[0], s.x[1], s.x[2]);
  }
  const SphereView view{nbCentre_, nbRadius_};
  exits_->build(view, box_, 0.0);
  if (total_.rebuilds == 0) {
    // The first lists come from the shared broad phase; later rebuilds query the exit index, whose
    // predicate is the broad phase's (the same sorted lists, so the same trajectory), because the HGrid
    // re-optimises its levels at every build: on uniform radius omega = 100 (N = 2000) one build cost as
    // much as 60,000 collisions' worth of instructions (issue 24 profile, docs/benchmarks/edmd/).
    broad_->build(view, box_, 0.0);
    broad_->findPairs(view, pairScratch_);
  } else {
    exits_->findPairs(view, pairScratch_);
  }
  for (Hood& h : hood_) h.size = 0;
  for (const broadphase::Pair& p : pairScratch_) {
    ++hood_[static_cast<std::size_t>(p.i)].size;
    ++hood_[static_cast<std::size_t>(p.j)].size;
  }
  Index offset = 0;
  for (Hood& h : hood_) {
    h.begin = offset;
    h.capacity = h.size + 6 + h.size / 3;  // spare room for neighbourhood exits
    offset += h.capacity;
    h.size = 0;
  }
  nbData_.assign(static_cast<std::size_t>(offset), -1);
  for (const broadphase::Pair& p : pairScratch_) {
    Hood& a = hood_[static_cast<std::size_t>(p.i)];
    Hood& b = hood_[static_cast<std::size_t>(p.j)];
    nbData_[static_cast<std::size_t>(a.begin + a.size++)] = p.j;
    nbData_[static_cast<std::size_t>(b.begin + b.size++)] = p.i;
  }
  // Sorted lists: the trajectory does not depend on the backend's pair order.
  for (const Hood& h : hood_) std::sort(nbData_.begin() + h.begin, nbData_.begin() + h.begin + h.size);
  countClassEntries();
  ++total_.rebuilds;
}

void HardSphereSystem::assignClasses() {
  // Class c = floor(log2(O_i / O_min)) from the masses (O^3 up to a common factor), which never change.
  // Without class skins the classes only sort the statistics (skinClasses()).
  const Index n = count();
  const bool split = sizeRatio_ >= 2.0 && n > 0;
  const double lightest = n > 0 ? mass_.minCoeff() : 1.0;
  Index top = 0;
  for (Index i = 0; i < n; ++i) {
    Index c = 0;
    if (split) {
      const double level = std::floor(std::log2(mass_[i] / lightest) / 3.0);
      c = static_cast<Index>(std::clamp(level, 0.0, 63.0));
    }
    hood_[static_cast<std::size_t>(i)].cls = c;
    top = std::max(top, c);
  }
  const std::size_t classes = static_cast<std::size_t>(top) + 1;
  if (classCount_.size() != classes) {
    classFloor_.resize(classes);
    for (std::size_t c = 0; c < classes; ++c) classFloor_[c] = classFloorMin(c);
    classTotal_.assign(classes, ClassCounters{});
    classAtRebuild_.assign(classes, ClassCounters{});
    classEntries_.assign(classes * classes, 0);
  }
  classCount_.assign(classes, 0);
  for (const Hood& h : hood_) ++classCount_[static_cast<std::size_t>(h.cls)];
}

void HardSphereSystem::countClassEntries() {
  std::fill(classEntries_.begin(), classEntries_.end(), 0);
  if (!classSkins()) return;
  const std::size_t classes = classCount_.size();
  for (Index i = 0; i < count(); ++i) {
    const std::size_t row = static_cast<std::size_t>(hood_[static_cast<std::size_t>(i)].cls) * classes;
    for (Index j : neighboursOf(i))
      ++classEntries_[row + static_cast<std::size_t>(hood_[static_cast<std::size_t>(j)].cls)];
  }
}

double HardSphereSystem::classFloorMin(std::size_t c) const {
  // Below min(2^c, kappa) the floor does not reach the class's skins (skin_i >= min(O_i, kappa O_min)),
  // and options_.skinFloor 2^(-3c/2) is the single-floor rule's floor: the larger of the two.
  const double reach = std::min(std::ldexp(1.0, static_cast<int>(c)), options_.skinCap);
  return std::max(options_.skinFloor * std::pow(2.0, -1.5 * static_cast<double>(c)), reach);
}

void HardSphereSystem::relocateList(Index i, Index capacity) {
  Hood& h = hood_[static_cast<std::size_t>(i)];
  const Index begin = static_cast<Index>(nbData_.size());
  nbData_.resize(nbData_.size() + static_cast<std::size_t>(capacity), -1);
  std::copy(nbData_.begin() + h.begin, nbData_.begin() + h.begin + h.size, nbData_.begin() + begin);
  h.begin = begin;
  h.capacity = capacity;
  ++total_.relocatedLists;
}

namespace {

// std::lower_bound without a branch on the comparisons (a conditional move per halving): in the long
// sorted lists of the large spheres of wide distributions the comparisons are coin flips, and their
// mispredictions were half the time of a list update (uniform volume omega 50).
Index* lowerBound(Index* first, std::size_t size, Index j) {
  if (size == 0) return first;
  Index* base = first;
  while (size > 1) {
    const std::size_t half = size / 2;
    base = base[half] < j ? base + half : base;
    size -= half;
  }
  return base + (*base < j ? 1 : 0);
}

}  // namespace

void HardSphereSystem::insertNeighbour(Index i, Index j) {
  Hood& h = hood_[static_cast<std::size_t>(i)];
  if (h.size == h.capacity) relocateList(i, 2 * h.capacity + 8);
  Index* first = nbData_.data() + h.begin;
  Index* last = first + h.size;
  Index* at = lowerBound(first, static_cast<std::size_t>(h.size), j);
  std::copy_backward(at, last, last + 1);
  *at = j;
  ++h.size;
}

void HardSphereSystem::eraseNeighbour(Index i, Index j) {
  Hood& h = hood_[static_cast<std::size_t>(i)];
  Index* first = nbData_.data() + h.begin;
  Index* last = first + h.size;
  Index* at = lowerBound(first, static_cast<std::size_t>(h.size), j);
  if (at == last || *at != j) return;
  std::copy(at + 1, last, at);
  --h.size;
}

double HardSphereSystem::exitLead(std::size_t c) const {
  // Bounces per exit B of the class: collisions of its members per exit, over the current epoch (all
  // epochs until it has 64 exits). A random flight with isotropic scattering and mean free path lambda,
  // re-centred at each exit of a room R, has the fewest exits per path length at lead ~0.9 when
  // lambda >~ R (B <~ 2), ~0.4-0.6 at lambda = R / 2 (B ~ 4) and ~0-0.2 below lambda = R / 5 (B >~ 15)
  // (docs/edmd.md, "Neighbourhood lead"); measured: uniform volume omega = 50 (small spheres flying through
  // the pores of large ones, B ~ 1.2) had 16% fewer exits at lead 0.8 than at 0, monodisperse spheres at
  // phi 0.5 (caged, B ~ 12) 15% more.
  const ClassCounters& now = classTotal_[c];
  const ClassCounters& then = classAtRebuild_[c];
  double exits = static_cast<double>(now.exits - then.exits);
  double collisions = static_cast<double>(now.collisions - then.collisions);
  if (exits < 64.0) {
    exits = static_cast<double>(now.exits);
    collisions = static_cast<double>(now.collisions);
  }
  if (!(exits > 0.0)) return 0.0;
  const double bounces = std::max(collisions, 1.0) / exits;
  return std::clamp(0.9 - 0.3 * std::log2(bounces / 1.5), 0.0, options_.exitLead);
}

void HardSphereSystem::placeCentre(Index i) {
  const State& s = state_[static_cast<std::size_t>(i)];
  Hood& hood = hood_[static_cast<std::size_t>(i)];
  double c[3] = {s.x[0], s.x[1], s.x[2]};
  const double speed2 = s.v[0] * s.v[0] + s.v[1] * s.v[1] + s.v[2] * s.v[2];
  // Size ratios < 2 keep their neighbourhoods on the sphere: their spheres are caged (monodisperse at phi
  // 0.5: ~12 bounces per exit, lead 0 by the rule anyway), and a lead during their compressions, which would
  // save ~15% of the exits there (~3% of the time), would change the trajectories the jamming tests and the
  // determinism reference were validated with.
  if (options_.exitLead > 0.0 && sizeRatio_ >= 2.0 && speed2 > 0.0) {
    // Ahead along v by lead x room; on a walled axis no further than the wall (the centre stays in the box).
    double step = exitLead(static_cast<std::size_t>(hood.cls)) * (hood.radius - radiusAt(s)) / std::sqrt(speed2);
    for (int k = 0; k < 3; ++k) {
      if (periodic_[k] || s.v[k] == 0.0) continue;
      const double limit = s.v[k] > 0.0 ? (length_[k] - s.x[k]) / s.v[k] : -s.x[k] / s.v[k];
      step = std::min(step, std::max(limit, 0.0));
    }
    for (int k = 0; k < 3; ++k) {
      c[k] = s.x[k] + step * s.v[k];
      if (periodic_[k]) {
        wrapIntoBox(c[k], k);
      } else {
        c[k] = std::clamp(c[k], 0.0, length_[k]);  // round-off of the step limit above
      }
    }
  }
  for (int k = 0; k < 3; ++k) hood.centre[k] = c[k];
  nbCentre_.col(i) = Eigen::Vector3d(c[0], c[1], c[2]);
}

void HardSphereSystem::refreshNeighbourhood(Index i) {
  const std::size_t ui = static_cast<std::size_t>(i);
  const State& s = state_[ui];
  auto restart = [&] {
    advanceAll();
    rebuildNeighbourhoods();
    resetSchedule();
  };
  Hood& hood = hood_[ui];
  if (hood.radius - radiusAt(s) < 0.5 * hood.skin) {
    restart();  // growth has used half of the room: a new epoch with larger neighbourhoods
    return;
  }
  if (options_.adaptiveSkin && total_.exits - exitsAtRebuild_ > 2 * std::int64_t{count()}) {
    // Skins too thin for how far the spheres fly: rebuild with a larger skin floor. The class rule is
    // O(classes^2), so it is asked every 256th exit only.
    const bool thin =
        classSkins() ? (total_.exits - exitsAtRebuild_) % 256 == 0 && classesWantRebuild(false) : skinTrend() > 0;
    if (thin) {
      restart();
      return;
    }
  }
  placeCentre(i);
  const SphereView view{nbCentre_, nbRadius_};
  exits_->update(view, std::span<const Index>(&i, 1));
  exits_->findNeighbours(view, i, 0.0, scratch_);
  // Reverse entries: drop i from lists it left, add it to lists it entered (both lists sorted).
  const std::span<const Index> old = neighboursOf(i);
  added_.clear();
  removed_.clear();
  std::size_t a = 0, b = 0;
  while (a < old.size() || b < scratch_.size()) {
    if (b == scratch_.size() || (a < old.size() && old[a] < scratch_[b])) {
      removed_.push_back(old[a++]);
    } else if (a == old.size() || scratch_[b] < old[a]) {
      added_.push_back(scratch_[b++]);
    } else {
      ++a;
      ++b;
    }
  }
  // The reverse lists' headers are scattered: request them all before the first update waits on one.
  for (Index j : removed_) __builtin_prefetch(&hood_[static_cast<std::size_t>(j)]);
  for (Index j : added_) __builtin_prefetch(&hood_[static_cast<std::size_t>(j)]);
  for (Index j : removed_) eraseNeighbour(j, i);
  for (Index j : added_) insertNeighbour(j, i);
  if (classSkins()) {
    const std::size_t classes = classCount_.size();
    const std::size_t ci = static_cast<std::size_t>(hood.cls);
    for (Index j : removed_) {
      const std::size_t cj = static_cast<std::size_t>(hood_[static_cast<std::size_t>(j)].cls);
      --classEntries_[ci * classes + cj];
      --classEntries_[cj * classes + ci];
    }
    for (Index j : added_) {
      const std::size_t cj = static_cast<std::size_t>(hood_[static_cast<std::size_t>(j)].cls);
      ++classEntries_[ci * classes + cj];
      ++classEntries_[cj * classes + ci];
    }
  }
  const Index size = static_cast<Index>(scratch_.size());
  if (size > hood.capacity) relocateList(i, size + 8 + size / 2);
  std::copy(scratch_.begin(), scratch_.end(), nbData_.begin() + hood.begin);
  hood.size = size;
  predict(i);
}

// ---------------------------------------------------------------------------------------------------
// Skin adaptation

int HardSphereSystem::skinTrend() const {
  // Narrow distributions (size ratio < 2) keep the exits-per-collision rule: both rules leave their
  // skins at the floor at phi 0.5, and it keeps the trajectories the jamming results of docs/edmd-results.md
  // and tests/edmd were validated with.
  if (sizeRatio_ < 2.0) {
    const double exits = exitRatioSinceRebuild();
    return exits > 0.8 ? 1 : (exits < 0.2 ? -1 : 0);
  }
  const double exitWork = options_.exitWork * static_cast<double>(total_.exits - exitsAtRebuild_);
  const double pairWork = static_cast<double>(pairWork_ - pairsAtRebuild_);
  if (exitWork > 2.0 * pairWork) return 1;
  if (exitWork < 0.5 * pairWork) return -1;
  return 0;
}

int HardSphereSystem::classTrend(std::size_t c) const {
  // The work balance of skinTrend() per class. Pair work of class c: half of every list entry scanned
  // that involves a class-c sphere, i.e. half of the scans made by class-c spheres plus half of the
  // class-c entries scanned by all classes d (entries of class c in class-d lists x predictions per
  // class-d sphere); summed over the classes it is the total pair work, as in skinTrend().
  const std::size_t classes = classCount_.size();
  const ClassCounters& now = classTotal_[c];
  const ClassCounters& then = classAtRebuild_[c];
  const double predictions = static_cast<double>(now.predictions - then.predictions);
  // Too few events to judge: fewer than two predictions per sphere (slow classes between exit-triggered
  // rebuilds) or than 64 in all.
  if (classCount_[c] == 0 || predictions < std::max(2.0 * static_cast<double>(classCount_[c]), 64.0)) return 0;
  double reverse = 0.0;
  for (std::size_t d = 0; d < classes; ++d) {
    if (classCount_[d] == 0) continue;
    const double perSphere = static_cast<double>(classTotal_[d].predictions - classAtRebuild_[d].predictions) /
                             static_cast<double>(classCount_[d]);
    reverse += static_cast<double>(classEntries_[d * classes + c]) * perSphere;
  }
  const double pairWork = 0.5 * (static_cast<double>(now.scans - then.scans) + reverse);
  const double exitWork = options_.exitWork * static_cast<double>(now.exits - then.exits);
  if (exitWork > 8.0 * pairWork) return 2;
  if (exitWork > 2.0 * pairWork) return 1;
  if (exitWork < 0.5 * pairWork) return -1;
  return 0;
}

bool HardSphereSystem::classesWantRebuild(bool shrinkToo) const {
  for (std::size_t c = 0; c < classFloor_.size(); ++c) {
    const int trend = classTrend(c);
    const double lowest = classFloorMin(c);
    if (trend > 0 && classFloor_[c] < std::max(1e3, lowest)) return true;
    if (shrinkToo && trend < 0 && classFloor_[c] > lowest) return true;
  }
  return false;
}

std::vector<SkinClass> HardSphereSystem::skinClasses() const {
  const std::size_t classes = classCount_.size();
  std::vector<SkinClass> out(classes);
  const double rmin = smallestRadius();
  for (std::size_t c = 0; c < classes; ++c) {
    out[c].count = classCount_[c];
    out[c].floor = classSkins() ? classFloor_[c] : skinFloor_;
    out[c].exits = classTotal_[c].exits;
    out[c].collisions = classTotal_[c].collisions;
    out[c].predictions = classTotal_[c].predictions;
    out[c].scans = classTotal_[c].scans;
  }
  for (const Hood& h : hood_) {
    SkinClass& k = out[static_cast<std::size_t>(h.cls)];
    k.meanSkin += h.skin / rmin;
    k.meanNeighbours += h.size;
  }
  for (SkinClass& k : out) {
    if (k.count == 0) continue;
    k.meanSkin /= k.count;
    k.meanNeighbours /= k.count;
  }
  return out;
}

double HardSphereSystem::exitRatioSinceRebuild() const {
  const std::int64_t collisions = total_.collisions - collisionsAtRebuild_;
  return collisions > 0 ? static_cast<double>(total_.exits - exitsAtRebuild_) / static_cast<double>(collisions) : 0.0;
}

double HardSphereSystem::meanNeighbours() const {
  double total = 0.0;
  for (const Hood& h : hood_) total += h.size;
  return count() ? total / count() : 0.0;
}

}  // namespace polydem::edmd
