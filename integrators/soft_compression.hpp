#pragma once
// Soft compression to a dense starting state without the event-driven module, as LIGGGHTS and LAMMPS
// users do with growing particles: all radii grow by a common factor (so the size distribution keeps
// its shape) under global viscous damping until the target packing fraction, then the system relaxes
// until the largest overlap is below a set fraction of the smaller radius.
//
// Rates are in units of the shortest contact duration t_c,min, so the same settings work whatever the
// stiffness: radii grow by `growthRate` (relative) per t_c,min, and the damping rate is
// gamma = damping / t_c,min. Growth pauses while the largest overlap exceeds max(5 max_overlap, 5%).
#include <cstdint>
#include <functional>
#include <string>

#include "integrators/dem_simulation.hpp"

namespace polydem::integrators {

struct CompressionSettings {
  double targetPacking = 0.0;            ///< compression.packing_fraction, in (0, 1)
  double growthRate = 2e-3;              ///< compression.growth_rate: relative radius growth per t_c,min
  double damping = 0.2;                  ///< compression.damping: gamma t_c,min
  double relaxedOverlap = 0.01;          ///< compression.max_overlap: stop once overlap / r_small is below
  std::int64_t maxSteps = 20'000'000;    ///< compression.max_steps: give up (target not reached) after this
  /// ConfigError naming the key for out-of-range values.
  void validate() const;
};

struct CompressionResult {
  std::int64_t growthSteps = 0;
  std::int64_t relaxSteps = 0;
  double packingFraction = 0.0;
  double maxOverlapRatio = 0.0;
  std::int64_t rebuilds = 0;
  bool reachedTarget = true;  ///< packing fraction reached and overlaps relaxed below max_overlap
  bool interrupted = false;   ///< stopped by SIGINT/SIGTERM (polydem::interruptRequested())
  std::string reason;         ///< why the target was not reached (empty when it was)
};

/// Compress `particles` in `box` (velocities are zeroed first) with the contact law and broad phase of
/// `settings` (its damping and gravity are replaced by the compression's: no gravity). On return
/// `particles` holds the relaxed state at rest, radii and masses scaled. `progress` (optional) is
/// called every few hundred steps. A run that spends maxSteps before reaching the packing fraction or
/// relaxing the overlaps returns the state it reached with reachedTarget = false and the reason (no
/// exception: the caller writes it, marked). With `stopOnInterrupt` an interrupt stops it the same way.
CompressionResult softCompress(ParticleStore& particles, const Box& box, DemSettings settings,
                               const CompressionSettings& compression,
                               const std::function<void(const DemSimulation&, bool growing)>& progress = {},
                               bool stopOnInterrupt = false);

}  // namespace polydem::integrators
