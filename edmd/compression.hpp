#pragma once
// Lubachevsky-Stillinger compression: grow the spheres at a rate tied to the thermal speed, slowing the
// growth as the pressure rises, rescaling the kinetic energy at every synchronisation, until a target
// reduced pressure (jamming) or a target packing fraction is reached.
//
// A. Donev, "Jammed Packings of Hard Particles", PhD thesis, Princeton University (2006): the LS algorithm,
// §1.1.1; fast initial growth against crystallisation, slow final stage for collective jamming, §11.3;
// the d = 4 "mix" schedule (a decade slower per few decades of pressure), Figure 11.3; thermostat by
// velocity rescaling, §3.2.4; free-volume estimate of the jamming density phi_J = phi / (1 - d/p), eq. 1.2.
// The default 3D schedule and the driver are our adaptation of these.
//
// Rates are dimensionless: Gamma = (dO_max/dt) / v_th, the growth speed of the largest radius in units
// of the thermal speed v_th = sqrt(sum m v^2 / sum m), which the thermostat holds at 1. Every radius grows
// in proportion (Ogarko, thesis, University of Twente, eq. 3.22), i.e. the engine's relative rate is g = Gamma v_th /
// O_max. (Ogarko's thesis quotes Gamma against v0 = sqrt(2E/(3M)) = v_th / sqrt(3); Donev 2006 against the "thermal
// speed" of the Skoge-Donev code, which is v_th.)
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "edmd/hard_sphere_system.hpp"

