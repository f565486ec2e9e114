#pragma once
// Energy minimisation of frictionless soft spheres by FIRE: the Fast Inertial Relaxation Engine of Bitzek,
// Bitzek, Koskinen, Gumbsch, Moseler & Gumbsch, Phys. Rev. Lett. 97, 170201 (2006), with the FIRE 2.0
// corrections of Guenole, Noehring, Vaid, Houlle, Xie, Prakash & Bitzek, Comput. Mater. Sci. 175, 109584
// (2020): semi-implicit (symplectic) Euler steps, mixing v <- (1 - alpha) v + alpha |v| F/|F| between the kick
// and the drift, on P = F.v <= 0 half a step back (x -= dt/2 v) and v = 0, dt grows only after N_delay
// downhill steps, no dt decrease in the first N_delay steps (initial delay), dt in [dt_min, dt_max], and a
// stop after N_P<0,max uphill steps in a row.
//
// Forces come from the engine's own force loop (contact::selectForceKernel, the kernel a relax step runs)
// over the engine's Verlet list, rebuilt when the two largest displacements since the build plus 2 max dr exceed the
// skin; rows are in canonical (i, j) order, so the minimised state is bit-identical for every complete broad phase. One
// FIRE step is one reduction pass (F.v, |v|^2, |F|^2, max |F_i|), one kick-mix-drift pass and the force loop: no
// allocation. With threads, the passes share out fixed chunks of 4096 particles and add the chunks' sums in chunk
// order, so the result is the same bytes for any thread count (as the force loop's).
//
// Two-level list (MinimiserSettings::outerSkin, default 5 x skin): FIRE's growing step carries the particles
// several times further per step than a relax step, so the list is rebuilt often; most rebuilds then cut the
// list from the broad phase's candidates within the outer skin (O(pairs)) instead of running the broad phase,
// and give the same list as a broad-phase build would.
//
// Inertia (Jacobi preconditioning): the minimum does not depend on the masses, so they are chosen to make
// every particle's vibration frequency about the same. m_i = k_self,i + sum_j k_ij over the Verlet candidates
// of i (k_ij the pair's normal stiffness; for Hertz at a reference overlap), i.e. the diagonal of the Hessian
// bounded from above, so that sqrt(k/m) <= ~1 everywhere: a size ratio of 100 then needs no more steps than a
// monodisperse packing, where physical masses (m ~ r^3 against k ~ r) would make the largest spheres 100x
// slower than the smallest. Masses are recomputed at each neighbour-list rebuild. Time is in units where
// omega ~ 1: dt_MD = 0.1 by default (a harmonic pair of equal m then has omega = 1, period 2 pi).
//
// Stopping rule: converged when max_i |F_i| <= tolerance x max(<|F_c|>, referenceForce), with <|F_c|> the
// mean normal force over the contacts (overlap > 0), or when there are no contacts (zero energy, zero force),
// or when every overlap is at round-off, below 64 eps max(L) (an unjammed state whose last contacts are
// rounding noise: their forces are noise too, so no relative criterion can be met; seen at N = 256). The state
// is measured every 256 steps (one O(P) pass: < 1% of the steps) and whenever the residual looks converged.
// The relative criterion is scale-free (any stiffness, any pressure). Its floor is round-off: a centre is
// known to eps L (L the box edge), so a force to eps L k; relative to a contact force k delta, the floor is
// eps L / delta, which grows with N^(1/3) and 1/p: ~1e-8 for N = 1000 at p/k = 1e-7, and 3-5e-9 measured for
// N = 10^4 equal spheres at p/k = 1e-6 (L = 40 d), above the default 1e-9. So a fourth stop: "round-off
// floor", when the largest Jacobi step max_i |F_i| / m_i is below eps max(L) (MinimiserReport::stepUlps <= 1:
// the forces ask no particle to move by a representable amount) and the residual has not halved for 4 x the
// steps its last halving took (at least 2048, at most 16384); converged = true, and the residual reached is reported
// beside the tolerance that was asked for. Not converged after maxIterations (or after maxUphill uphill steps in a
// row): FireResult::converged = false with the residual reached.
//
// Conjugate gradients (MinimiserSettings::method = ConjugateGradient, `--method cg`): the same forces, list,
// masses (as the preconditioner M^-1) and stopping rule, with Polak-Ribiere+ preconditioned conjugate
// directions d = M^-1 F + beta d (beta = max(0, F.(M^-1 F - s_old) / (F_old.s_old)): a negative beta restarts
// along the preconditioned force) and a line search of one trial and one secant step: move by the last line
// step a_t, take the secant root a* = a_t g(0) / (g(0) - g(a_t)) of g(a) = F(x + a d).d (exact for a harmonic
// energy whose contacts do not change along the line), capped at 4 a_t and at one skin of travel for any
// sphere, and move there. Two force
// evaluations per iteration; FireResult::iterations counts force evaluations for both methods, so they compare
// in the same unit. Why a second method: near jamming FIRE restarts from rest at every uphill step, and in a
// large packing those restarts come every ~10^3 steps, before the slow collective modes of the creeping
// contact network have built up speed; CG keeps its conjugate direction. Measured over the jamming protocol from
// a hard-sphere start at p/k 1e-6: 1.46x fewer force evaluations than FIRE at N = 2000, 1.58x at N = 10^4, the
// same phi_J to 2e-9, and the same cost per evaluation (docs/jamming_dem.md).
#include <Eigen/Core>
#include <chrono>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "contact/contact_law.hpp"
#include "contact/force_loop.hpp"
#include "core/box.hpp"
#include "core/particle_store.hpp"
#include "integrators/verlet_list.hpp"

