#pragma once
// The parts of `polydem relax` (see relax.cpp for the subcommand): the starting state (relax_start.cpp),
// checkpoints and resume (relax_checkpoint.cpp), the time loop with its outputs, contact files included
// (relax_run.cpp), the printed report (relax_report.cpp) and the dt-factor / skin sweep (relax_sweep.cpp).
// Internal to the relax subcommand.
#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "apps/polydem/relax_scene.hpp"
#include "core/io/checkpoint.hpp"
#include "core/io/contacts.hpp"
#include "core/io/particle_file.hpp"
#include "integrators/dem_simulation.hpp"
#include "integrators/soft_compression.hpp"
#include "polydem/mpi_config.hpp"

namespace polydem::app {

// ---- the starting state (relax_start.cpp) ----------------------------------------------------------

/// The starting state: read or generated, masses from density; then compressed (compressStart) and
/// given velocities (setVelocities).
struct Start {
  ParticleStore particles;
  Box box;
  std::string origin;
  std::map<std::string, std::string> attributes;
  std::optional<std::string> targetNotReached;  ///< the soft compression stopped before its target: why
  bool interrupted = false;                     ///< SIGINT/SIGTERM during the soft compression
  std::optional<Eigen::Matrix3Xd> fileVelocity, fileAngularVelocity;  ///< from the particle file
  double fileTime = 0.0;                                              ///< the particle file's time (s)
};

/// What a resumed run needs besides the simulation state: the scene (as given: file text and overrides,
/// so it is parsed exactly as the first time), the attributes written into outputs, and the origin line.
struct RunContext {
  std::string sceneText;
  std::string sceneSource;
  std::vector<std::string> overrides;
  std::map<std::string, std::string> attributes;
  std::string origin;
  std::string checkpointNote;  ///< non-empty: the report's checkpoint line (a checkpoint written elsewhere)
};

/// Read or generate the particles of `scene` and set their masses.
Start prepare(const RelaxScene& scene);
/// The initial velocities of the run (after the compression, if any).
void setVelocities(const RelaxScene& scene, Start& s);
/// Run the soft compression of `scene` chunk by chunk; between chunks poll interrupts and write
/// checkpoints (phase "compression") as the scene asks. On return `start` holds the compressed particles
/// at rest, marked if the target was not reached or the run was interrupted.
void compressStart(const RelaxScene& scene, integrators::SoftCompression& c, Start& start, const RunContext& run,
                   bool quiet, bool checkpoints);

// ---- checkpoints (relax_checkpoint.cpp) -------------------------------------------------------------

inline constexpr const char* kCheckpointKind = "relax";

/// `compression` non-null: the run is in its soft compression (phase "compression"), else in the time
/// loop (phase "run").
io::Checkpoint makeCheckpoint(const integrators::DemSimulation& sim, const RunContext& run,
                              const integrators::CompressionProgress* compression = nullptr);
integrators::DemState stateFrom(const io::Checkpoint& c);
integrators::CompressionProgress compressionFrom(const io::Checkpoint& c);
/// The scene text, overrides, attributes and origin saved in `c`, then `overrides` (later ones win).
RunContext contextFrom(const io::Checkpoint& c, const std::vector<std::string>& overrides);
/// Keys a resumed run may change: they decide how long it runs, on how many threads (bit-identical for
/// any count) and what it writes, never the trajectory.
bool resumableKey(const std::string& assignment);

// ---- the time loop and its outputs (relax_run.cpp) --------------------------------------------------

struct RunSummary {
  double wallSeconds = 0.0;  ///< the time loop only
  double finalEnergy = 0.0;
  double initialEnergy = 0.0;
  Eigen::Matrix3Xd positions;  ///< by id, for sweep comparisons
  bool interrupted = false;
};

/// The time loop's steps on several MPI ranks (relax_mpi.cpp, POLYDEM_WITH_MPI builds; docs/parallel.md).
/// runScene() on rank 0 asks it to advance and to bring `sim` up to the distributed state before reading it
/// (outputs, checks, the report); the other ranks serve() rank 0's requests. Null in RunMode: the steps run
/// in `sim` itself.
class StepDriver {
 public:
  virtual ~StepDriver() = default;
  virtual bool root() const = 0;
  /// Advance `steps` steps (fewer when some rank saw SIGINT/SIGTERM); returns the step reached.
  virtual std::int64_t advance(std::int64_t steps) = 0;
  virtual bool interrupted() const = 0;
  /// `sim` := the distributed run's state, gathered to rank 0.
  virtual void sync(integrators::DemSimulation& sim) = 0;
  /// The loop is over: the other ranks return from serve().
  virtual void finish() = 0;
  /// Re-sorts of the storage order (DemSettings::resort) during the distributed loop; after finish().
  virtual std::int64_t resorts() const = 0;
  /// The loop's time by phase, mean over the ranks (after finish()); the report shows it instead of rank 0's
  /// serial copy's, which ran no step.
  virtual integrators::PhaseTimes phaseTimes() const = 0;
  /// Lines after the start lines and after the closing report (rank 0).
  virtual void printStart() const = 0;
  virtual void printReport() const = 0;
  /// Ranks > 0: do rank 0's requests until finish().
  virtual RunSummary serve() = 0;
};

#if POLYDEM_WITH_MPI
/// Launched by mpirun with more than one rank.
bool severalRanks();
/// Collective: distribute `sim`'s state over the ranks (parallel::DistributedDem); `decomposition` is rcb
/// (recursive coordinate bisection by cost, rebalanced) or brick.
std::unique_ptr<StepDriver> makeStepDriver(const integrators::DemSimulation& sim, const std::string& decomposition);
/// The relax features a parallel run does not have yet are refused (ConfigError naming the key).
void requireParallelSupport(bool sweep);
/// Collective: compressStart() with the steps on the ranks (rank 0 drives, prints and writes; the others
/// serve); on return every rank's `start` holds the compressed particles and rank 0's outcome.
void compressOnRanks(const RelaxScene& scene, integrators::SoftCompression& c, Start& start, const RunContext& run,
                     bool quiet, const std::string& decomposition);
#else
inline bool severalRanks() { return false; }
#endif

/// How runScene() runs and what it prints.
struct RunMode {
  bool quiet = false;    ///< no progress lines
  bool brief = false;    ///< no start lines and no closing report (sweep rows)
  bool resumed = false;  ///< continues a checkpoint: no step-0 outputs, the time series is appended to
  std::optional<std::string> targetNotReached = {};  ///< the soft compression's reason: outputs are marked
  StepDriver* driver = nullptr;                      ///< several MPI ranks run the steps (see StepDriver)
};

/// Particle data in id order, for snapshots and the final state: positions (wrapped), velocities, angular
/// velocities (rotation on), time, step, and `attrs` plus step, time, contact and dt (the Python module writes
/// its files through it too, so they match the CLI's byte for byte).
io::ParticleData snapshotOf(const integrators::DemSimulation& sim, const std::map<std::string, std::string>& attrs);
// ---- contact files and derived arrays of the snapshots (relax_run.cpp) ----------------------------------

/// The particle pairs in contact at the current step with their forces (output.contacts), rows in id order,
/// `attrs` plus step, time and contact. Forces from the snapshot's state (see relax_run.cpp). O(N + P).
io::ContactData contactsOf(const integrators::DemSimulation& sim, const std::map<std::string, std::string>& attrs);

/// output.arrays "rattler": 1 for a particle left with fewer than d + 1 = 4 contacts (pairs and walls with
/// gap <= 0) after rattlers are removed recursively (jamming::analyseContacts), else 0; `d` in id order.
Eigen::VectorXd rattlerFlags(const io::ParticleData& d);

/// At most this many distinct radii make a configuration a discrete mixture for size_class.
inline constexpr int kMaxSizeComponents = 8;

/// output.arrays "size_class": with at most kMaxSizeComponents distinct radii (equal to 1e-12 relative;
/// mono, bi and other discrete mixtures) the component index 0, 1, ... in ascending radius; otherwise the
/// octave floor(log2(r / r_min)), r_min the smallest radius (class k holds 2^k r_min <= r < 2^(k+1) r_min).
struct SizeClasses {
  Eigen::VectorXd values;
  bool discrete = false;
  std::string rule;  ///< the rule applied, stored as the snapshot attribute size_class
};
SizeClasses sizeClasses(const Eigen::VectorXd& radius);

/// Every output of the scene (and the sweep's), checked before anything is computed.
void checkOutputs(const RelaxScene& scene, const std::vector<std::filesystem::path>& inputs,
                  const std::vector<std::pair<std::filesystem::path, std::string>>& extra = {});
/// The time loop with outputs, checkpoints and progress; prints the start lines and the closing
/// report unless `mode.brief`.
RunSummary runScene(const RelaxScene& scene, integrators::DemSimulation sim, const RunContext& run,
                    const RunMode& mode);

// ---- the printed report (relax_report.cpp) ----------------------------------------------------------

/// The lines before the time loop: particles, contact law, time step, broad phase, start state.
void printStart(const RelaxScene& scene, const integrators::DemSimulation& sim, const RunContext& run, bool resumed);
/// What the report's timing line divides by and what it names.
struct LoopTiming {
  double loopSeconds = 0.0;
  std::int64_t stepsRun = 0;
  std::int64_t totalSteps = 0;
  bool interrupted = false;
  std::int64_t resorts = 0;  ///< re-sorts of the storage order (DemSettings::resort) during the loop
  /// A run on several ranks: its phase times (StepDriver::phaseTimes), else the serial simulation's are used.
  std::optional<integrators::PhaseTimes> rankPhases;
};
/// The closing "--- relax report ---".
void printReport(const RelaxScene& scene, const integrators::DemSimulation& sim, const RunContext& run,
                 const LoopTiming& timing, const std::optional<std::string>& targetNotReached);

// ---- the sweep (relax_sweep.cpp) ---------------------------------------------------------------------

/// The swept key and its values, ascending.
struct SweepSpec {
  std::string what;  ///< "dt-factor" or "skin"
  std::vector<double> values;
};
/// "dt-factor=10,20,50" or "skin=0.05,0.1" (strict numbers; dt-factor >= 5, not with run.dt). Throws ConfigError.
SweepSpec parseSweep(const RelaxScene& scene, const std::string& spec);
struct SweepRow {
  double value;
  std::int64_t steps;
  RunSummary run;
};
/// One run of `scene` per value from `start` (compressed, velocities set), over the same simulated time;
/// stops after an interrupted run (then the last row's run.interrupted). `quiet`: no line per run on stderr.
std::vector<SweepRow> sweepRows(const RelaxScene& scene, const SweepSpec& sweep, const Start& start,
                                const RunContext& context, bool quiet);
/// The error of a row (integrators::convergenceError: energy drift for a dissipation-free scene, else against
/// the finest setting) and its cost.
struct SweepError {
  std::optional<double> energy;  ///< undefined for a zero reference energy
  double position = 0.0;         ///< max |dx| / r_min against the finest setting
  double usPerParticleStep = 0.0;
};
std::vector<SweepError> sweepErrors(const RelaxScene& scene, const SweepSpec& sweep, const Start& start,
                                    const std::vector<SweepRow>& rows);

/// --sweep dt-factor=10,20,50 | skin=0.05,0.1: same scene (same start) per setting, same simulated time.
int runSweep(RelaxScene scene, const std::string& spec, bool quiet, const std::vector<std::filesystem::path>& inputs);

}  // namespace polydem::app
