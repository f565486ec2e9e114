#pragma once
// A DEM run (integrators::DemSimulation's time loop) split over MPI ranks by regions of the box (a brick grid, or
// recursive coordinate bisection by cost, rebalanced at neighbour-list builds: parallel/decomposition.hpp), with a
// final state that is byte-identical to the serial run for any rank count (docs/parallel.md).
//
// Why it is identical. The serial force loop sums the force on particle k in slot order: its body force, then
// -F_ik from every listed pair (i, k) with i < k in ascending i, then its own row's sum over j > k in
// ascending j, then its walls (contact/force_loop.hpp). Slots are fixed after the one spatial sort at the
// start, so the serial slot is a global key. Each rank keeps its owned particles and their ghosts in
// ascending key and runs the *same compiled kernel* over a list of every pair that has an owned particle:
// row i of the local list holds exactly the serial row's pairs (i, j) that involve an owned particle, in the
// same order, so every owned particle's force is the same sum of the same terms in the same order. A pair
// across two ranks is computed by both, from bit-identical inputs (ghost positions and velocities are sent
// every step, unshifted: the kernel's minimum image sees the same differences as in the serial run), and so
// is its tangential spring. The half kicks are element-wise, the rebuild decision is an exact maximum over
// ranks (MPI_MAX), and contact histories are keyed by id pairs.
//
// Ghosts are sized by particle: j (owned by another rank) is a ghost of rank q only if some particle i of q
// can be within the skin of it, |x_i - x_j| <= r_i + r_j + skin. Two necessary conditions are tested, both
// exact bounds: (1) the distance from x_j to q's region is at most r_j + r_max(q) + skin, r_max(q) the largest
// radius owned by q; (2) the reach field of q at x_j's cell is at least -r_j, where the field, on a grid of the box
// (up to 32^3, at least 4 cells across the largest ball), is R(c) = max over q's particles i of (r_i + skin - dist(x_i,
// cell c)) (a lower bound of |x_i - x_j| for every x_j in c). (2) is what keeps a small particle off a rank whose large
// particles are nowhere near it; (1) alone would copy a shell of the largest radius's thickness around every region. At
// each neighbour-list build (the same steps as the serial run: max displacement > skin/2) particles are wrapped,
// migrate to the rank whose brick holds them, carrying velocity, rotation and the contact springs of their pairs and
// walls, and ghosts are chosen again. The serial run's re-sorts (DemSettings::resort: at fixed steps, when the storage
// order has decayed) change the slots, so the keys: the decay is measured on the global key order (integer sums over
// the ranks) at the same steps, and a re-sort gives every particle its new serial slot as key, from the serial
// Morton order of all centres, before a build.
//
// The start and every output go through the serial state (integrators::DemState in slot order): every rank
// constructs from the same global state (so a serial checkpoint resumes on any rank count), and gather()
// assembles the global state on rank 0 (outputs, checkpoints, the stability messages), which is limited to
// what one process can hold and to 2^31 - 1 doubles per message. Collective errors (the stability check) are
// thrown on every rank as CollectiveError.
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "broadphase/broad_phase.hpp"
#include "contact/contact_history.hpp"
#include "contact/contact_law.hpp"
#include "contact/contact_list.hpp"
#include "contact/force_loop.hpp"
#include "core/errors.hpp"
#include "integrators/dem_simulation.hpp"
#include "parallel/decomposition.hpp"