namespace polydem::integrators {

/// FIRE 2.0 parameters (Guenole et al. 2020, Table 1 defaults).
struct FireSettings {
  double forceTolerance = 1e-9;  ///< converged: max |F_i| <= this x max(<|F_c|>, referenceForce)
  double referenceForce = 0.0;   ///< N; a force scale below which residuals count as zero (0 = none)
  std::int64_t maxIterations = 1000000;
  double dt = 0.1;            ///< initial step dt_MD in the preconditioned units (omega ~ 1)
  double dtMaxFactor = 10.0;  ///< dt_max = this x dt_MD
  double dtMinFactor = 0.02;  ///< dt_min = this x dt_MD
  int nDelay = 20;            ///< N_delay: downhill steps before dt grows and alpha shrinks
  double fInc = 1.1;
  double fDec = 0.5;
  double alphaStart = 0.25;
  double fAlpha = 0.99;
  std::int64_t maxUphill = 2000;      ///< N_P<0,max: uphill steps in a row before giving up
  bool initialDelay = true;           ///< no dt decrease during the first N_delay steps
  std::int64_t progressInterval = 0;  ///< iterations between progress callbacks (0 = none)
  /// Throws ConfigError naming the setting (minimise.force_tolerance, ...).
  void validate() const;
};

/// What a minimiser is built with. The contact law must be frictionless and elastic (no dashpot): FIRE
/// itself removes the energy.
/// Which descent runs on the forces (the header's FIRE or conjugate gradients).
enum class MinimiserMethod { Fire, ConjugateGradient };
/// "fire" or "cg".
const char* methodName(MinimiserMethod method);

struct MinimiserSettings {
  contact::ContactParameters contact;  ///< linear (constant or radius-scaled) or Hertz; e = 1, mu = 0
  double skin = -1.0;                  ///< Verlet skin (m); < 0 = 0.2 r_min
  /// Two-level list (VerletList::setOuterSkin): the broad phase finds the pairs within this gap (m), and
  /// the list is cut to `skin` from them until a pair may have closed outer - skin; < 0 = 5 x skin (less where a
  /// periodic edge is too short for it), 0 or skin = one level (every rebuild runs the broad phase).
  double outerSkin = -1.0;
  std::string broadPhase = "linked-cell";
  bool spatialSort = true;  ///< Morton order once at construction (ids travel with the particles)
  int threads = 1;          ///< OpenMP threads of the force loop (bit-identical results)
  MinimiserMethod method = MinimiserMethod::Fire;
  FireSettings fire;  ///< the stopping rule, budget and progress for both methods; the step parameters for FIRE
};

/// Observables of the current state (a pass over the contact list: not per step).
struct MinimiserReport {
  std::int64_t iteration = 0;     ///< FIRE steps in this minimise() call
  double energy = 0.0;            ///< elastic energy (J)
  double maxForce = 0.0;          ///< max_i |F_i| (N)
  double meanContactForce = 0.0;  ///< <|F_n|> over contacts (N); 0 without contacts
  double residual = 0.0;          ///< maxForce / max(meanContactForce, referenceForce); 0 when both are 0
  /// Largest Jacobi step max_i |F_i| / m_i (m) in units of the round-off of a coordinate, eps max(L): the
  /// move the remaining forces ask for, against the resolution of the positions (about 1 at the round-off
  /// floor, where no tolerance below can be met).
  double stepUlps = 0.0;
  std::size_t contacts = 0;  ///< particle pairs with overlap > 0
  std::size_t wallContacts = 0;
  double maxOverlapRatio = 0.0;  ///< largest overlap / smaller radius
  double maxOverlap = 0.0;       ///< largest overlap (m)
  double pressure = 0.0;         ///< virial pressure (Pa): sum F_n |r_ij| / (3 V), walls with lever r_i - delta
  double reducedPressure = 0.0;  ///< pressure / pressureUnit()
  double packingFraction = 0.0;
  double dt = 0.0;  ///< current FIRE step, or the last CG line step (in units of M^-1 F)
};

/// Wall seconds of one minimise() call by part (steady clock), for the cost against a `relax` step.
struct FirePhaseSeconds {
  double broadPhase = 0.0;  ///< neighbour-list builds (wrapping, the build, the masses)
  double force = 0.0;       ///< force-loop passes
  double update = 0.0;      ///< the FIRE sums, mixing, kick and drift, the restarts
  double measure = 0.0;     ///< energy, contact and pressure measurements (every 256 steps and for progress)
  double total() const { return broadPhase + force + update + measure; }
};

struct FireResult {
  bool converged = false;
  std::string stopReason;        ///< "converged", "no contacts", "overlaps at round-off", "round-off floor", "iteration
                                 ///< budget", "uphill", "interrupted"
  std::int64_t iterations = 0;   ///< force evaluations: FIRE steps, or 2 per CG iteration
  std::int64_t uphillSteps = 0;  ///< FIRE: P <= 0 events; CG: restarts along the preconditioned force
  std::int64_t rebuilds = 0;     ///< neighbour-list builds in this call (broad phase or refined)
  std::int64_t broadPhaseBuilds = 0;  ///< of which through the broad phase (the rest refined the outer list)
  FirePhaseSeconds seconds;           ///< where this call's wall time went
  MinimiserReport last;
};

namespace fire {
/// Stiffness of pair (i, j) at the reference overlap (N/m) for the Jacobi masses: (factor R_eff) scale for
/// the radius-scaled linear law (scale 1) and Hertz (scale sqrt of the reference overlap), factor for the
/// constant linear law. A value built once per mass update, so the loop over the candidates inlines it.
struct StiffnessRule {
  double factor, scale;
  bool byRadius;
  double operator()(double ri, double rj) const { return byRadius ? factor * (ri * rj / (ri + rj)) * scale : factor; }
};
}  // namespace fire

class FireMinimiser {
 public:
  using Progress = std::function<void(const MinimiserReport&)>;

