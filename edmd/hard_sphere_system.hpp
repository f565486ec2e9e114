#pragma once
// Event-driven molecular dynamics (EDMD) of hard spheres with radii growing in proportion to their size,
// the engine of the Lubachevsky-Stillinger compression (A. Donev, "Jammed Packings of Hard Particles", PhD
// thesis, Princeton University (2006), ch. 3).
//
// Design (Donev 2006, §3.4, Algorithms 2-5):
// * Every particle lives at its own time: its state (x, v, t_i, radius at the last synchronisation) is
//   advanced only when it takes part in an event (Donev 2006, §3.2.2). The global clock is reset to 0 at every
//   synchronisation (Donev 2006, Algorithm 3), which keeps |t| small near jamming.
// * One predicted event per particle in an indexed 4-ary heap (Donev 2006, §3.4.1): binary collision, check
//   after a partner's collision, plain check (prediction invalidated by a third party), exit from the
//   bounding neighbourhood, hard-wall collision. Predictions accept a collision with j only before both
//   i's best event and j's current event, t_c < min(t_e(i), t_e(j)) (Donev 2006, Algorithm 5, step 4); a claimed
//   particle's previous partner is lazily relabelled a check at its old time (Algorithm 5, step 5). The strict test is
//   what stops a just-collided pair from being re-predicted at zero delay by the first of the two.
// * Near-neighbour lists with bounding neighbourhoods (Donev 2006, §3.3.2): neighbourhood i is a sphere
//   of radius rho_i = O_i + skin_i centred where i was when it was built; i and j are neighbours when
//   their neighbourhoods overlap, and a collision with a non-neighbour is impossible while both stay
//   inside. Leaving the neighbourhood is an event; it re-centres the neighbourhood (on wide distributions
//   ahead of the sphere along its velocity, SystemOptions::exitLead) and refreshes the
//   list through the exit index, a second broad-phase backend over the neighbourhoods (SystemOptions::
//   exitIndex, by default hgrid-dynamic: a multi-level grid of cells stored as runs, O(1) moves), with update() for
//   the one moved neighbourhood and findNeighbours(), so the work per event does not depend on the size
//   ratio. The broad phase SystemOptions::broadPhase builds the first lists (build() + findPairs()); later
//   global rebuilds take findPairs() of the exit index (the HGrid's level optimiser made each build cost
//   as much as ~10^4-10^5 collisions on the widest distributions). Every complete backend gives the same
//   sorted lists (one pair predicate), so neither choice changes the trajectory.
//   rho_i is fixed between global rebuilds ("epochs") so that an exit moves one neighbourhood in the grid;
//   growth eats into the room rho_i - O_i(t), and when some particle has used half of it everything is
//   synchronised and rebuilt (O(N), rare: radii grow by ~skin/2 per epoch). The skin is
//   skin_i = (mu - 1) max(min(O_i, kappa O_min), f O_min (O_min / O_i)^(3/2)): proportional for small
//   spheres, capped for large ones, whose list would otherwise grow as (O_i / O_min)^3 instead of
//   (O_i / O_min)^2, and a floor f (adapted at rebuilds) that covers the flight of fast small spheres and
//   falls with their thermal speed ~ O^(-3/2). For size ratios >= 2 the floor is one per size class
//   (radii in [2^c, 2^(c+1)) O_min), each adapted by the work its class causes (SystemOptions::classSkins),
//   so that mid-size spheres flying far through the pores of large ones get skins that cover their flight.
// * The event loop is bound by loads (a 10^4-particle system exceeds L2): the likely next particle's
//   event, state and neighbourhood are prefetched one event ahead, and a collision partner's data
//   before the collision arithmetic (process()).
// * Growth: O_i(t) = O_i(0) (1 + g t) with one relative rate g (1/s), so dO_i/dt is proportional to O_i
//   and the size distribution keeps its shape (V. Ogarko, PhD thesis, University of Twente, eq. 3.22).
// * Collisions: kinematics.hpp (robust quadratic, elastic rule with the growth term).
// * Pressure: collisional virial over a window, p = PV/(N k_B T) = 1 + sum(|r_ij| J) / (2 int K dt)
//   (Donev 2006, §3.2.4; equal to Ogarko's thesis form Z = 1 + sum |dp| l / (2 E dt), eq. 3.33). Wall collisions add
//   O_i J (the distance from the centre to the contact point), which makes p the pressure on the walls.
// * Masses proportional to O^3 (uniform density), scaled so the mean mass is 1.
//
// Units: any consistent set; lengths as given, time in length / speed.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "broadphase/broad_phase.hpp"
#include "core/box.hpp"
#include "core/huge_pages.hpp"
#include "core/types.hpp"
#include "edmd/event_queue.hpp"

