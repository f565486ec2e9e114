// HardSphereSystem, part: the state of a synchronised system for checkpoints (saveState, restoreState)
// and the invariant checker validate() used by tests.
#include <fmt/format.h>

#include <algorithm>
#include <stdexcept>

#include "core/errors.hpp"
#include "edmd/hard_sphere_system.hpp"

namespace polydem::edmd {

// ---------------------------------------------------------------------------------------------------
// Checkpoint state

SystemState HardSphereSystem::saveState() {
  synchronise();
  const Index n = count();
  const std::size_t un = static_cast<std::size_t>(n);
  SystemState out;
  out.position.resize(3 * un);
  out.velocity.resize(3 * un);
  out.radius.resize(un);
  out.mass.resize(un);
  out.external.resize(un);
  out.hoodCentre.resize(3 * un);
  out.hoodRadius.resize(un);
  out.hoodSkin.resize(un);
  out.hoodBegin.resize(un);
  out.hoodSize.resize(un);
  out.hoodCapacity.resize(un);
  for (std::size_t i = 0; i < un; ++i) {
    const State& s = state_[i];
    const Hood& h = hood_[i];
    for (std::size_t k = 0; k < 3; ++k) {
      out.position[3 * i + k] = s.x[k];
      out.velocity[3 * i + k] = s.v[k];
      out.hoodCentre[3 * i + k] = h.centre[k];
    }
    out.radius[i] = s.r0;
    out.mass[i] = mass_[static_cast<Index>(i)];
    out.external[i] = external_[i];
    out.hoodRadius[i] = h.radius;
    out.hoodSkin[i] = h.skin;
    out.hoodBegin[i] = h.begin;
    out.hoodSize[i] = h.size;
    out.hoodCapacity[i] = h.capacity;
  }
  out.neighbours.assign(nbData_.begin(), nbData_.end());
  out.classSkinFloor = classFloor_;
  out.classCounters.clear();
  for (const std::vector<ClassCounters>* counters : {&classTotal_, &classAtRebuild_}) {
    for (const ClassCounters& k : *counters) {
      out.classCounters.insert(out.classCounters.end(), {k.exits, k.collisions, k.predictions, k.scans});
    }
  }
  out.growth = growth_;
  out.elapsed = elapsed_;
  out.skinFloor = skinFloor_;
  out.sizeRatio = sizeRatio_;
  out.kinetic = kinetic_;
  out.maxOverlap = maxOverlap_;
  out.window = window_;
  out.total = total_;
  out.collisionsAtSort = collisionsAtSort_;
  out.collisionsAtRebuild = collisionsAtRebuild_;
  out.exitsAtRebuild = exitsAtRebuild_;
  out.pairsAtRebuild = pairsAtRebuild_;
  out.pairWork = pairWork_;
  out.lastCollision = lastCollision_;
  return out;
}

void HardSphereSystem::restoreState(const SystemState& state) {
  const Index n = count();
  const std::size_t un = static_cast<std::size_t>(n);
  auto require = [&](bool ok, const char* what) {
    if (!ok) throw InputError(fmt::format("engine state for {} particles: {}", n, what));
  };
  require(state.position.size() == 3 * un && state.velocity.size() == 3 * un && state.hoodCentre.size() == 3 * un,
          "positions, velocities or neighbourhood centres of the wrong length");
  require(state.radius.size() == un && state.mass.size() == un && state.external.size() == un &&
              state.hoodRadius.size() == un && state.hoodSkin.size() == un && state.hoodBegin.size() == un &&
              state.hoodSize.size() == un && state.hoodCapacity.size() == un,
          "per-particle arrays of the wrong length");
  std::vector<char> seen(un, 0);
  for (std::int64_t e : state.external) {
    require(e >= 0 && e < n && !seen[static_cast<std::size_t>(e)], "the particle numbering is not a permutation");
    seen[static_cast<std::size_t>(e)] = 1;
  }
  const std::int64_t slots = static_cast<std::int64_t>(state.neighbours.size());
  for (std::size_t i = 0; i < un; ++i) {
    require(state.hoodBegin[i] >= 0 && state.hoodSize[i] >= 0 && state.hoodSize[i] <= state.hoodCapacity[i] &&
                state.hoodBegin[i] + state.hoodCapacity[i] <= slots,
            "a neighbour list outside its storage");
    for (std::int64_t k = 0; k < state.hoodSize[i]; ++k) {
      const std::int64_t j = state.neighbours[static_cast<std::size_t>(state.hoodBegin[i] + k)];
      require(j >= 0 && j < n, "a neighbour index out of range");
    }
  }
  // Size classes: a state saved before they existed has neither array (its class floors start afresh).
  const bool hasClasses = !state.classSkinFloor.empty() || !state.classCounters.empty();
  require(!hasClasses || state.classCounters.size() == 8 * state.classSkinFloor.size(),
          "size-class skin floors and counters disagree in length");
  for (std::size_t i = 0; i < un; ++i) {
    State& s = state_[i];
    Hood& h = hood_[i];
    for (std::size_t k = 0; k < 3; ++k) {
      s.x[k] = state.position[3 * i + k];
      s.v[k] = state.velocity[3 * i + k];
      h.centre[k] = state.hoodCentre[3 * i + k];
    }
    s.t = 0.0;
    s.r0 = state.radius[i];
    mass_[static_cast<Index>(i)] = state.mass[i];
    inverseMass_[static_cast<Index>(i)] = 1.0 / state.mass[i];
    external_[i] = static_cast<Index>(state.external[i]);
    h.radius = state.hoodRadius[i];
    h.skin = state.hoodSkin[i];
    h.begin = static_cast<Index>(state.hoodBegin[i]);
    h.size = static_cast<Index>(state.hoodSize[i]);
    h.capacity = static_cast<Index>(state.hoodCapacity[i]);
    nbRadius_[static_cast<Index>(i)] = h.radius;
    nbCentre_.col(static_cast<Index>(i)) = Eigen::Vector3d(h.centre[0], h.centre[1], h.centre[2]);
  }
  nbData_.assign(state.neighbours.begin(), state.neighbours.end());
  sizeRatio_ = state.sizeRatio;
  assignClasses();  // from the restored masses, as the saved system had them
  if (hasClasses) {
    const std::size_t classes = classCount_.size();
    require(state.classSkinFloor.size() == classes,
            "a different number of size classes (the masses do not match the saved system's)");
    classFloor_ = state.classSkinFloor;
    for (std::size_t c = 0; c < classes; ++c) {
      const std::int64_t* a = state.classCounters.data() + 4 * c;
      const std::int64_t* b = state.classCounters.data() + 4 * (classes + c);
      classTotal_[c] = ClassCounters{a[0], a[1], a[2], a[3]};
      classAtRebuild_[c] = ClassCounters{b[0], b[1], b[2], b[3]};
    }
  }
  countClassEntries();
  growth_ = state.growth;
  elapsed_ = state.elapsed;
  clock_ = 0.0;
  kineticMark_ = 0.0;
  skinFloor_ = state.skinFloor;
  sizeRatio_ = state.sizeRatio;
  kinetic_ = state.kinetic;
  maxOverlap_ = state.maxOverlap;
  window_ = state.window;
  total_ = state.total;
  collisionsAtSort_ = state.collisionsAtSort;
  collisionsAtRebuild_ = state.collisionsAtRebuild;
  exitsAtRebuild_ = state.exitsAtRebuild;
  pairsAtRebuild_ = state.pairsAtRebuild;
  pairWork_ = state.pairWork;
  lastCollision_ = state.lastCollision;
  std::fill(collisionsInRun_.begin(), collisionsInRun_.end(), 0);
  recent_ = {};
  recentNext_ = 0;
  // The exit index answers "which neighbourhoods overlap this one" (a sorted set, a function of the
  // centres and radii alone), so building it afresh gives the same answers as the incrementally moved one.
  // The broad phase is rebuilt too, so that describeBroadPhase() reports the restored neighbourhoods.
  if (n > 0) {
    const SphereView view{nbCentre_, nbRadius_};
    broad_->build(view, box_, 0.0);
    exits_->build(view, box_, 0.0);
  }
  resetSchedule();
}

// ---------------------------------------------------------------------------------------------------
// Invariants

void HardSphereSystem::validate(double overlapTolerance) const {
  const Index n = count();
  auto fail = [](const std::string& what) { throw std::logic_error("hard-sphere system: " + what); };
  queue_.validate();
  Eigen::Matrix3Xd x(3, n);
  for (Index i = 0; i < n; ++i) {
    const State& s = state_[static_cast<std::size_t>(i)];
    const double dt = clock_ - s.t;
    if (dt < 0.0) fail(fmt::format("particle {} lives in the future (t_i = {}, clock {})", i, s.t, clock_));
    x.col(i) = Eigen::Vector3d(s.x[0] + s.v[0] * dt, s.x[1] + s.v[1] * dt, s.x[2] + s.v[2] * dt);
    const Event& e = event_[static_cast<std::size_t>(i)];
    if (queue_.key(i) != e.time) fail(fmt::format("heap key of particle {} differs from its event time", i));
    if (e.time < clock_) fail(fmt::format("event of particle {} at {} lies before the clock {}", i, e.time, clock_));
    if (e.kind == EventKind::Collision) {
      const Event& f = event_[static_cast<std::size_t>(e.partner)];
      if (f.kind != EventKind::Collision || f.partner != i || f.time != e.time) {
        fail(fmt::format("asymmetric schedule: {} collides with {} but not vice versa", i, e.partner));
      }
    }
    // Inside the neighbourhood.
    const Hood& hood = hood_[static_cast<std::size_t>(i)];
    if (nbCentre_.col(i) != Eigen::Vector3d(hood.centre[0], hood.centre[1], hood.centre[2]) ||
        nbRadius_[i] != hood.radius) {
      fail(fmt::format("neighbourhood copies of particle {} disagree", i));
    }
    Eigen::Vector3d d = x.col(i) - nbCentre_.col(i);
    d = box_.minimumImageAny(d);
    const double r = radiusAt(s);
    if (d.norm() + r > nbRadius_[i] * (1.0 + 1e-9)) {
      fail(fmt::format("particle {} left its neighbourhood: |d| + r = {} > {}", i, d.norm() + r, nbRadius_[i]));
    }
    const auto list = neighboursOf(i);
    if (!std::is_sorted(list.begin(), list.end())) fail(fmt::format("neighbour list of {} not sorted", i));
    for (Index j : list) {
      const auto back = neighboursOf(j);
      if (!std::binary_search(back.begin(), back.end(), i)) fail(fmt::format("list of {} lacks {}", j, i));
    }
  }
  // Completeness of the lists and overlaps: every pair whose neighbourhoods overlap must be listed.
  auto checkPair = [&](Index i, Index j) {
    const Eigen::Vector3d dc = box_.minimumImageAny(nbCentre_.col(i) - nbCentre_.col(j));
    if (dc.norm() <= nbRadius_[i] + nbRadius_[j]) {
      const auto list = neighboursOf(i);
      if (!std::binary_search(list.begin(), list.end(), j)) {
        fail(fmt::format("neighbourhoods of {} and {} overlap but they are not neighbours", i, j));
      }
    }
    const Eigen::Vector3d dx = box_.minimumImageAny(x.col(i) - x.col(j));
    const double s = radiusAt(state_[static_cast<std::size_t>(i)]) + radiusAt(state_[static_cast<std::size_t>(j)]);
    if (s - dx.norm() > overlapTolerance * s) {
      fail(fmt::format("particles {} and {} overlap by {:.3g} relative", i, j, (s - dx.norm()) / s));
    }
  };
  // The class entry counts of the skin rule follow the lists.
  if (classSkins()) {
    const std::size_t classes = classCount_.size();
    std::vector<std::int64_t> entries(classes * classes, 0);
    for (Index i = 0; i < n; ++i) {
      const std::size_t row = static_cast<std::size_t>(hood_[static_cast<std::size_t>(i)].cls) * classes;
      for (Index j : neighboursOf(i)) ++entries[row + static_cast<std::size_t>(hood_[static_cast<std::size_t>(j)].cls)];
    }
    if (entries != classEntries_) fail("size-class list entry counts disagree with the lists");
  }
  if (n <= 2000) {
    for (Index i = 0; i < n; ++i)
      for (Index j = i + 1; j < n; ++j) checkPair(i, j);
  } else {
    for (Index i = 0; i < n; ++i)
      for (Index j : neighboursOf(i))
        if (j > i) checkPair(i, j);
  }
}

}  // namespace polydem::edmd
