#pragma once
// Particle files: the in-memory record of one configuration (ParticleData) and a plain text format.
// HDF5 snapshots (core/io/hdf5_snapshot.hpp) carry the same record; readParticles()/writeParticles()
// pick the format from the file extension.
//
// Text format (SI units, origin of the box at 0). Full-line comments before the header line whose first
// word is `boundaries:`, `columns:`, `time:` or `attribute:` are metadata and must be well formed; any
// other comment is free text. '#' also starts a trailing comment; blank lines and CR LF are accepted.
//
//   # columns: x y z r vx vy vz wx wy wz         <- optional: [id] x y z r [vx vy vz] [wx wy wz], in order
//   # boundaries: periodic periodic wall         <- optional; periodic|wall per axis x y z
//   # time: 12.5                                 <- optional; seconds, finite (default 0)
//   # attribute: reduced_pressure = 1e12         <- optional, one per ParticleData::attributes entry
//   # attribute: "key with spaces" = "a \"quoted\" value\n"
//   3 10 10 10                                   <- N Lx Ly Lz
//   1.0 1.0 1.0 0.5 0 0 0 0 0 0                  <- one line per particle, the columns above
//
// Columns: without a `# columns:` line the count decides: 4 (x y z r), 7 (+ vx vy vz) or 10 (+ wx wy wz,
// angular velocity in rad/s). `id` (a non-negative integer, unique) is only read with a `# columns:`
// line; without it ids are 0..N-1 in line order. The writer adds the id column only when the ids are
// not 0..N-1.
// Attributes: `# attribute: KEY = VALUE`. KEY and VALUE are each either bare (KEY: no blank, '=' or
// '"'; VALUE: the rest of the line, blanks trimmed) or a double-quoted string with the escapes \\ \"
// \n \r \t and \xHH (any byte), so every key and value round-trips (the writer quotes whatever is
// not plain). Keys must be non-empty and unique.
//
// Reading is strict: every problem throws InputError "FILE:LINE: problem". Centres outside [0, L) on
// periodic axes are wrapped into the box (legitimate periodic data); outside [0, L] on walled axes they
// are an error. N = 0 (a file holding only the header `0 Lx Ly Lz`) is valid.
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
  std::vector<Index> id;                      ///< N, unique, >= 0
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

/// Write `data` as text (format above): metadata comments (columns, boundaries, time, attributes), the
/// header, one line per particle at full precision (%.17g, so reading back is bit-exact), velocities and
/// angular velocities if present, ids if not 0..N-1. Atomic: written to a temporary beside `file` and
/// renamed over it, so `file` is never left truncated. Throws ConfigError if the arrays of `data`
/// disagree in size or an attribute key is empty, InputError if the file cannot be written.
void writeText(const std::filesystem::path& file, const ParticleData& data);

/// Read by extension: .h5/.hdf5 (any case) -> readSnapshot(), anything else -> readText().
/// `defaultBoundaries` only matters for text files (snapshots always store their boundaries).
ParticleData readParticles(const std::filesystem::path& file,
                           std::array<Boundary, 3> defaultBoundaries = kAllPeriodic);

/// Write by extension: .h5/.hdf5 (any case) -> writeSnapshot() (plus XDMF sidecar), else writeText().
void writeParticles(const std::filesystem::path& file, const ParticleData& data);

/// True for .h5/.hdf5 (any case): the extensions readParticles()/writeParticles() treat as HDF5.
bool isHdf5Path(const std::filesystem::path& file);

/// Throw ConfigError unless position, velocity and angularVelocity (3 x N, if present) and id (N) match
/// radius (N).
/// Writers call it; the values themselves are not checked (a blown-up state may still be worth saving).
void requireConsistentSizes(const ParticleData& data);

}  // namespace polydem::io