namespace polydem::edmd {

struct SystemOptions {
  /// Broad phase that builds the first neighbour lists (registry name). The engine calls only its build()
  /// and findPairs() (and, for the overlap check of the input, on the spheres themselves).
  std::string broadPhase = "hgrid-td";
  /// Broad phase over the neighbourhoods that answers exits (update() with the one re-centred
  /// neighbourhood, then findNeighbours()) and the later global rebuilds (build() + findPairs()). Any
  /// complete backend gives the same lists; one whose update() is O(|moved|) keeps an exit O(1):
  /// hgrid-dynamic (broadphase/hgrid_dynamic.hpp). Every registered backend is complete; an unknown name is a
  /// ConfigError.
  std::string exitIndex = "hgrid-dynamic";
  /// mu: neighbourhood radius rho_i = O_i + (mu - 1) min(O_i, kappa O_min) at each global rebuild.
  double neighbourhoodScale = 1.4;
  /// kappa: cap of the skin in units of the smallest radius (wide size distributions).
  double skinCap = 4.0;
  /// Floor of the skin in units of the smallest radius: skin_i = (mu - 1) max(min(O_i, cap O_min),
  /// f O_min (O_min / O_i)^(3/2)), f = skinFloor initially. The floor covers the flight of fast small
  /// spheres; their thermal speed, and with it the room they need, falls as m^(-1/2) ~ O^(-3/2), so large
  /// spheres keep the capped skin and their lists do not grow with f. Equal to the earlier rule
  /// (mu - 1) clamp(O_i, f O_min, max(f, cap) O_min) (removed, docs/edmd.md) for monodisperse systems and,
  /// with skinCap >= 1, whenever f = 1.
  double skinFloor = 1.0;
  /// Adapt f at global rebuilds from the fraction of events that are neighbourhood exits (Donev
  /// 2006, §3.6.1, automatic tuning of mu_cutoff): x1.3 when exits cost too much, /1.15 when they are cheap (never
  /// below skinFloor). Small, fast spheres of wide size distributions then get skins of a few smallest radii.
  bool adaptiveSkin = true;
  /// How "too much" is judged, for size ratios >= 2: balance the work, W = exitWork x exits / (pair
  /// predictions), grow above 2, shrink below 0.5; an exit (grid query, list merge, prediction) costs as
  /// much as some tens of pair predictions, and a skin that minimises exit work ~ 1/f plus list work ~ f^3
  /// spends about as much on both. Narrower distributions grow above 0.8 exits per collision and shrink
  /// below 0.2 (both rules leave their skins at the floor there).
  /// Cost of one exit in pair predictions. Scanned at phi 0.5 (benchmarks/edmd_bench.cpp,
  /// docs/edmd-results.md): uniform volume omega = 50 is flat within noise over 30-100 and slower at 10 and
  /// 300; omega = 10 is 1.5x slower at 30 than at 60-100.
  double exitWork = 100.0;
  /// Size ratios >= 2: one skin floor per size class (class c: radii in [2^c, 2^(c+1)) O_min), each
  /// balanced by its own work (issue 24): skin_i = (mu - 1) max(min(O_i, kappa O_min),
  /// f_c O_min (2^c O_min / O_i)^(3/2)). The exits of class c, x exitWork, are weighed against the pair
  /// predictions that involve class c (half of each scanned list entry to each side: the scans made by
  /// class-c spheres and the class-c entries scanned by every other class). Sphere sizes that fly far
  /// between collisions (mid-size and small spheres in the pores of large ones) then get skins that cover
  /// their flight, while the large spheres keep capped skins. f_c never falls below
  /// max(skinFloor 2^(-3c/2), min(2^c, kappa)) and starts there, where every skin is the single-floor
  /// rule's; growth steps are x1.3 (x2 when exits cost 8x the pair work), shrinking /1.15. false: one
  /// floor f for all classes (f_c = f 2^(-3c/2)), balanced by the total work (the rule before issue 24,
  /// kept for before/after comparisons). Size ratios < 2 have one class and are unaffected either way.
  bool classSkins = true;
  /// Floor of the surface separation speed after a collision (m/s), against zero-delay re-collisions of
  /// grazing pairs whose approach speed is below round-off. Far below any physical speed.
  double minSeparationSpeed = 1e-10;
  /// Relative overlap (s - |r|) / s found at a collision above which the run stops with SimulationError.
  double overlapLimit = 1e-6;
  /// Watchdog: within one run() a particle may take part in at most
  /// watchdogFactor x (mean collisions per particle requested) + watchdogSlack collisions.
  double watchdogFactor = 1000.0;
  std::int64_t watchdogSlack = 100000;
  /// Renumber the particles internally along a Morton curve at every global rebuild and, at a
  /// synchronisation, once this many collisions per particle have passed since the last renumbering
  /// (0 = only at rebuilds). Neighbours then sit close in memory: the prediction loop is bound by loads
  /// of the neighbours' states. Invisible to callers (every accessor uses the caller's order).
  double resortInterval = 50.0;
  /// Largest lead of a re-centred neighbourhood: at an exit, the new neighbourhood is centred ahead of the
  /// sphere along its velocity, by a fraction (the lead) of its room rho_i - O_i (0: on the sphere, as in
  /// Donev 2006). A sphere flying straight then crosses (1 + lead) x room before its next exit instead of
  /// 1 x room; one that turns back exits after (1 - lead) x room. The lead of each size class follows from
  /// its bounces per exit (HardSphereSystem::exitLead): near this cap for spheres that fly farther than
  /// their room between collisions, 0 for caged ones. In [0, 0.9]; 0 turns leads off.
  double exitLead = 0.9;
};

enum class EventKind : std::uint8_t {
  None,          ///< nothing predicted (time +inf)
  Collision,     ///< binary collision with `partner`
  PartnerCheck,  ///< the partner of a collision just processed: state already advanced, re-predict
  Check,         ///< prediction invalidated by a third party: re-predict at this time
  Exit,          ///< touches the inner surface of its bounding neighbourhood
  Wall           ///< hard-wall collision, partner = 2 axis + (upper ? 1 : 0)
};

struct Event {
  double time;
  Index partner;
  EventKind kind;
};

/// Event counts (cumulative since construction, or of one run() call).
struct EventCounts {
  std::int64_t collisions = 0;  ///< binary collisions processed
  std::int64_t wallCollisions = 0;
  std::int64_t checks = 0;          ///< partner checks and invalidated predictions
  std::int64_t exits = 0;           ///< neighbourhood exits (partial list rebuilds)
  std::int64_t rebuilds = 0;        ///< global neighbourhood rebuilds
  std::int64_t relocatedLists = 0;  ///< neighbour lists moved to a larger slot (out of room)
  std::int64_t missed = 0;          ///< predicted collisions found separating when processed (grazing)
  std::int64_t events() const { return collisions + wallCollisions + checks + exits; }
  /// Counts between two snapshots (later - earlier).
  friend EventCounts operator-(const EventCounts& a, const EventCounts& b) {
    return {a.collisions - b.collisions, a.wallCollisions - b.wallCollisions, a.checks - b.checks, a.exits - b.exits,
            a.rebuilds - b.rebuilds,     a.relocatedLists - b.relocatedLists, a.missed - b.missed};
  }
};

/// Event and list statistics of one size class of the skin rule (SystemOptions::classSkins): the spheres
/// with radii in [2^c, 2^(c+1)) O_min. Counters are cumulative since construction.
struct SkinClass {
  Index count = 0;        ///< spheres in the class
  double floor = 0.0;     ///< f_c
  double meanSkin = 0.0;  ///< mean room rho_i - O_i at the last global rebuild, in units of O_min
  double meanNeighbours = 0.0;
  std::int64_t exits = 0;        ///< neighbourhood exits of class members
  std::int64_t collisions = 0;   ///< binary collisions a class member took part in (a pair counts twice)
  std::int64_t predictions = 0;  ///< predictions made by class members
  std::int64_t scans = 0;        ///< list entries scanned by those predictions (pair predictions)
};

/// One processed binary collision, in the caller's particle numbering (i < j).
struct CollisionRecord {
  Index i = -1, j = -1;
  double time = 0.0;  ///< HardSphereSystem::time() of the collision (s)
};

/// Accumulators of the collisional virial since resetPressureWindow().
struct PressureWindow {
  double virial = 0.0;           ///< sum over collisions of |r_ij| J (J m)
  double kineticIntegral = 0.0;  ///< integral of the total kinetic energy over time (J s)
  double duration = 0.0;         ///< s
  std::int64_t collisions = 0;
  /// p = PV / (N k_B T) = 1 + virial / (2 int K dt); NaN for an empty window.
  double reducedPressure() const;
};

/// The complete state of a synchronised system (clock at 0), in the engine's internal numbering: what
/// restoreState() needs to continue exactly as the saved system would have (checkpoint and resume, bit
/// for bit). The event schedule is not part of it: at a synchronisation it is reset to "every particle
/// checks now", a function of N alone. The neighbourhoods and lists are, because exits between global
/// rebuilds (advances, re-centring) shape the arithmetic of the trajectory.
struct SystemState {
  std::vector<double> position, velocity;  ///< 3N, internal order, (x, y, z) per particle
  std::vector<double> radius, mass;        ///< N: radius at clock 0, mass
  std::vector<std::int64_t> external;      ///< N: internal slot -> caller's index
  std::vector<double> hoodCentre;          ///< 3N
  std::vector<double> hoodRadius, hoodSkin;
  std::vector<std::int64_t> hoodBegin, hoodSize, hoodCapacity;
  std::vector<std::int64_t> neighbours;  ///< the flat list storage, spare slots included
  std::vector<double> classSkinFloor;    ///< f_c per size class (SystemOptions::classSkins)
  /// 8 per size class: exits, collisions, predictions, scans (cumulative) of class 0, 1, ..., then the
  /// same four as they stood at the last global rebuild, class by class. Empty in states saved before
  /// size classes existed (the floors then restart from their minimum).
  std::vector<std::int64_t> classCounters;
  double growth = 0.0, elapsed = 0.0, skinFloor = 1.0, sizeRatio = 1.0, kinetic = 0.0, maxOverlap = 0.0;
  PressureWindow window;
  EventCounts total;
  std::int64_t collisionsAtSort = 0, collisionsAtRebuild = 0, exitsAtRebuild = 0, pairsAtRebuild = 0, pairWork = 0;
  CollisionRecord lastCollision;
};

class HardSphereSystem {
 public:
  /// Hard spheres at the given centres (3 x N, inside the box), radii (N, > 0) and velocities (3 x N).
  /// Throws ConfigError for inconsistent sizes, bad radii, centres outside the box or through a wall,
  /// overlapping pairs (beyond 1e-12 relative) and boxes too small for the neighbourhoods.
  HardSphereSystem(const Box& box, const Eigen::Matrix3Xd& position, const Eigen::VectorXd& radius,
                   const Eigen::Matrix3Xd& velocity, SystemOptions options = {});
  ~HardSphereSystem();
  HardSphereSystem(const HardSphereSystem&) = delete;
  HardSphereSystem& operator=(const HardSphereSystem&) = delete;

