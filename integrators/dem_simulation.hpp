#pragma once
// A soft-sphere DEM run: particles, box, contact law, neighbour list and velocity Verlet.
//
// One step (velocity Verlet, Allen & Tildesley 2nd ed., eq. 3.19):
//   v += dt/2 F/m;  x += dt v;  [rebuild the Verlet list if max |x - x_build| > skin/2];
//   F = F(x, v_pred);  v += dt/2 F/m
// with v_pred = v(t + dt/2) + dt/2 F(t)/m the predicted full-step velocity for dashpots (see
// contact/force_loop.hpp), or v(t + dt/2) itself with DashpotVelocity::HalfStep (LAMMPS). Rotation (omega, torque,
// solid-sphere inertia) is integrated the same way, only when the kernel has rotation (friction, or the general kernel:
// DemSettings::needsRotation). Periodic coordinates are wrapped into [0, L) at each rebuild, so between rebuilds they
// stray at most skin/2 outside, which the minimum image in the kernel absorbs.
//
// A stability check runs every `checkInterval` steps (and on demand): non-finite state, a particle
// outside a walled box, an overlap above a fraction of the smaller radius, or energy growth in a
// conservative run throw SimulationError naming the step, the particles and the likely cause.
//
// Within advance(), when the next step follows at once (not the call's last step, not a stability-check step),
// a step's closing half kick is applied in the next step's opening pass (kick, kick, drift): the same operations
// in the same order, one pass over the particles fewer per step.
//
// Nothing in the time loop allocates once the neighbour list and histories have reached their size.
// With settings.threads > 1 the force loop and the kicks run on OpenMP threads (bit-identical results).
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "contact/contact_history.hpp"
#include "contact/contact_law.hpp"
#include "contact/force_loop.hpp"
#include "core/box.hpp"
#include "core/huge_pages.hpp"
#include "core/particle_store.hpp"
#include "integrators/time_step.hpp"
#include "integrators/verlet_list.hpp"