  /// Validates (ConfigError naming the key), wraps periodic centres, sorts spatially (optional), builds the
  /// neighbour list and computes forces. Velocities start at zero.
  FireMinimiser(ParticleStore particles, const Box& box, const MinimiserSettings& settings);

  /// Run FIRE from the current positions until the stopping rule holds or the budget is spent. With
  /// `stopOnInterrupt`, polydem::interruptRequested() is polled every step. Throws SimulationError for a
  /// non-finite state.
  FireResult minimise(const Progress& progress = {}, bool stopOnInterrupt = false);

  /// Multiply every radius by `factor` > 0 (affine compression for > 1, decompression for < 1, at fixed
  /// centres and box: the same configuration as shrinking the box about fixed scaled centres). Forces are
  /// recomputed; velocities set to zero.
  void scaleRadii(double factor);

  /// Observables of the current state. O(N + P).
  MinimiserReport measure() const;
  /// Divisor of reducedPressure: k (N/m^2) for radius-scaled linear contacts, K (Pa) for Hertz, k / (2 <r>)
  /// for constant linear stiffness (N/m over a mean diameter), so that p / unit is dimensionless and
  /// independent of the length scale.
  double pressureUnit() const { return pressureUnit_; }
  /// Mean contact force (N) a packing of these spheres has at reduced pressure p: p unit V / (N <2r>) (from
  /// p = N z <F> <d> / (6 V) with z = 6). For FireSettings::referenceForce.
  double contactForceAtPressure(double reducedPressure) const;
  double packingFraction() const;