  Index count() const { return static_cast<Index>(state_.size()); }
  const Box& box() const { return box_; }
  const SystemOptions& options() const { return options_; }

  /// Relative growth rate g (1/s): dO_i/dt = g O_i(last synchronisation). Synchronises first.
  void setGrowthRate(double relativeRate);
  double growthRate() const { return growth_; }

  /// Process events until `collisions` more binary collisions have happened or the clock has advanced by
  /// `duration` (s), whichever comes first; the clock then stands at the last event or at the time limit.
  /// Returns the counts of this call. Throws SimulationError from the watchdog (an unbounded collision
  /// sequence: names the particle) or on an overlap beyond options().overlapLimit (names the pair).
  EventCounts run(std::int64_t collisions, double duration = kInfinity);
  /// Process the next event; false if nothing is scheduled. For tests and fine control.
  bool step();
  /// The next event of the schedule (time relative to the current clock origin).
  Event nextEvent() const;

  /// Advance every particle to the current time, fold the elapsed time into the radii, reset the clock
  /// to 0 and re-predict every event (Donev 2006, thesis, Algorithms 3-4). O(N x neighbours).
  void synchronise();
  /// Multiply all velocities by `factor` (synchronises; the thermostat).
  void scaleVelocities(double factor);
  /// Rescale velocities so that sqrt(sum m v^2 / sum m) = speed ("thermal speed"). Synchronises.
  void setThermalSpeed(double speed);
  /// Set all velocities (3 x N). Synchronises.
  void setVelocities(const Eigen::Matrix3Xd& velocity);

