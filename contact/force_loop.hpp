#pragma once
// The force loop: contact forces (and torques) over a ContactList, plus walls, gravity and global
// viscous damping, written as one template over the contact law and the scene's feature flags.
//
// Runtime choices become compile-time ones in exactly one place, selectForceKernel(): a frictionless,
// wall-free, gravity-free scene runs computeForces<LinearLaw, {}> which has no rotation arrays, no
// history, no wall loop and no branches for any of them. Every shipped combination is instantiated
// once in force_kernels_*.cpp (every law x 8 flag sets).
//
// Velocities: velocity Verlet evaluates forces at positions x(t + dt) while the velocities are at
// t + dt/2. Dashpots and viscous damping use the predicted v(t + dt) = v(t + dt/2) + dt/2 a(t)
// (`velocity`), which keeps the dissipated energy second-order accurate; with v(t + dt/2) the head-on
// restitution is off by about zeta omega_0 dt (5% at e = 0.1, f = 50). The tangential spring grows by
// v_t(t + dt/2) dt (`velocityHalf`), the midpoint rule for the slip displacement. With
// DemSettings::dashpotVelocity = HalfStep (LAMMPS's choice: its velocity Verlet computes forces after the
// drift with v(t + dt/2)) the integrator passes velocityHalf as `velocity` too and skips the prediction:
// the kernel is the same code, reading the other array, so the option costs nothing either way.
//
// Threads (ForceContext::threads > 1, OpenMP builds): the serial loop adds each pair's force to row i
// and subtracts it from particle j at once, a scatter that threads cannot share without races, and
// whose order fixes the rounding. The threaded loop keeps that order exactly ("owner sums"): the
// rows are cut into contiguous blocks of about equal work, one per thread, each owning the forces of its
// particles (ContactList::buildBlocks). Pairs with both particles in one block are handled by its owner
// as in the serial loop. The few "cross" pairs (j in a later block than i) are computed in a first pass,
// shared evenly between the threads, each storing F_c. After a barrier the owner of each block sets its body
// forces, subtracts the stored F_c of the cross pairs into the block in ascending (i, j), the first terms of
// the serial sum of F_j, and runs its rows as the serial loop does, reading F_c of the cross pairs back in
// place. Every force is thus summed in the serial order, and any thread count gives results bit-identical
// to the serial loop; each pair is computed (and its spring advanced) once; no atomics, no per-thread force
// arrays; the scratch is 3 doubles (9 with friction) and a flag per cross pair, a few per cent of the pairs
// in Morton order. (Until session 26 the owner of j computed the cross pairs: with two blocks every cross
// pair lies in the second, so one thread did them all while the other waited.) Rejected, after
// measuring: per-thread force buffers reduced afterwards (not bit-identical, T x 3N traffic); storing
// every pair force and gathering them through the transposed list (bit-identical too, but the gather's
// scattered reads of a 3P-double array made a one-thread run cost about 1.5x the serial CPU time); atomics
// (slow, order-dependent); colouring (a colouring per rebuild). Walls stay serial (few).
//
// Look-ahead (ForceContext::lookAhead): a row lists its j > i, and in Morton order some of them lie far
// ahead in memory, beyond the caches once the arrays outgrow them: the load of x_j then stalls the loop
// (about half the force time at 10^6 spheres, perf). The loop therefore prefetches the data of the
// candidate kLookAheadDistance (batched loop: kBatchedLookAheadDistance) entries further down the list (across row
// ends): its centre and radius, and with LookAhead::Contacts also its velocity and force, which only touching pairs
// read. The prefetches change no result. DemSimulation chooses: none below kLookAheadMinCount particles (the arrays fit
// in this machine's L2), Centres for the batched loop, and for the one-pass loop Contacts when at least a quarter of
// the candidates touched at the last stability check, else Centres.
#include <cstddef>
#include <cstdint>
#include <string>

#include "contact/contact_history.hpp"
#include "contact/contact_law.hpp"
#include "contact/contact_list.hpp"
#include "core/types.hpp"