namespace polydem::parallel {

/// A SimulationError that every rank throws at the same point (the stability check found a fault).
class CollectiveError : public SimulationError {
 public:
  using SimulationError::SimulationError;
};

/// Counts and times of one rank; see DistributedDem::stats().
struct RankStats {
  double owned = 0.0;              ///< particles owned
  double ghosts = 0.0;             ///< ghost copies held
  double pairs = 0.0;              ///< candidate pairs in the local list
  double ghostBytesPerStep = 0.0;  ///< bytes sent per step for ghost updates
  double migrated = 0.0;           ///< particles sent away at rebuilds, in total
  double cost = 0.0;               ///< owned particles + their candidate pairs (the bisection's weight)
  double coarseGhosts = 0.0;       ///< ghosts the distance rule (1) alone would send, at the last build
  double commSeconds = 0.0;        ///< in MPI calls (exchanges, reductions, gathers)
  double loopSeconds = 0.0;        ///< in advance(), all of it
  // advance()'s time by phase (wall-clock, MPI calls inside a phase included): together nearly all of loopSeconds.
  double integrationSeconds = 0.0;  ///< kicks and drift
  double reductionSeconds =
      0.0;                    ///< the step's reduction (largest displacement, interrupt): waits for the slowest rank
  double buildSeconds = 0.0;  ///< re-sorts and rebuilds (migration, ghosts, reach field, list)
  double ghostSeconds = 0.0;  ///< ghost updates between builds
  double forceSeconds = 0.0;  ///< the force kernel
  double checkSeconds = 0.0;  ///< stability checks
};

/// Every rank's RankStats (rank order), on rank 0.
struct ParallelStats {
  std::string decomposition;    ///< Decomposition::describe()
  std::int64_t rebalances = 0;  ///< bisections recomputed at builds
  std::int64_t resorts = 0;     ///< re-sorts by DemSettings::resort (as the serial run's) in this object's life
  std::vector<RankStats> ranks;
};

class DistributedDem {
 public:
  /// Collective. Every rank passes the same `global` state (DemSimulation::state()) and the settings of the
  /// run that made it; each keeps the particles whose build position lies in its brick, and their ghosts.
  /// With DecompositionKind::Bisection the regions are recomputed at a build when the largest cost (owned
  /// particles + their candidate pairs) exceeds the mean by more than `rebalanceThreshold` (relative).
  DistributedDem(const integrators::DemState& global, const integrators::DemSettings& settings,
                 DecompositionKind kind = DecompositionKind::Bisection, double rebalanceThreshold = 0.1);

  /// Collective: advance `steps` steps. With `stopOnInterrupt`, stops after the step at which some rank saw
  /// polydem::interruptRequested(). Returns the steps done. Throws CollectiveError from the stability check.
  std::int64_t advance(std::int64_t steps, bool stopOnInterrupt);
  /// Collective: DemSimulation::growRadii() (soft compression): every radius x factor >= 1, masses / factor^3,
  /// moments of inertia / factor^5, and a build when the growth since the last one exceeds skin / 2.
  void growRadii(double factor);
  /// Collective: DemSimulation::contactStats().maxOverlapRatio, the exact maximum over the ranks.
  double maxOverlapRatio();
  /// Some rank saw an interrupt (collective knowledge: the same on every rank).
  bool interrupted() const { return interrupted_; }
  std::int64_t step() const { return step_; }

  /// Collective: the global state in slot order on rank 0 (DemSimulation::restore() continues it); an empty
  /// state on the other ranks.
  integrators::DemState gather();
  /// Collective: every rank's counts and times, on rank 0.
  ParallelStats stats();
  const Decomposition& decomposition() const { return grid_; }