namespace polydem::integrators {

struct StabilityLimits {
  std::int64_t checkInterval = 100;  ///< steps between checks; 0 = only on demand
  double maxOverlapFraction = 0.25;  ///< overlap / smaller radius that counts as an explosion
  double energyTolerance = 1e-2;     ///< allowed relative growth of the total energy in conservative runs
  void validate() const;
};

/// When DemSettings::resort re-sorts the particles during a run. The decay measure: with the box cut into
/// 8^b Morton cells of at least `cellParticles` particles each on average (b <= 10; b = 0, i.e. never, below
/// 8 cellParticles particles), the fraction of particles whose slot lies outside the range of slots their
/// cell would hold in Morton order. 0 right after a sort; about 1 for a random order. A particle leaves its
/// cell's range once it has moved out of its cell (cells of ~256 particles are ~6 spacings wide), so the
/// default 0.3 re-sorts after typical displacements of about a particle spacing: a dense packing that only
/// relaxes never re-sorts, a gas or a flow does.
struct ResortRule {
  std::int64_t interval = 500;  ///< steps between decay measurements (0 = never re-sort)
  double threshold = 0.3;       ///< re-sort when orderDecay() exceeds this (>= 0)
  Index cellParticles = 256;    ///< particles per coarse cell of the measure, on average (>= 1)
  void validate() const;
};

/// Which velocity the dashpots (and viscous damping) see when forces are computed at x(t + dt).
enum class DashpotVelocity {
  Predicted,  ///< v(t + dt/2) + dt/2 F(t)/m: second-order dissipation (the default)
  HalfStep,   ///< v(t + dt/2), as LAMMPS's velocity Verlet (fix nve/sphere) does: for reproducing LAMMPS
};

struct DemSettings {
  contact::ContactParameters contact;
  double stepsPerContact = 50.0;  ///< f: dt = t_c,min / f (>= 5)
  double timeStep = 0.0;          ///< s; > 0 overrides the automatic dt (then f is reported as t_c,min / dt)
  double skin = -1.0;             ///< Verlet skin (m); < 0 = 0.2 r_min
  std::string broadPhase = "linked-cell";
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();             ///< m/s^2
  double viscousDamping = 0.0;                                   ///< global damping rate gamma (1/s): F -= gamma m v
  DashpotVelocity dashpotVelocity = DashpotVelocity::Predicted;  ///< run.dashpot_velocity
  StabilityLimits stability;
  bool spatialSort = true;     ///< reorder particles along a Morton curve at start (and see resort)
  bool generalKernel = false;  ///< force the most general kernel (comparisons); needs rotation arrays
  /// Re-sort during the run (with spatialSort): every `interval` steps the decay of the storage order is
  /// measured (DemSimulation::orderDecay()), and above `threshold` the particles are put back in Morton
  /// order and the neighbour list is rebuilt at that step. Decided from the step number and the state
  /// alone, so the skin, the backend, the thread count and a resume never change when it happens.
  ResortRule resort;
  /// OpenMP threads for the force loop, the kicks and the neighbour-list rebuild (the backend's grid build
  /// and pair search, the CSR list) (>= 1). 1 runs the serial code; > 1 needs a POLYDEM_WITH_OPENMP build
  /// and gives bit-identical results (see contact/force_loop.hpp, broadphase/pair_chunks.hpp).
  int threads = 1;
  /// An explicit timeStep above t_c,min / 5 is refused (ConfigError naming run.dt) unless this is set
  /// (run.allow_unstable_dt): the same rule as run.dt_factor >= 5.
  bool allowUnstableDt = false;
  /// The particle store needs rotation arrays (Features::rotation): friction (torques), or the general
  /// kernel, which has the Cundall-Strack terms compiled in.
  bool needsRotation() const { return contact.usesFriction() || generalKernel; }
  /// No dissipation at all: elastic contacts (e = 1, mu = 0) and no viscous damping. Energy is then
  /// conserved unless gravity acts along a periodic axis (DemSimulation::conservative()).
  bool dissipationFree() const { return contact.elastic() && viscousDamping == 0.0; }
  /// > 0: the initial velocities were scaled by the impact rule so that two smallest particles overlap by
  /// this fraction of their radius (velocities.overlap). Error messages then name velocities.overlap as
  /// the fix for excessive overlaps: a stiffer contact would only rescale the velocities again.
  double impactOverlap = 0.0;
};

/// Seconds spent in each phase of the time loop (wall clock).
struct PhaseTimes {
  double broadPhase = 0.0;   ///< displacement-triggered rebuilds, including history remapping
  double force = 0.0;        ///< the force kernel
  double integration = 0.0;  ///< kicks and drift (with the displacement check)
  double check = 0.0;        ///< stability checks
  /// Steps whose closing half kick ran in the next step's opening pass (DemSimulation::advance)
  std::int64_t joinedKicks = 0;
};

/// Whether step `s` of an advance() call of `steps` steps, which ends at global step `stepAfter`, leaves its
/// closing half kick to the next step's opening pass: only when that step follows at once (not the call's last
/// step), no stability check follows this one (it reads the full-step velocities) and no stop is asked for. The
/// one rule of DemSimulation::advance and the MPI engine's advance (which passes its rank-reduced stop flag).
inline bool joinClosingKick(std::int64_t s, std::int64_t steps, std::int64_t stepAfter, std::int64_t checkInterval,
                            bool stopAsked) {
  return s + 1 < steps && !(checkInterval > 0 && stepAfter % checkInterval == 0) && !stopAsked;
}

struct Energies {
  double kinetic = 0.0;     ///< translational, J
  double rotational = 0.0;  ///< J
  double elastic = 0.0;     ///< normal and tangential springs, J
  double potential = 0.0;   ///< gravity, -sum m g.x, J (0 without gravity)
  double total() const { return kinetic + rotational + elastic + potential; }
};

/// Everything that determines the trajectory from a step on, in slot order (bit-exact): a checkpoint.
/// Wall-clock phase times are not part of it. See DemSimulation::state() and DemSimulation::restore().
struct DemState {
  Box box;
  std::int64_t step = 0;
  double timeOrigin = 0.0;        ///< simulated time at step 0 (s): the start file's time
  TimeStepChoice timeStep;        ///< dt and the pair that set it
  double skin = 0.0;              ///< resolved Verlet skin (m)
  double initialEnergy = 0.0;     ///< reference of the energy check
  double growthSinceBuild = 0.0;  ///< radius growth since the last neighbour-list build (m)
  std::int64_t builds = 0;        ///< neighbour-list builds so far
  bool rotation = false;          ///< the store has rotation arrays
  std::vector<Index> id;
  Eigen::Matrix3Xd position, velocity, force, angularVelocity, torque;  ///< rotation arrays empty without
  Eigen::VectorXd radius, inverseMass, inverseInertia;
  Eigen::Matrix3Xd referencePosition;             ///< centres at the last build
  Eigen::VectorXd referenceRadius;                ///< radii at the last build
  std::vector<std::uint64_t> pairKeys, wallKeys;  ///< history keys (checked against the rebuilt list)
  std::vector<double> pairValues, wallValues;     ///< history values, width per key
};

class DemSimulation {
 public:
  /// Validates everything (ConfigError naming the key), sorts particles spatially (optional), chooses
  /// dt, builds the neighbour list and computes the initial forces. Periodic coordinates are wrapped.
  DemSimulation(ParticleStore particles, const Box& box, const DemSettings& settings);