  /// Time since construction (s).
  double time() const { return elapsed_ + clock_; }
  /// Centres at the current time, wrapped into the box (3 x N).
  Eigen::Matrix3Xd positions() const;
  Eigen::Matrix3Xd velocities() const;
  /// Radii at the current time (N).
  Eigen::VectorXd radii() const;
  /// Masses (N), proportional to r^3 with mean 1.
  Eigen::VectorXd masses() const;
  /// Total kinetic energy (tracked exactly through every collision).
  double kineticEnergy() const { return kinetic_; }
  /// sqrt(sum m v^2 / sum m).
  double thermalSpeed() const;
  Eigen::Vector3d momentum() const;
  /// Sphere volume / box volume at the current time.
  double packingFraction() const;
  double largestRadius() const;
  double smallestRadius() const;

  /// Virial accumulators since the last reset (the pending part up to the current time included).
  PressureWindow pressureWindow() const;
  void resetPressureWindow();

  const EventCounts& counts() const { return total_; }
  /// The last binary collision processed (i = j = -1 before the first); with step(), the collision
  /// sequence of a run (tests compare it against a brute-force reference).
  const CollisionRecord& lastCollision() const { return lastCollision_; }
  /// Largest relative overlap (s - |r|) / s met at any collision so far (0 if none).
  double maxOverlapSeen() const { return maxOverlap_; }
  /// Description of the broad phase used for the neighbourhoods.
  std::string describeBroadPhase() const;
  /// Mean neighbour-list length.
  double meanNeighbours() const;
  /// Current skin floor f (see SystemOptions::skinFloor); with class skins, that of the smallest class.
  double skinFloor() const { return classSkins() ? classFloor_[0] : skinFloor_; }
  /// Pair predictions made (list entries scanned), cumulative.
  std::int64_t pairPredictions() const { return pairWork_; }
  /// Per size class of the skin rule (one class for size ratios < 2). O(classes).
  std::vector<SkinClass> skinClasses() const;