namespace polydem::contact {

/// Scene features the kernel is specialised on (besides the law). Structural: usable as a template
/// argument.
struct KernelFlags {
  bool walls = false;    ///< some axis is walled: particle-wall contacts from ContactList
  bool gravity = false;  ///< F += m g
  bool viscous = false;  ///< F -= gamma m v, torque -= gamma I omega
  bool operator==(const KernelFlags&) const = default;
};

/// What the force loop prefetches for the candidate kLookAheadDistance entries ahead (see above).
enum class LookAhead : std::uint8_t {
  None,      ///< nothing (small systems: their arrays sit in the caches)
  Centres,   ///< x_j and r_j, read by every candidate's overlap test
  Contacts,  ///< also v_j and F_j, read and written by touching candidates
};
inline constexpr Index kLookAheadDistance = 16;  ///< list entries, the one-pass loop
/// The batched loop's distance: its contact tests run faster than the one-pass loop's candidates, so a line
/// needs more entries' time to arrive (at 10^6 spheres 64 beat 16 by 8-13% on equal and uniform-volume omega 10
/// spheres; 32 and 128 were no better, and at 5 x 10^4 every distance gave the same).
inline constexpr Index kBatchedLookAheadDistance = 64;
inline constexpr Index kLookAheadMinCount = 32768;  ///< below this, LookAhead::None

/// The look-ahead for `count` particles of which `touchingShare` of the list's candidates touched, for a
/// kernel that takes the batched loop (`batched`, ForceKernel::batched()) or the one-pass loop. The batched
/// loop reads v_j and F_j of its touching pairs only after the whole batch's contact tests, by which time their
/// lines have had a batch's time to arrive; prefetching them too was slower in every measured scene (equal and
/// uniform-volume spheres, 5 x 10^4 to 10^6, 0.08 to 4 candidates per row), so it takes Centres.
inline LookAhead chooseLookAhead(Index count, double touchingShare, bool batched) {
  if (count < kLookAheadMinCount) return LookAhead::None;
  if (batched) return LookAhead::Centres;
  return touchingShare >= 0.25 ? LookAhead::Contacts : LookAhead::Centres;
}

/// The pair loops of laws without rotation or pair history. The batched loop works in three passes over
/// up to 256 candidates taken across rows: the contact test of every candidate (the touching ones kept
/// without a branch), the forces of the kept pairs (independent of each other), then the sums in the
/// one-pass loop's order.
enum class Batching {
  Batched,  ///< the batched loop (the default)
  OnePass,  ///< row by row, the contact test deciding a branch per candidate
};

/// Everything the kernel reads and writes, as raw column-major 3 x N arrays (SI units). Non-owning.
struct ForceContext {
  Index count = 0;
  const double* position = nullptr;      ///< x(t + dt)
  const double* velocityHalf = nullptr;  ///< v(t + dt/2)
  const double* velocity = nullptr;      ///< v(t + dt) predicted; may equal velocityHalf when unused
  const double* radius = nullptr;
  const double* inverseMass = nullptr;
  double* force = nullptr;  ///< overwritten
  // Rotation: null unless the law uses rotation.
  const double* angularVelocityHalf = nullptr;
  const double* angularVelocity = nullptr;
  const double* inverseInertia = nullptr;
  double* torque = nullptr;  ///< overwritten
  const ContactList* list = nullptr;
  ContactHistory* pairHistory = nullptr;   ///< parallel to list->neighbour; width Law::kHistorySize
  ContactHistory* wallHistory = nullptr;   ///< parallel to list->wallParticle
  double length[3] = {1.0, 1.0, 1.0};      ///< box edges
  double halfLength[3] = {0.5, 0.5, 0.5};  ///< L/2 on periodic axes, +inf on walled axes (no image)
  double gravity[3] = {0.0, 0.0, 0.0};     ///< m/s^2
  double viscousRate = 0.0;                ///< gamma, 1/s
  double dt = 0.0;                         ///< s, for the tangential spring increment
  /// > 1: the OpenMP loop over list->blockCount() blocks (POLYDEM_WITH_OPENMP builds), which needs
  /// list->buildBlocks() and the cross scratch. 1 = the serial loop.
  int threads = 1;
  double* crossScratch = nullptr;         ///< threads > 1: crossScratchSize() doubles
  std::uint8_t* crossTouching = nullptr;  ///< threads > 1: one flag per cross pair
  LookAhead lookAhead = LookAhead::None;  ///< prefetching only: results do not depend on it
  /// Laws without rotation or pair history (ForceKernel::batched()): which loop sums the pairs. Speed
  /// only: the forces are the same bit for bit in every loop (tested).
  Batching batching = Batching::Batched;
};

/// Doubles of ForceContext::crossScratch for `crossPairs` cross pairs: the force on i (and the torques on i and j).
inline std::size_t crossScratchSize(std::size_t crossPairs, bool rotation) { return (rotation ? 9 : 3) * crossPairs; }

/// Overwrite force (and torque) with the total force on every particle. O(N + P + W); no allocation.
template <class Law, KernelFlags kFlags>
void computeForces(const typename Law::Params& params, const ForceContext& ctx);

using ForceKernelFn = void (*)(const ContactModel& model, const ForceContext& ctx);

struct ForceKernel {
  ForceKernelFn run = nullptr;
  bool rotation = false;  ///< needs angular velocity, torque, inertia
  int historyWidth = 0;   ///< doubles per contact in the histories
  std::string name;       ///< e.g. "linear+frictionless [walls]"
  /// Takes the batched loop (ForceContext::batching); PairKernel::kBatched is the same rule at compile time.
  bool batched() const { return !rotation && historyWidth == 0; }
};

/// The one runtime -> compile-time switch. `general` forces the most general kernel of the normal law
/// (Cundall-Strack tangential, walls, gravity and viscous terms compiled in) for comparisons: with
/// mu = 0, g = 0 and gamma = 0 it computes the same forces as the specialised kernel, just slower.
ForceKernel selectForceKernel(const ContactModel& model, KernelFlags flags, bool general = false);

/// Observables of the current contacts, for reports and the stability checker (not in the hot path).
struct ContactStats {
  std::size_t contacts = 0;      ///< particle pairs with overlap > 0
  std::size_t wallContacts = 0;  ///< particle-wall contacts with overlap > 0
  double maxOverlapRatio = 0.0;  ///< largest overlap / smaller radius (walls: / radius)
  Index maxOverlapI = -1;        ///< slot of the particle with the largest overlap ratio
  Index maxOverlapJ = -1;        ///< its partner's slot, or -1 - face for a wall
  double elasticEnergy = 0.0;    ///< normal springs + tangential springs (J)
};

/// Measure contacts over the list (reads positions and histories only). O(N + P + W).
ContactStats measureContacts(const ContactModel& model, const ForceContext& ctx);

}  // namespace polydem::contact
