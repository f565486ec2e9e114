#pragma once
// Plain text particle files: one ParticleData (core/io/particle_data.hpp) per file.
//
// Text format (SI units, origin of the box at 0). Full-line comments before the header line whose first
// word is `boundaries:`, `columns:`, `time:` or `attribute:` are metadata and must be well formed; any
// other comment is free text. '#' also starts a trailing comment; blank lines and CR LF are accepted.
//
//   # columns: x y z r vx vy vz wx wy wz         <- optional: [id] x y z r [vx vy vz] [wx wy wz] [arrays], in order
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
// not 0..N-1. Optional arrays (ParticleData::arrays, e.g. relax's output.arrays) follow the built-in
// columns, only with a `# columns:` line: a 1-component array as its name, a 3-component one as NAME_x
// NAME_y NAME_z (three consecutive words of that form are read as one 3-component array); names are
// letters, digits and '_', not a built-in column or dataset name; values finite numbers.
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

#include "core/io/particle_data.hpp"

namespace polydem::io {

/// Read a text particle file (format above). `defaultBoundaries` applies when the file has no
/// `# boundaries:` line. Throws InputError "FILE:LINE: problem" for any malformed or invalid content.
ParticleData readText(const std::filesystem::path& file, std::array<Boundary, 3> defaultBoundaries = kAllPeriodic);

/// Write `data` as text (format above): metadata comments (columns, boundaries, time, attributes), the
/// header, one line per particle at full precision (%.17g, so reading back is bit-exact), velocities and
/// angular velocities if present, ids if not 0..N-1. Atomic: written to a temporary beside `file` and
/// renamed over it, so `file` is never left truncated. Throws ConfigError if the arrays of `data`
/// disagree in size or an attribute key is empty, InputError if the file cannot be written.
void writeText(const std::filesystem::path& file, const ParticleData& data);

}  // namespace polydem::io