  /// The state at a synchronisation (synchronises first). O(N x neighbours) copies; never called per event.
  SystemState saveState();
  /// Continue from `state` (saved from a system of the same count, box and options): afterwards this system
  /// evolves bit for bit as the saved one did after saveState(). Throws InputError for inconsistent sizes or
  /// a numbering that is not a permutation.
  void restoreState(const SystemState& state);

  /// Check every invariant (tests; O(N^2) for N <= 2000, else O(N x neighbours)): particles inside their
  /// neighbourhoods, lists complete and symmetric, schedule symmetric, heap consistent, event times not
  /// in the past, no overlap beyond `overlapTolerance` (relative). Throws std::logic_error.
  void validate(double overlapTolerance = 1e-10) const;

  static constexpr double kInfinity = std::numeric_limits<double>::infinity();

 private:
  struct alignas(64) State {
    double x[3];  // position at local time t (not wrapped until the particle is advanced)
    double t;     // local time
    double v[3];
    double r0;  // radius at clock 0
  };

  void sortSpatially();
  Index external(Index i) const { return external_[static_cast<std::size_t>(i)]; }
  void checkInput(const Eigen::Matrix3Xd& position, const Eigen::VectorXd& radius,
                  const Eigen::Matrix3Xd& velocity) const;
  void advance(Index i);
  /// Coordinate x on axis k, at most one box length outside [0, L), into [0, L) on a periodic axis (x - L is
  /// exact for x in [L, 2L)); walled axes are left alone.
  void wrapIntoBox(double& x, int k) const {
    if (!periodic_[k]) return;
    if (x >= length_[k]) {
      x -= length_[k];
    } else if (x < 0.0) {
      x += length_[k];
      if (x >= length_[k]) x = 0.0;
    }
  }
  /// Centre i's neighbourhood for an exit: ahead of the sphere along its velocity by exitLead(class of i).
  void placeCentre(Index i);
  /// Lead of the re-centred neighbourhoods of class c, in [0, SystemOptions::exitLead].
  double exitLead(std::size_t c) const;
  void advanceAll();
  void resetSchedule();
  void rebuildNeighbourhoods();
  void refreshNeighbourhood(Index i);
  void predict(Index i);
  void collide(Index i, Index j);
  void collideWithWall(Index i, int wall);
  void process(Index i);
  void flushKinetic();
  [[noreturn]] void watchdogTrip(Index i) const;
  double radiusAt(const State& s) const { return s.r0 + (growth_ * s.r0) * clock_; }
  double wrapped(double d, int axis) const;  // one axis of the minimum image, branch-free
  static bool keepEarlier(double tau, double tc, double horizon, double& best);
  void minimumImage(double d[3]) const {
    for (int k = 0; k < 3; ++k) {
      if (!periodic_[k]) continue;
      if (d[k] > half_[k]) {
        d[k] -= length_[k];
      } else if (d[k] < -half_[k]) {
        d[k] += length_[k];
      }
    }
  }

