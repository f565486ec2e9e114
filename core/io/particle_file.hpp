#pragma once
// Particle files: the in-memory record of one configuration (ParticleData) and a plain text format.
// HDF5 snapshots (core/io/hdf5_snapshot.hpp) carry the same record; readParticles()/writeParticles()
// pick the format from the file extension.
//
// Text format (SI units, origin of the box at 0):
//
//   # boundaries: periodic periodic wall     <- optional; any of periodic|wall per axis x y z
//   # any other comment; '#' also starts a trailing comment, blank lines are ignored
//   3 10 10 10                               <- N Lx Ly Lz
//   1.0 1.0 1.0 0.5                          <- x y z r, or x y z r vx vy vz; N such lines,
//   ...                                         all with the same column count
//
// Reading is strict: every problem throws InputError "FILE:LINE: problem". Centres outside [0, L) on
// periodic axes are wrapped into the box (legitimate periodic data); outside [0, L] on walled axes they
// are an error. Text files store neither ids (they become 0..N-1 in line order), time nor attributes:
// use HDF5 snapshots when those matter.
#include <array>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/box.hpp"
#include "core/types.hpp"

namespace polydem::io {

/// One configuration as stored in a file. Positions, velocities and radii in SI units.
struct ParticleData {
  Box box;
  Eigen::Matrix3Xd position;                  ///< 3 x N
  Eigen::VectorXd radius;                     ///< N
  std::optional<Eigen::Matrix3Xd> velocity;   ///< 3 x N; present if the file had velocities
  std::optional<Eigen::Matrix3Xd> angularVelocity;  ///< 3 x N, rad/s; present if the file had them
  std::vector<Index> id;                      ///< N, unique; text files: 0..N-1 in line order
  double time = 0.0;                          ///< s
  std::map<std::string, std::string> attributes;  ///< scene parameters, free-form key -> value

  Index count() const { return static_cast<Index>(radius.size()); }
};

inline constexpr std::array<Boundary, 3> kAllPeriodic = {Boundary::Periodic, Boundary::Periodic,
                                                         Boundary::Periodic};

/// Read a text particle file (format above). `defaultBoundaries` applies when the file has no
/// `# boundaries:` line. Throws InputError "FILE:LINE: problem" for any malformed or invalid content.
ParticleData readText(const std::filesystem::path& file,
                      std::array<Boundary, 3> defaultBoundaries = kAllPeriodic);

/// Write `data` as text: a `# boundaries:` comment, the header, one line per particle at full
/// precision (%.17g, so reading back is bit-exact), velocities if present. Ids, time and attributes are
/// not stored. Throws ConfigError if the arrays of `data` disagree in size, InputError if the file
/// cannot be written.
void writeText(const std::filesystem::path& file, const ParticleData& data);

/// Read by extension: .h5/.hdf5 (any case) -> readSnapshot(), anything else -> readText().
/// `defaultBoundaries` only matters for text files (snapshots always store their boundaries).
ParticleData readParticles(const std::filesystem::path& file,
                           std::array<Boundary, 3> defaultBoundaries = kAllPeriodic);

/// Write by extension: .h5/.hdf5 (any case) -> writeSnapshot() (plus XDMF sidecar), else writeText().
void writeParticles(const std::filesystem::path& file, const ParticleData& data);

/// True for .h5/.hdf5 (any case): the extensions readParticles()/writeParticles() treat as HDF5.
bool isHdf5Path(const std::filesystem::path& file);

/// Throw ConfigError unless position (3 x N), velocity (3 x N, if present) and id (N) match radius (N).
/// Writers call it; the values themselves are not checked (a blown-up state may still be worth saving).
void requireConsistentSizes(const ParticleData& data);

}  // namespace polydem::io