  /// Continue from `state` (from state()) with `settings` (the same as the run that saved it): no
  /// spatial sort, no new time step; the neighbour list is rebuilt from the saved build positions and
  /// radii, so it holds the same pairs in the same order, and the contact histories are put back. The
  /// resumed trajectory is bit-identical to the uninterrupted one. Throws InputError if the state is
  /// inconsistent (sizes, history keys that the rebuilt list does not have).
  static DemSimulation restore(const DemState& state, const DemSettings& settings);
  /// The complete state at the current step (see DemState). O(N + P).
  DemState state() const;

  /// Advance `steps` steps. Throws SimulationError from the stability check. With `stopOnInterrupt`,
  /// polydem::interruptRequested() is polled after each complete step (a safe point: the state is that of
  /// an uninterrupted run at that step) and the loop stops early. Returns the steps done.
  std::int64_t advance(std::int64_t steps, bool stopOnInterrupt = false);

  /// Run the stability check now. Throws SimulationError.
  contact::ContactStats checkStability() const;  ///< the contact statistics it checked

  /// Multiply every radius by `factor` (>= 1) at constant density (masses by factor^3, inertia by
  /// factor^5), for soft compression. The neighbour list stays valid: the rebuild criterion becomes
  /// 2 max|dx| + 2 max(dr) > skin. The time step is kept (contacts only get longer as masses grow);
  /// energy is no longer conserved, so the energy check of a dissipation-free run restarts from the current total
  /// (O(N + P); a damped run has no energy check and keeps its reference). O(N).
  void growRadii(double factor);
  /// Total sphere volume / box volume.
  double packingFraction() const;
  /// The same expression for given radii (a copy of the particles' radii gives the same bytes).
  static double packingFraction(const Eigen::VectorXd& radius, const Box& box);

  std::int64_t step() const { return step_; }
  /// Simulated time (s): the time origin (0, or the start file's time) plus step x dt.
  double time() const { return timeOrigin_ + static_cast<double>(step_) * dt_; }
  /// Start the clock at `t` (s), e.g. the time of the snapshot a run continues from.
  void setTimeOrigin(double t) { timeOrigin_ = t; }
  double dt() const { return dt_; }
  const TimeStepChoice& timeStepChoice() const { return timeStep_; }
  const ParticleStore& particles() const { return particles_; }
  const Box& box() const { return box_; }
  const contact::ContactModel& model() const { return model_; }
  const contact::ForceKernel& kernel() const { return kernel_; }
  const DemSettings& settings() const { return settings_; }
  const VerletList& neighbours() const { return verlet_; }
  const contact::ContactHistory& pairHistory() const { return pairHistory_; }
  const contact::ContactHistory& wallHistory() const { return wallHistory_; }
  /// Rebuilds of the neighbour list (including the initial build).
  std::int64_t rebuilds() const { return verlet_.builds(); }
  /// Re-sorts by DemSettings::resort in this object's lifetime (not part of the state: a resumed run counts
  /// from 0; the initial sort is not counted).
  std::int64_t resorts() const { return resorts_; }
  /// Decay of the storage order, the measure of ResortRule (0 = Morton order at the coarse level, up to 1).
  /// O(N + 8^b).
  double orderDecay() const;
  const PhaseTimes& times() const { return times_; }
  /// Energies at the current step (velocities synchronised). O(N + P).
  Energies energies() const { return energies(contactStats()); }
  /// The same with the elastic energy taken from contact statistics already measured at this step. O(N).
  Energies energies(const contact::ContactStats& stats) const;
  /// Total energy at step 0.
  double initialEnergy() const { return initialEnergy_; }
  /// Contacts, largest overlap, elastic energy at the current step. O(N + P).
  contact::ContactStats contactStats() const;
  /// Total linear momentum (kg m/s).
  Eigen::Vector3d momentum() const;
  /// True when energy should be conserved: e = 1, mu = 0, no viscous damping, gravity only along walled axes.
  bool conservative() const { return conservative_; }
  /// Heap bytes held by the run: particle arrays, neighbour list, histories, buffers.
  std::size_t memoryBytes() const;
  /// Bytes of the per-particle arrays and the neighbour list advised to use transparent huge pages.
  std::size_t hugePageBytesAdvised() const { return hugePages_.advisedBytes(); }