  Box box_;
  SystemOptions options_;
  std::array<bool, 3> periodic_{};
  std::array<double, 3> length_{}, half_{};
  std::array<double, 3> wrap_{};  // length on periodic axes, 0 on walled ones
  bool hasWalls_ = false;

  LargeVector<State> state_;     // the hot arrays on huge pages where the kernel has them (core/huge_pages.hpp)
  std::vector<Index> external_;  // internal slot -> caller's index
  std::int64_t collisionsAtSort_ = 0;
  double skinFloor_ = 1.0;  // current f
  double sizeRatio_ = 1.0;  // largest / smallest radius (constant: all radii grow in proportion)
  std::int64_t collisionsAtRebuild_ = 0, exitsAtRebuild_ = 0, pairsAtRebuild_ = 0;
  std::int64_t pairWork_ = 0;  // pair predictions made (neighbour-list entries scanned), cumulative
  double exitRatioSinceRebuild() const;
  /// +1: the skins are too thin (exits cost too much), -1: too thick, 0: keep (SystemOptions::adaptiveSkin).
  int skinTrend() const;
  // Size classes of the skin rule (SystemOptions::classSkins). The class of a sphere is a function of its
  // mass (fixed for ever, saved with the state), so it survives renumbering and restores.
  struct ClassCounters {
    std::int64_t exits = 0, collisions = 0, predictions = 0, scans = 0;
  };
  bool classSkins() const { return options_.classSkins && classCount_.size() > 1; }
  void assignClasses();
  void countClassEntries();  // classEntries_ from the current lists
  /// Per class: +2 far too thin, +1 too thin, -1 too thick, 0 keep (too few events to judge: 0).
  int classTrend(std::size_t c) const;
  bool classesWantRebuild(bool shrinkToo) const;
  double classFloorMin(std::size_t c) const;
  std::vector<Index> classCount_;          // spheres per class
  std::vector<double> classFloor_;         // f_c
  std::vector<ClassCounters> classTotal_;  // cumulative
  std::vector<ClassCounters> classAtRebuild_;
  std::vector<std::int64_t> classEntries_;  // C x C: entries of class d in the lists of class c, [c * C + d]
  double periodicLength() const;            // shortest periodic edge (inf if none)
  Eigen::VectorXd mass_, inverseMass_;
  LargeVector<Event> event_;
  EventQueue queue_;
  double growth_ = 0.0;
  double clock_ = 0.0;    // time since the last synchronisation
  double elapsed_ = 0.0;  // time folded in at synchronisations

