#pragma once
// Soft compression to a dense starting state without the event-driven module, as LIGGGHTS and LAMMPS
// users do with growing particles: all radii grow by a common factor (so the size distribution keeps
// its shape) under global viscous damping until the target packing fraction, then the system relaxes
// until the largest overlap is below a set fraction of the smaller radius.
//
// Rates are in units of the shortest contact duration t_c,min, so the same settings work whatever the
// stiffness: radii grow by `growthRate` (relative) per t_c,min, and the damping rate is
// gamma = damping / t_c,min. Growth pauses while the largest overlap exceeds max(5 max_overlap, 5%).
#include <algorithm>
#include <cstdint>
#include <functional>
#include <string>

#include "integrators/dem_simulation.hpp"

namespace polydem::integrators {

struct CompressionSettings {
  double targetPacking = 0.0;          ///< compression.packing_fraction, in (0, 1)
  double growthRate = 2e-3;            ///< compression.growth_rate: relative radius growth per t_c,min
  double damping = 0.2;                ///< compression.damping: gamma t_c,min
  double relaxedOverlap = 0.01;        ///< compression.max_overlap: stop once overlap / r_small is below
  std::int64_t maxSteps = 20'000'000;  ///< compression.max_steps: give up (target not reached) after this
  /// ConfigError naming the key for out-of-range values.
  void validate() const;
  /// The packing fraction to generate the start at when `requested` is asked for: never above the
  /// target, since the compression only grows radii (a start above it would never relax to it).
  double startPacking(double requested) const { return std::min(requested, targetPacking); }
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

/// Where a compression stands: with the simulation's DemState, all a resumed compression needs.
struct CompressionProgress {
  enum class Phase : int { Growing = 0, Relaxing = 1, Done = 2 };
  Phase phase = Phase::Growing;
  std::int64_t steps = 0;        ///< steps so far (growth + relaxation)
  std::int64_t growthSteps = 0;  ///< set when growth ends
  std::int64_t relaxSteps = 0;
  bool packed = false;           ///< the packing fraction was reached (set when growth ends)
  double overlap = 0.0;          ///< largest overlap / r_small after the last relaxation chunk
  double contactDuration = 0.0;  ///< t_c,min of the starting state: sets the rates
  double viscousDamping = 0.0;   ///< gamma = damping / t_c,min, the simulation's viscous_damping
};

/// Where the steps of a compression run when not in its own DemSimulation: on several MPI ranks
/// (apps/polydem/relax_mpi.cpp, parallel::DistributedDem), each call collective. The compression then keeps its
/// simulation for the radii alone (the packing fraction, computed by the serial expression from the same
/// bytes) until sync() brings it up to the engine's state.
class CompressionEngine {
 public:
  virtual ~CompressionEngine() = default;
  virtual void advance(std::int64_t steps) = 0;
  /// DemSimulation::growRadii().
  virtual void growRadii(double factor) = 0;
  /// DemSimulation::contactStats().maxOverlapRatio.
  virtual double maxOverlapRatio() = 0;
  /// `sim` := the engine's state.
  virtual void sync(DemSimulation& sim) = 0;
};

/// A soft compression advanced chunk by chunk (20 growth steps, or 100 relaxation steps), so that the
/// caller can poll interrupts and save checkpoints between chunks. A compression restored from
/// state() and progress() continues bit-identically.
class SoftCompression {
 public:
  /// Start compressing `particles` (velocities zeroed) with the law and broad phase of `settings`; its
  /// gravity is dropped and its damping replaced by the compression's.
  SoftCompression(ParticleStore particles, const Box& box, DemSettings settings,
                  const CompressionSettings& compression);
  /// Continue a compression saved at a chunk boundary. `settings` as given to the first constructor.
  SoftCompression(const DemState& state, DemSettings settings, const CompressionSettings& compression,
                  const CompressionProgress& progress);

  /// Run the steps on `engine` from now on (null: in simulation()); the engine starts from simulation()'s state.
  /// simulation() and particles() are then stale until sync().
  void runOn(CompressionEngine* engine) { engine_ = engine; }
  /// simulation() := the engine's state (nothing without an engine).
  void sync();

  /// Run one chunk. Returns false (doing nothing) once the compression has ended.
  bool advance();
  /// The packing fraction and the largest overlap / smaller radius of the current state (with an engine:
  /// the packing fraction from the radii kept in step, the overlap a collective call).
  double packingFraction() const;
  double maxOverlapRatio() const;
  bool finished() const { return progress_.phase == CompressionProgress::Phase::Done; }
  bool growing() const { return progress_.phase == CompressionProgress::Phase::Growing; }
  const DemSimulation& simulation() const { return sim_; }
  const CompressionProgress& progress() const { return progress_; }
  /// The result so far; on a finished compression, reachedTarget and reason say how it ended.
  CompressionResult result() const;
  /// The particles at rest (velocities and spins zeroed), radii and masses scaled.
  ParticleStore particles() const;

 private:
  DemSettings compressionSettings(DemSettings settings, double viscousDamping) const;
  void growRadii(double factor);

  CompressionSettings compression_;
  CompressionProgress progress_;
  DemSimulation sim_;
  CompressionEngine* engine_ = nullptr;
  Eigen::VectorXd radii_;  ///< with an engine: the radii, grown as the engine grows them (sized on first growth)
};

/// Compress `particles` in `box` (velocities are zeroed first) with the contact law and broad phase of
/// `settings` (its damping and gravity are replaced by the compression's: no gravity). On return
/// `particles` holds the relaxed state at rest, radii and masses scaled. `progress` (optional) is
/// called every 1000 steps. A run that spends maxSteps before reaching the packing fraction or
/// relaxing the overlaps returns the state it reached with reachedTarget = false and the reason (no
/// exception: the caller writes it, marked). With `stopOnInterrupt` an interrupt (polled between chunks)
/// stops it the same way.
CompressionResult softCompress(ParticleStore& particles, const Box& box, DemSettings settings,
                               const CompressionSettings& compression,
                               const std::function<void(const DemSimulation&, bool growing)>& progress = {},
                               bool stopOnInterrupt = false);

}  // namespace polydem::integrators