 private:
  struct RestoreTag {};
  DemSimulation(const DemState& state, const DemSettings& settings, RestoreTag);
  void validateSettings();
  void selectKernel();
  void rejectCoincidentCentres() const;
  [[noreturn]] void blowUp(Index slot, const std::string& what) const;

  contact::ForceContext context();
  contact::ForceContext context() const;
  void rebuild();
  /// Transparent huge pages for the per-particle arrays and the neighbour list (core/huge_pages.hpp): the
  /// arrays that are new or have moved since the last call; after every rebuild.
  void adviseHugePages();
  /// The force loop's look-ahead from the share of the list's candidates that touch (contact::chooseLookAhead).
  void chooseLookAhead(const contact::ContactStats& stats);
  /// Wrap periodic coordinates into [0, L) and check walled ones (SimulationError naming the particle).
  void wrapPositions();
  /// The particles in Morton order of their (wrapped) centres, every per-particle array permuted in place
  /// (the arrays keep their memory: views of them stay valid), then a rebuild.
  void resortParticles();
  /// First half of a step: v += dt/2 F/m, x += dt v (and the predicted v, omega); returns the largest
  /// squared displacement since the last build.
  /// `close`: apply the previous step's closing half kick in the same pass first (see advance()).
  double openingKickAndDrift(bool close = false);
  template <bool kClose>
  double openingPass();
  void computeForces();
  /// Second half of a step: v += dt/2 F/m (and omega += dt/2 torque/I) with the new forces.
  void closingKick();
  [[noreturn]] void fail(const std::string& what, const std::string& cause) const;
  std::string dtHint() const;

  ParticleStore particles_;
  Box box_;
  DemSettings settings_;
  contact::ContactModel model_;
  contact::ForceKernel kernel_;
  contact::KernelFlags flags_;
  TimeStepChoice timeStep_;
  double dt_ = 0.0;
  VerletList verlet_;
  contact::ContactHistory pairHistory_, wallHistory_;
  std::vector<std::uint64_t> pairKeys_, wallKeys_;
  Eigen::Matrix3Xd velocityPredicted_, angularVelocityPredicted_;
  std::vector<double> crossScratch_;                         ///< threads > 1: forces (torques) of the cross pairs
  std::vector<std::uint8_t> crossTouching_;                  ///< threads > 1: contact flag per cross pair
  contact::LookAhead lookAhead_ = contact::LookAhead::None;  ///< the force loop's prefetching (force_loop.hpp)
  bool predict_ = false;  ///< dashpots or viscous damping present and Predicted: keep velocityPredicted_
  bool conservative_ = false;
  double growthSinceBuild_ = 0.0;  ///< largest radius increase since the last neighbour-list build (m)
  std::int64_t resorts_ = 0;
  mutable std::vector<Index> decayCells_;  ///< orderDecay(): slot ranges of the coarse cells
  std::int64_t step_ = 0;
  double timeOrigin_ = 0.0;
  double initialEnergy_ = 0.0;
  PhaseTimes times_;
  HugePageAdvice hugePages_;
};

/// Morton (Z-order) permutation of the centres on a 1024^3 grid over the box: order[k] = old slot.
std::vector<Index> mortonOrder(const Eigen::Matrix3Xd& centres, const Box& box);

/// The measure of DemSettings::resort in parts, so that a distributed run (parallel::DistributedDem) decides a
/// re-sort at the same steps as the serial one: DemSimulation::orderDecay() counts the particles whose slot lies
/// outside the slot range of their coarse cell, the cells having orderDecayBits() bits per axis (0: too few
/// particles, never re-sorted) and coarseCell() the cell of a centre (wrapped like the rebuild wraps it on
/// periodic axes): the leading bits of the key mortonOrder() sorts by, so a sorted store has every particle
/// inside its cell's range.
int orderDecayBits(Index count, Index cellParticles);
std::uint64_t coarseCell(const double* x, const Box& box, int bits);

}  // namespace polydem::integrators
