#pragma once
// Lubachevsky-Stillinger compression: grow the spheres at a rate tied to the thermal speed, slowing the
// growth as the pressure rises, rescaling the kinetic energy at every synchronisation, until a target
// reduced pressure (jamming) or a target packing fraction is reached.
//
// Seed 001 (shared/seeds/001_3d36564c50aaa2ef.txt): LS algorithm :78-97; fast initial growth against
// crystallisation, slow final stage for collective jamming :12454-12458; the d = 4 "mix" schedule
// (a decade slower per few decades of pressure) :12434-12436; thermostat by velocity rescaling
// :2579-2586; free-volume estimate of the jamming density phi_J = phi / (1 - d/p), eq. 1.2, :344-351.
// Digest shared/spec/event-driven-and-jamming.md §2.8 [rec] default 3D schedule, §2.11 driver.
//
// Rates are dimensionless: Gamma = (dO_max/dt) / v_th, the growth speed of the largest radius in units
// of the thermal speed v_th = sqrt(sum m v^2 / sum m), which the thermostat holds at 1. Every radius grows
// in proportion (seed 000 eq. 3.22), i.e. the engine's relative rate is g = Gamma v_th / O_max.
// (Seed 000 quotes Gamma against v0 = sqrt(2E/(3M)) = v_th / sqrt(3); seed 001 against the "thermal
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
  /// clamp(0.01 / Gamma, 10, 1000), which keeps the heating of a block near 2% (digest §2.4).
  double blockCollisionsPerParticle = 0.0;
  double thermalSpeed = 1.0;
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
  std::string stopReason;  ///< "pressure", "packing fraction", "collision budget"
  EventCounts counts;      ///< events of the whole compression
  double wallSeconds = 0.0;
};

/// Maxwell-Boltzmann start velocities: components ~ N(0, 1/m) with masses proportional to r^3, the
/// centre-of-mass drift removed (the thermostat rescales them afterwards). Deterministic in `seed`.
Eigen::Matrix3Xd maxwellBoltzmannVelocities(const Eigen::VectorXd& radius, std::uint64_t seed);

/// Free-volume estimate of the jamming density, phi / (1 - d/p) with d = 3 (seed 001 eq. 1.2).
inline double jammingDensityEstimate(double phi, double pressure) {
  return pressure > 3.0 ? phi / (1.0 - 3.0 / pressure) : std::numeric_limits<double>::quiet_NaN();
}

/// Run the compression on `system` (velocities must not all be zero). Calls `onBlock` after every block.
/// Leaves the system synchronised with growth off. Throws ConfigError for a bad schedule or target.
CompressionResult compress(HardSphereSystem& system, const CompressionOptions& options,
                           const std::function<void(const Progress&)>& onBlock = {});

/// Run at fixed density (growth off) for `collisionsPerParticle`, rescaling the thermal speed to 1 every
/// `blockCollisionsPerParticle`. Returns the pressure over the whole run and the collision rate.
struct EquilibriumRun {
  double pressure = 0.0;
  double collisionsPerSecond = 0.0;
  double eventsPerSecond = 0.0;
  EventCounts counts;
  double wallSeconds = 0.0;
};
EquilibriumRun runAtFixedDensity(HardSphereSystem& system, double collisionsPerParticle,
                                 double blockCollisionsPerParticle = 100.0);

}  // namespace polydem::edmd