namespace polydem::edmd {

/// One stage of the schedule: grow at `rate` until the reduced pressure reaches `untilPressure`.
struct Stage {
  double rate = 1e-3;
  double untilPressure = std::numeric_limits<double>::infinity();
};

/// Parse "1e-3:1e4,1e-4:1e6,1e-5" (rate:until-pressure, the last stage open-ended). Throws ConfigError.
std::vector<Stage> parseSchedule(const std::string& text);
/// Inverse of parseSchedule.
std::string formatSchedule(const std::vector<Stage>& schedule);

struct CompressionOptions {
  /// Digest §2.8 [rec]: 1e-3 to p = 1e4, 1e-4 to 1e6, 1e-5 beyond.
  std::vector<Stage> schedule = {{1e-3, 1e4}, {1e-4, 1e6}, {1e-5, std::numeric_limits<double>::infinity()}};
  double targetPressure = 1e12;        ///< stop when the block pressure reaches this
  double targetPackingFraction = 0.0;  ///< > 0: stop exactly at this packing fraction instead
  double maxCollisionsPerParticle = 1e7;
  /// Collisions per particle between synchronisations (thermostat, pressure reading); 0 = automatic:
  /// clamp(0.01 / Gamma, 10, 1000), which keeps the heating of a block near 2% (our estimate).
  double blockCollisionsPerParticle = 0.0;
  double thermalSpeed = 1.0;
  /// false: skip the precision limit of the target pressure (tests of the plateau detection only).
  bool checkPrecision = true;
};

/// State after one block.
struct Progress {
  double packingFraction = 0.0;
  double pressure = 0.0;         ///< reduced pressure of the block
  double jammingEstimate = 0.0;  ///< phi / (1 - 3/p) (NaN while p <= 3)
  double rate = 0.0;             ///< Gamma of the block
  int stage = 0;
  double collisionsPerParticle = 0.0;  ///< cumulative
  double eventsPerSecond = 0.0;        ///< of the block
  double collisionsPerSecond = 0.0;    ///< of the block
  double wallSeconds = 0.0;            ///< since the start of compress()
  double time = 0.0;                   ///< simulated time
  std::int64_t blocks = 0;
  double meanNeighbours = 0.0;     ///< neighbour-list length at the end of the block
  double exitsPerCollision = 0.0;  ///< of the block
  std::int64_t rebuilds = 0;       ///< global neighbourhood rebuilds in the block
};

struct CompressionResult {
  Progress last;
  /// "pressure", "packing fraction" (the target was reached); "collision budget", "jammed before the target
  /// packing fraction", "pressure plateau at round-off", "interrupted", "no events (every particle at rest)"
  /// (it was not).
  std::string stopReason;
  bool targetReached = false;
  EventCounts counts;  ///< events of the whole compression (earlier sessions of a resumed run included)
  double wallSeconds = 0.0;
};

/// Where a compression stands at a block boundary, besides the system itself (HardSphereSystem::saveState):
/// with both, compress() continues bit for bit as the uninterrupted run (checkpoint and resume).
struct CompressionState {
  bool begun = false;      ///< false: compress() starts afresh (sets the thermal speed, records `initial`)
  std::int64_t stage = 0;  ///< index into the schedule
  std::int64_t blocks = 0;
  EventCounts initial;  ///< the system's counts when the compression began
  /// Plateau detection (pressures stuck at round-off): maxResolvablePressure() at the start, the largest
  /// block pressure of the current and of the previous window of kPlateauBlocks blocks.
  double pressureLimit = 0.0;
  double windowMax = 0.0, previousWindowMax = 0.0;
  std::int64_t windowBlocks = 0;
  std::int64_t windowStart = 0;  ///< collisions (since `initial`) when the current window began
};

/// The plateau test: once the block pressure is within kPlateauBand of maxResolvablePressure(), a window
/// (at least kPlateauBlocks blocks and kPlateauGrowth / Gamma collisions per particle) whose largest
/// pressure is not kPlateauRise x that of the window before ends the run ("pressure plateau at
/// round-off"). Near jamming ln p rises by ~2 Gamma per collision per particle (docs/edmd-results.md runs), so a
/// compressing packing gains ~e^4 per window, whatever the block size; at the plateau the window maxima
/// agree within noise (docs/edmd.md "Termination").
inline constexpr std::int64_t kPlateauBlocks = 100;
inline constexpr double kPlateauBand = 1.0 / 30.0;
inline constexpr double kPlateauRise = 1.5;
inline constexpr double kPlateauGrowth = 2.0;

/// Called at every block boundary at which the compression goes on (the system synchronised, growth
/// about to be set for the next block): the place to take a checkpoint. Return true to stop there
/// ("interrupted"). Must not change the system.
using BoundaryHook = std::function<bool(HardSphereSystem&, const CompressionState&)>;

/// The largest reduced pressure that double precision resolves for `system` near jamming. The reduced
/// pressure of a packing near jamming is about (r_i + r_j) / gap_ij (p ~ 3 / (1 - phi/phi_J), all gaps
/// scaling with the radii), and a gap is known to about one unit in the last place (ulp) of the
/// coordinates, ulp(L) for the longest box edge L. A pressure p needs the gaps of the smallest pairs,
/// 2 r_min / p, to span `kGapUlps` ulps. Measured (docs/edmd.md "Termination"): 200 monodisperse spheres
/// (L = 11 r) plateau at p = 2.4e14, gaps of ~5 ulps; 32 ulps puts the limit a factor ~6 below the
/// plateau, where the pressure still rises steadily. r_min is taken at space filling (phi = 1), which
/// makes the limit conservative by at most (1/phi_J)^(1/3) ~ 1.15.
double maxResolvablePressure(const HardSphereSystem& system);
inline constexpr double kGapUlps = 32.0;

/// Check a schedule and targets before a run (also done by compress()): rates in [kMinRate, kMaxRate],
/// stage pressures increasing and > 1, target pressure in (3, maxResolvablePressure] (with a target
/// packing fraction it is the jamming guard, and compress() caps it at the limit instead), target packing
/// fraction in (current, 1) or 0, at least 2 spheres. Throws ConfigError naming the problem.
void validateCompression(const HardSphereSystem& system, const CompressionOptions& options);
inline constexpr double kMinRate = 1e-9;  ///< slower: jamming would need > ~1e9 collisions per particle
inline constexpr double kMaxRate = 1.0;   ///< faster: spheres grow faster than they move (no thermostat)

/// Maxwell-Boltzmann start velocities: components ~ N(0, 1/m) with masses proportional to r^3, the
/// centre-of-mass drift removed (the thermostat rescales them afterwards). Deterministic in `seed`.
Eigen::Matrix3Xd maxwellBoltzmannVelocities(const Eigen::VectorXd& radius, std::uint64_t seed);

/// Free-volume estimate of the jamming density, phi / (1 - d/p) with d = 3 (Donev 2006, thesis, eq. 1.2).
inline double jammingDensityEstimate(double phi, double pressure) {
  return pressure > 3.0 ? phi / (1.0 - 3.0 / pressure) : std::numeric_limits<double>::quiet_NaN();
}

/// Radius factor that reopens a packing jammed at phi_J to a reduced pressure of about `pressure`: the
/// free-volume law p ~ d / (1 - phi / phi_J) (d = 3; Donev 2006, thesis, eqs. 1.2 and 9.1) puts pressure P at
/// phi = phi_J (1 - 3/P), i.e. radii x (1 - 3/P)^(1/3). Holds for packings jammed well beyond P (reduced
/// pressure >= kReopenMargin P). Throws ConfigError unless pressure > 3 and finite.
double reopenRadiusFactor(double pressure);
/// A packing reopened to P must have been jammed beyond kReopenMargin x P for reopenRadiusFactor to hold.
inline constexpr double kReopenMargin = 10.0;

/// Run the compression on `system` (velocities must not all be zero, at least 2 spheres). Calls `onBlock`
/// after every block and `atBoundary` where it goes on. `state` non-null: continue from it (begun) and keep
/// it up to date. Leaves the system synchronised with growth off. No block runs past the collision budget.
/// Throws ConfigError for a bad schedule or target (validateCompression).
CompressionResult compress(HardSphereSystem& system, const CompressionOptions& options,
                           const std::function<void(const Progress&)>& onBlock = {},
                           const BoundaryHook& atBoundary = {}, CompressionState* state = nullptr);

/// Run at fixed density (growth off) for `collisionsPerParticle`, rescaling the thermal speed to 1 every
/// `blockCollisionsPerParticle`. Returns the pressure over the whole run and the collision rate.
struct EquilibriumRun {
  double pressure = 0.0;
  double collisionsPerSecond = 0.0;
  double eventsPerSecond = 0.0;
  EventCounts counts;
  double wallSeconds = 0.0;
};
/// `stop` (optional) is polled between blocks; true ends the run early (an interrupt).
EquilibriumRun runAtFixedDensity(HardSphereSystem& system, double collisionsPerParticle,
                                 double blockCollisionsPerParticle = 100.0, const std::function<bool()>& stop = {});

}  // namespace polydem::edmd
