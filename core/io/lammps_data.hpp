#pragma once
// LAMMPS data files, atom_style sphere (read_data / write_data of LAMMPS, https://docs.lammps.org/read_data.html).
//
//   LAMMPS data file ...                    <- first line: free text
//   300 atoms
//   1 atom types
//   0 0.01 xlo xhi                          <- orthogonal box; a tilt line "xy xz yz" is refused
//   0 0.01 ylo yhi
//   0 0.01 zlo zhi
//
//   Atoms # sphere
//
//   1 1 0.001 2500 0.004 0.002 0.007 0 0 0  <- id type diameter density x y z [ix iy iz]
//
//   Velocities
//
//   1 0.1 0 0 0 0 0                         <- id vx vy vz wx wy wz (wx wy wz angular velocity, rad/s)
//
// Mapping to ParticleData: polydem id = LAMMPS id - 1 (LAMMPS ids start at 1); radius = diameter / 2;
// positions shifted so the box starts at 0; atom types (when not all 1), densities (when not all
// equal; otherwise the attribute `density`) and image flags (arrays "type", "density", "image") are kept
// as optional arrays, so writing back reproduces them. A Masses section is read and checked only for
// form. Data files carry no boundaries: `boundaries` decides. Any other section, a missing count, a
// non-sphere Atoms style or a malformed line is an InputError "FILE:LINE: problem".
#include <array>
#include <filesystem>

#include "core/io/particle_data.hpp"

namespace polydem::io {

/// Read a LAMMPS data file (format above). Throws InputError "FILE:LINE: problem".
ParticleData readLammpsData(const std::filesystem::path& file, std::array<Boundary, 3> boundaries = kAllPeriodic);

/// Write `data` as a LAMMPS data file (atom_style sphere, with a Velocities section when `data` has
/// velocities), atomically, at full precision (%.17g). Density from the array or the attribute `density`,
/// else 1. Throws ConfigError if the arrays of `data` disagree in size, InputError if it cannot be written.
void writeLammpsData(const std::filesystem::path& file, const ParticleData& data);

/// True for names ending in .data or .lmp, or starting with "data." (LAMMPS habits).
bool isLammpsDataPath(const std::filesystem::path& file);

}  // namespace polydem::io
