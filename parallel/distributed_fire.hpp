#pragma once
// FIRE energy minimisation (integrators/fire_minimiser.hpp) on MPI ranks, with a result that is the serial
// minimiser's to the bit for any rank count (docs/parallel.md).
//
// The particles, their ghosts, migration and the neighbour list through the broad phase are a DistributedDem's
// (distributed_dem.hpp), built with the minimiser's outer skin: its list is the serial outer candidates of every
// owned particle, in the serial (i, j) order. On top, as the serial VerletList and FireMinimiser do:
//   - the list within the skin is cut from those candidates with the one pair predicate, at the serial steps
//     (the same rebuild rule from exact global maxima: the two largest displacements since the build), and the
//     centres are wrapped only when the serial run wraps them (at a build through the broad phase);
//   - the Jacobi masses are summed over every local row (integrators::fire::jacobiMasses): an owned particle's
//     sum has the serial terms in the serial order;
//   - the forces are the same compiled kernel over that list;
//   - FIRE's sums (P = F.v, |F|^2, ...) and measure()'s sums (energy, mean contact force, pressure, packing
//     fraction) are added by chunks of 4096 serial slots in chunk order, as the serial minimiser adds them:
//     parallel/keyed_chunks.hpp; maxima and counts are exact over the ranks;
//   - the descent is the one loop of integrators/fire_descent.hpp, so every decision (uphill, dt, stop) is
//     the serial one.
// Conjugate gradients (`--method cg`) run the same way (fire::descendByCg), the direction and the last
// preconditioned force kept in the DistributedDem's velocity arrays, which migrate with their particles.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "integrators/fire_descent.hpp"
#include "integrators/fire_minimiser.hpp"
#include "parallel/distributed_dem.hpp"
#include "parallel/keyed_chunks.hpp"

namespace polydem::parallel {

class DistributedFire {
 public:
  using Progress = integrators::FireMinimiser::Progress;

  /// Collective. Every rank passes the same minimiser, as constructed (its particles neither moved nor changed
  /// size since; std::logic_error otherwise): the distributed run continues it.
  DistributedFire(const integrators::FireMinimiser& serial, DecompositionKind kind = DecompositionKind::Bisection);

  /// Collective: FireMinimiser::minimise(), the same result on every rank.
  integrators::FireResult minimise(const Progress& progress = {}, bool stopOnInterrupt = false);
  /// Collective: FireMinimiser::scaleRadii().
  void scaleRadii(double factor);
  /// Collective: FireMinimiser::measure().
  integrators::MinimiserReport measure();
  /// Collective: FireMinimiser::packingFraction().
  double packingFraction();
  /// Collective: the centres in slot order on every rank, as the serial minimiser holds them (unwrapped
  /// between builds).
  Eigen::Matrix3Xd positions();
  /// Collective: the radii in slot order on every rank.
  Eigen::VectorXd radii();
  /// Collective: every rank's counts and times, on rank 0.
  ParallelStats stats() { return dem_.stats(); }

  const integrators::MinimiserSettings& settings() const { return settings_; }
  integrators::FireSettings& fireSettings() { return settings_.fire; }
  /// Force evaluations so far, counting the serial minimiser's before this object took over.
  std::int64_t forceEvaluations() const { return forceEvaluations_; }

  // fire::descend()'s system (integrators/fire_descent.hpp).
  void prepare(const integrators::MinimiserReport& start);
  integrators::fire::FireSums sums();
  bool interrupted() const { return interrupted_; }
  void restart(double dt);
  void advance(double dt, double keep, double toward);
  void finish(integrators::FireResult& res);
  double overlapFloor() const;
  // fire::descendByCg()'s system.
  void resetPrevious();
  std::array<double, 2> precondition();
  void restartDirection();
  std::array<double, 3> direct(double beta, bool update);
  double along();
  void moveAlong(double a);
  double skin() const { return skin_; }

 private:
  /// The list within the skin from the outer candidates, at the current centres (ghosts current).
  void cut();
  /// After a move: the exact pair drift over the ranks (each rank's two largest displacements), the list check,
  /// then the ghosts (exchanged, or fresh from a build) and the forces.
  void afterMove(const integrators::fire::LargestTwo& largest);
  /// A split chunk's packed records (`width` values per particle: 3-vectors, then scalars) into packScratch_ as
  /// arrays: each 3-vector field 3 x count, then each scalar field count long.
  void unpack(Index count, const double* packed, int width);
  void updateMasses();
  void computeForces();
  /// The serial FireMinimiser::rebuild(): a cut when no pair outside the candidates can be within the skin,
  /// else a build through the broad phase (wrap, migrate, ghosts, candidates) and a cut. Ghosts current first.
  void rebuild();
  /// Collective: FireMinimiser::broadPhaseBuild()'s check of the centres (non-finite, outside a walled box), the
  /// serial message thrown on every rank as CollectiveError.
  void checkCentres();
  /// The two largest displacements (summed) of all particles from `reference` (3 per local slot), exact over
  /// the ranks; +inf when some centre is not finite.
  double drift(const Eigen::Matrix3Xd& reference);
  integrators::fire::StiffnessRule stiffnessRule() const;
  contact::ForceContext context();

  integrators::MinimiserSettings settings_;
  DistributedDem dem_;
  KeyedChunks chunks_;
  contact::ContactList inner_;
  Eigen::Matrix3Xd innerReference_;
  std::vector<double> crossScratch_;
  std::vector<std::uint8_t> crossTouching_;
  std::vector<double> part_, packScratch_, extra_, gathered_;
  Index total_ = 0;
  double skin_ = 0.0, outerSkin_ = 0.0, pressureUnit_ = 1.0, hertzReferenceOverlap_ = 1e-4;
  double growthSinceBuild_ = 0.0, growthSinceOuter_ = 0.0, pairDrift_ = 0.0;
  bool interrupted_ = false, stopOnInterrupt_ = false;
  std::int64_t forceEvaluations_ = 0, rebuildsInCall_ = 0, broadBuildsInCall_ = 0;
  double broadSeconds_ = 0.0, forceSeconds_ = 0.0, callStart_ = 0.0, broadAtStart_ = 0.0, forceAtStart_ = 0.0;
};

}  // namespace polydem::parallel
