#pragma once
// polydem jam, internal: the options of the subcommand and its checkpoint format (jam_checkpoint.cpp).
#include <cstdint>
#include <memory>
#include <string>

#include "core/io/checkpoint.hpp"
#include "core/io/particle_file.hpp"
#include "core/size_distribution.hpp"
#include "edmd/compression.hpp"
#include "edmd/hard_sphere_system.hpp"
#include "jamming/contact_network.hpp"

namespace polydem::app {

struct JamOptions {
  DistributionSpec dist;
  std::string fractionKind = "volume";
  Index count = 1000;
  double initialPhi = 0.3;
  std::string boundaries = "periodic";
  std::string sampling = "systematic";
  std::uint64_t seed = 1;
  std::string input;
  double reopen = 0.0;
  std::string schedule = edmd::formatSchedule(edmd::CompressionOptions{}.schedule);
  double targetPressure = 1e12;
  double targetPhi = 0.0;
  double maxCollisions = 1e7;
  double block = 0.0;
  std::string broadPhase = "hgrid-td";
  double neighbourhoodScale = 1.4;
  double skinCap = 4.0;
  double contactGap = 0.0;
  double runCollisions = 0.0;
  std::string output;
  bool writeVelocities = false;
  double progressSeconds = 2.0;
  std::string equivalent = "none";
  std::string eosCsv;
  std::string checkpoint;
  double checkpointInterval = 600.0;
  std::string resume;
  std::int64_t stopAfterBlocks = 0;
};

// Checkpoint (io::Checkpoint of kind "jam"): the settings, the start record (ids, attributes), the
// compression state and the engine state (edmd::SystemState), each stored bit-exact.
inline constexpr std::int64_t kJamCheckpointFormat = 1;

void putSettings(io::Checkpoint& c, const JamOptions& o);
void getSettings(const io::Checkpoint& c, JamOptions& o);
void putEngine(io::Checkpoint& c, const edmd::SystemState& s);
edmd::SystemState getEngine(const io::Checkpoint& c);
/// The box, ids and attributes of the start (positions and radii come from the engine state).
void putStartRecord(io::Checkpoint& c, const io::ParticleData& start);
io::ParticleData getStartRecord(const io::Checkpoint& c);
void putCompressionState(io::Checkpoint& c, const edmd::CompressionState& cs);
edmd::CompressionState getCompressionState(const io::Checkpoint& c);

/// The sessions of a run up to a checkpoint: the compression's wall-clock seconds in them and how many there were.
struct SessionRecord {
  bool wallKnown = true;  // false: the checkpoint predates the record (written before session 33)
  double wallSeconds = 0.0;
  std::int64_t sessions = 0;
};
void putSessionRecord(io::Checkpoint& c, const SessionRecord& record);
/// Checked: wall seconds finite and >= 0, sessions >= 1 (InputError naming the file and entry).
SessionRecord getSessionRecord(const io::Checkpoint& c);

// The parts of a run (jam_parts.cpp), shared by `polydem jam` and the Python module's jam(): the same
// start, checkpoints, contact analysis and output file from both. They print nothing.

edmd::CompressionOptions compressionOptions(const JamOptions& opt);
edmd::SystemOptions systemOptions(const JamOptions& opt);

/// --reopen: the radii of `start` x edmd::reopenRadiusFactor(pressure), refused (ConfigError) if the
/// packing's reduced_pressure attribute is not well above `pressure`. Returns the note for the origin line.
std::string reopenStart(io::ParticleData& start, double pressure, const std::string& input);

/// Random sequential addition of opt.count radii from `distribution` (or its opt.equivalent mixture), with
/// the ids and attributes the output carries; `origin` receives the start line. ConfigError if count < 2.
io::ParticleData sampledStart(const SizeDistribution& distribution, const JamOptions& opt, std::string& origin);

/// The system of a fresh start (ids 0..N-1 filled in if missing), with Maxwell-Boltzmann velocities of
/// opt.seed; unreachable targets refused (edmd::validateCompression). `input` names the start in messages.
std::unique_ptr<edmd::HardSphereSystem> startedSystem(const JamOptions& opt, const edmd::CompressionOptions& copt,
                                                      io::ParticleData& start, const std::string& input);

/// The system saved in checkpoint `saved` (read from `file`) whose start record is `start`, in its saved state.
std::unique_ptr<edmd::HardSphereSystem> restoreSystem(const io::Checkpoint& saved, const std::string& file,
                                                      const JamOptions& opt, const io::ParticleData& start);

/// The checkpoint of a run at a block boundary; `eosOffset` is the size of the EOS table written so far.
io::Checkpoint jamCheckpoint(const JamOptions& opt, const std::string& origin, const io::ParticleData& start,
                             edmd::HardSphereSystem& system, const edmd::CompressionState& cs, std::int64_t eosOffset);

/// What the report and the output say about the final packing.
struct JamSummary {
  bool interrupted = false;
  bool targetReached = false;
  std::string stopReason;
  double pressure = 0.0, phi = 0.0, phiJ = 0.0;
  Eigen::Matrix3Xd x;
  Eigen::VectorXd r;
  jamming::ContactOptions contactOptions;
  jamming::ContactNetwork net;
};

/// The contact network of the final packing (contact gap from opt.contactGap or summary.pressure), phi, phi_J.
void analysePacking(const JamOptions& opt, const edmd::HardSphereSystem& system, JamSummary& summary);

/// What -o writes: the packing with its provenance and summary as attributes (velocities in HDF5 and LAMMPS
/// outputs, in text with opt.writeVelocities).
io::ParticleData packingRecord(const JamOptions& opt, const edmd::CompressionOptions& copt,
                               const io::ParticleData& start, const edmd::HardSphereSystem& system, const JamSummary& s,
                               std::int64_t collisions);

}  // namespace polydem::app