 private:
  // The minimiser on ranks uses the particles, ghosts, migration and candidate list of a DistributedDem.
  friend class DistributedFire;
  void selectKernel();
  void buildList(const Eigen::Matrix3Xd& centres, const Eigen::VectorXd& radii);
  void remapHistories(std::vector<double>& pool, std::vector<double>& wallPool);
  /// The distance rule (1) for particle (x, r) and rank q.
  bool coarseGhost(const double* x, double r, int q) const;
  /// Rules (1) and (2).
  bool needsGhost(const double* x, double r, int q) const;
  /// Collective: every rank's reach field from its owned particles (`centres` 3 x m, `radii` m).
  void exchangeReach(const std::vector<double>& centres, const std::vector<double>& radii);
  double reachAt(int q, const double* x) const;
  int reachCell(const double* x) const;
  /// `close`: apply the previous step's closing half kick in the same pass first (see advance()).
  double openingKickAndDrift(bool close);
  template <bool kClose>
  double openingPass();
  void closingKick();
  void exchangeGhosts();
  /// Collective: wrap the owned centres on periodic axes; a fault (non-finite, outside a walled box) is thrown
  /// on every rank.
  void wrapOwned();
  void rebuild();
  /// Collective: column k = the column of `rows` (one per local particle) of the particle with key k, for every
  /// particle of the system, on every rank (its owner's value).
  Eigen::MatrixXd gatherOwned(const Eigen::MatrixXd& rows);
  /// Collective: DemSimulation::orderDecay() of the global slot order.
  double orderDecay();
  /// Collective: DemSimulation::resortParticles(): new keys in the Morton order of all centres, then a build.
  void resort();
  /// Collective: every rank's cost; a bisection is recomputed when it is out of balance (before the migration).
  void rebalance();
  void computeForces();
  contact::ForceContext context();
  void check();
  /// Gather, run the serial check on rank 0 and throw its message on every rank (or `fallback`).
  [[noreturn]] void failCollectively(const std::string& fallback);
  void setupGhostBuffers();
  /// Whether the force kernel reads a ghost's v(t + dt/2): as `velocity` without the prediction, and for the
  /// tangential springs of rotating laws. A frictionless run with the prediction reads only the predicted
  /// velocity, so its ghost updates leave v(t + dt/2) out (a third of the bytes); a ghost's v(t + dt/2) is
  /// read by nothing else (kicks, checks, gathers and migrations use owned particles).
  bool ghostsReadHalfStep() const { return !predict_ || rotation_; }
  int recordWidth() const;
  void packRecord(Index slot, std::vector<double>& out) const;

  // run
  Box box_;
  integrators::DemSettings settings_;
  contact::ContactModel model_;
  contact::ForceKernel kernel_;
  contact::KernelFlags flags_;
  integrators::TimeStepChoice timeStep_;
  bool predict_ = false, conservative_ = false, rotation_ = false;
  double dt_ = 0.0, skin_ = 0.0, growth_ = 0.0, timeOrigin_ = 0.0, initialEnergy_ = 0.0;
  std::int64_t step_ = 0, builds_ = 0;
  bool interrupted_ = false;
  int rank_ = 0, size_ = 1;
  Decomposition grid_;
  double rebalanceThreshold_ = 0.1;
  std::int64_t rebalances_ = 0;
  std::int64_t resorts_ = 0;
  std::int64_t total_ = 0;       ///< particles in the system (all ranks)
  double rmaxGlobal_ = 0.0;      ///< the largest radius of the system (growRadii())
  Eigen::VectorXd sampleRadii_;  ///< `auto` only, from the first growRadii(): every radius of the system, grown
  bool resample_ = false;        ///< radii grew since `auto` chose: choose again at the next build
  bool carryForces_ = false;     ///< a build between steps (growRadii()): records carry the forces and torques
  std::vector<double> rmax_;     ///< largest owned radius per rank (-1: owns nothing)
  std::vector<std::vector<std::pair<std::int32_t, double>>> reach_;  ///< per rank: (cell, R) by cell
  int reachCells_[3] = {1, 1, 1};  ///< the reach grid's cells per axis (exchangeReach)

  // local particles, owned and ghosts, ascending key (= serial slot)
  Index n_ = 0;
  std::vector<Index> key_, id_, ownedSlots_;
  std::vector<std::uint8_t> owned_;
  Eigen::Matrix3Xd x_, v_, vp_, w_, wp_, f_, tq_, ref_;
  Eigen::VectorXd r_, invm_, invI_, refR_;

  // ghost updates: per rank the local slots sent (owned) and received (ghosts), in ascending key
  std::vector<std::vector<Index>> sendSlots_, recvSlots_;
  std::vector<double> sendBuffer_, recvBuffer_;
  std::vector<int> sendOffset_, recvOffset_, partners_;

  // neighbour list and contact springs
  std::unique_ptr<broadphase::BroadPhase> backend_;
  std::vector<broadphase::Pair> pairs_;
  contact::ContactList list_;
  std::vector<Index> fill_;
  contact::ContactHistory pairHistory_, wallHistory_;
  std::vector<std::uint64_t> pairKeys_, wallKeys_;
  std::vector<double> crossScratch_;
  std::vector<std::uint8_t> crossTouching_;

  RankStats stats_;
};

}  // namespace polydem::parallel
