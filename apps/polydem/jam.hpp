#pragma once
// polydem jam, internal: the options of the subcommand and its checkpoint format (jam_checkpoint.cpp).
#include <cstdint>
#include <string>

#include "core/io/checkpoint.hpp"
#include "core/io/particle_file.hpp"
#include "core/size_distribution.hpp"
#include "edmd/compression.hpp"
#include "edmd/hard_sphere_system.hpp"

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

}  // namespace polydem::app
