#pragma once
// LAMMPS dump files in the native text format ("dump atom/custom", https://docs.lammps.org/dump.html),
// as OVITO and LAMMPS read_dump read them. One frame per snapshot:
//
//   ITEM: TIME
//   0.0015                                 <- ParticleData::time, s (before TIMESTEP, which LAMMPS 2021's
//   ITEM: TIMESTEP                            read_dump accepts; after it, it refuses the file)
//   1000                                   <- the attribute `step` (0 if absent)
//   ITEM: NUMBER OF ATOMS
//   300
//   ITEM: BOX BOUNDS pp pp ff              <- pp periodic, ff wall, per axis
//   0 0.01
//   0 0.01
//   0 0.01
//   ITEM: ATOMS id type radius x y z vx vy vz omegax omegay omegaz [arrays...]
//
// Columns: id is polydem id + 1; type from the array "type" (else 1); vx.. only with velocities,
// omegax.. only with angular velocities; arrays follow as `NAME` (one component) or `NAME_x NAME_y NAME_z`,
// except LAMMPS's own names: force -> fx fy fz, torque -> tqx tqy tqz, image -> ix iy iz.
// The reader takes these frames back (any column order; id, x y z and radius or diameter required;
// columns it does not know become arrays), strict: InputError "FILE:LINE: problem".
#include <filesystem>
#include <span>
#include <vector>

#include "core/io/particle_data.hpp"

namespace polydem::io {

/// Write `frames` as one multi-frame dump, atomically. Throws ConfigError if a frame's arrays disagree
/// in size, InputError if the file cannot be written.
void writeLammpsDump(const std::filesystem::path& file, std::span<const ParticleData> frames);

/// Read every frame of a dump (format above). Throws InputError "FILE:LINE: problem".
std::vector<ParticleData> readLammpsDump(const std::filesystem::path& file);

/// True for names ending in .dump or .lammpstrj, or starting with "dump.".
bool isLammpsDumpPath(const std::filesystem::path& file);

}  // namespace polydem::io