  const ParticleStore& particles() const { return particles_; }
  /// Centres wrapped into [0, L) on periodic axes (the stored ones stray up to a skin outside between
  /// rebuilds), for outputs and analyses.
  Eigen::Matrix3Xd wrappedPositions() const;
  const Box& box() const { return box_; }
  const MinimiserSettings& settings() const { return settings_; }
  FireSettings& fireSettings() { return settings_.fire; }
  const VerletList& neighbours() const { return verlet_; }
  const contact::ForceKernel& kernel() const { return kernel_; }
  /// Force evaluations so far (each costs one force-loop pass).
  std::int64_t forceEvaluations() const { return forceEvaluations_; }
  std::size_t memoryBytes() const;

  /// What a continuation on MPI ranks needs besides the particles (parallel/distributed_fire.hpp).
  struct ListState {
    double growthSinceBuild = 0.0, growthSinceOuter = 0.0;  ///< radius growth since the list's builds (m)
    double hertzReferenceOverlap = 0.0;                     ///< the masses' reference overlap (Hertz)
    bool moved = false;  ///< some centre moved since the last build through the broad phase
  };
  ListState listState() const;
  /// Take the centres `x` and radii `r` (slot order) of a run that continued this one elsewhere (on MPI
  /// ranks): velocities zero, a build through the broad phase, forces. The centres are wrapped as a build wraps
  /// them, so wrappedPositions() and measure() describe the state that run reached.
  void adoptState(const Eigen::Matrix3Xd& x, const Eigen::VectorXd& r);

 private:
  contact::ForceContext context() const;
  /// A new Verlet list: refined from the outer candidates when they still hold every pair within the skin,
  /// else through the broad phase (broadPhaseBuild()); the masses follow the list.
  void rebuild();
  /// Wrap the centres (naming a particle that is not finite or left a walled box) and build through the
  /// broad phase.
  void broadPhaseBuild();
  /// Whether some pair left out of the Verlet list may now touch (the displacements and radius growth since
  /// the build, against the skin).
  bool listStale() const;
  void computeForces();
  /// x += a d, then the list check and the forces (a conjugate-gradient move).
  void moveAlong(const double* d, double a);
  void updateMasses();
  fire::StiffnessRule stiffnessRule() const;
  /// fire::descend()'s system (fire_minimiser.cpp).
  class Serial;
  /// The start of a descent: Hertz masses at the current overlaps, velocities zero.
  void prepareDescent(const MinimiserReport& start);
  /// The end of a minimise() call: velocities zero, the call's counters and seconds into `res`.
  void finishCall(FireResult& res);

  ParticleStore particles_;
  Box box_;
  MinimiserSettings settings_;
  contact::ContactModel model_;
  contact::ForceKernel kernel_;
  VerletList verlet_;
  contact::ContactHistory pairHistory_, wallHistory_;  // width 0: the frictionless kernels keep none
  std::vector<double> crossScratch_;
  std::vector<std::uint8_t> crossTouching_;
  std::vector<double> cgDirection_, cgPrevious_;  // conjugate gradients only (sized on first use)
  std::vector<double> chunkMaxima_;  ///< the two largest displacements per chunk of the passes (2 per chunk)
  double growthSinceBuild_ = 0.0;
  double pressureUnit_ = 1.0;
  double hertzReferenceOverlap_ = 1e-4;  ///< relative overlap at which Hertz stiffness sets the masses
  std::int64_t forceEvaluations_ = 0;
  std::int64_t rebuildsInCall_ = 0;
  std::int64_t broadBuildsInCall_ = 0;
  double growthSinceOuter_ = 0.0;  ///< largest radius growth since the last broad-phase build
  double pairDrift_ = 0.0;         ///< the two largest displacements since the build, summed (listStale())
  double broadSeconds_ = 0.0, forceSeconds_ = 0.0;   // running totals over the object's life
  std::chrono::steady_clock::time_point callStart_;  // of the current minimise() call
  double broadAtStart_ = 0.0, forceAtStart_ = 0.0;
  mutable std::vector<double> measurePart_;  ///< measure()'s per-particle sums (3 per particle)
  HugePageAdvice hugePages_;  ///< the particle arrays and the list (core/huge_pages.hpp), after every rebuild
};

}  // namespace polydem::integrators