  // Bounding neighbourhoods and near-neighbour lists. The lists live in one flat array, each with some
  // spare room (a full list moves to a larger slot at the end; the array is compacted at the next global
  // rebuild), so that the prediction loop reads the list of i from adjacent memory instead of chasing
  // per-particle allocations.
  struct alignas(64) Hood {
    double centre[3];
    double radius;  // rho
    double skin;    // room rho - O at the last global rebuild
    Index begin, size, capacity;
    Index cls;  // size class of the skin rule (0 for size ratios < 2)
  };
  void prefetchList(Index i) const {  // the first two cache lines of i's list
    const Index* first = nbData_.data() + hood_[static_cast<std::size_t>(i)].begin;
    __builtin_prefetch(first);
    __builtin_prefetch(first + 16);
  }
  /// How many neighbours ahead predict() requests states and events: 16 (most lists of equal spheres at once)
  /// once the states outgrow 1 MiB (N > 16,384), else 4. Interleaved runs (docs/benchmarks/edmd/peer/README.md,
  /// session 33), 16 against 4: 1.05x at N = 32,000, 1.12x at 10^5; at 10^4, where the states stay in cache,
  /// 0.97x.
  std::size_t prefetchAhead_ = 4;
  std::span<const Index> neighboursOf(Index i) const {
    const Hood& h = hood_[static_cast<std::size_t>(i)];
    return {nbData_.data() + h.begin, static_cast<std::size_t>(h.size)};
  }
  void insertNeighbour(Index i, Index j);
  void relocateList(Index i, Index capacity);
  void eraseNeighbour(Index i, Index j);
  LargeVector<Hood> hood_;
  LargeVector<Index> nbData_;
  Eigen::Matrix3Xd nbCentre_;  // copies of hood_ centre and radius for the broad phase
  Eigen::VectorXd nbRadius_;
  std::vector<Index> added_, removed_;
  std::unique_ptr<broadphase::BroadPhase> broad_;
  std::unique_ptr<broadphase::BroadPhase> exits_;  // SystemOptions::exitIndex over the neighbourhoods
  std::vector<Index> scratch_;
  std::vector<broadphase::Pair> pairScratch_;
  bool rebuildPending_ = false;

  // Kinetic energy and virial.
  double kinetic_ = 0.0;
  double kineticMark_ = 0.0;  // clock value up to which kinetic_ has been integrated
  PressureWindow window_;
  double maxOverlap_ = 0.0;

  EventCounts total_;
  CollisionRecord lastCollision_;
  // Watchdog.
  std::vector<std::int64_t> collisionsInRun_;
  std::int64_t watchdogLimit_ = std::numeric_limits<std::int64_t>::max();
  std::int64_t sameTimeEvents_ = 0;
  double lastEventTime_ = -1.0;
  std::array<std::array<Index, 2>, 8> recent_{};
  std::size_t recentNext_ = 0;
};

}  // namespace polydem::edmd
