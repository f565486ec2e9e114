#pragma once
// Particle files by extension: .h5/.hdf5 (any case) are HDF5 snapshots (core/io/hdf5_snapshot.hpp),
// .data/.lmp/data.* LAMMPS data files (core/io/lammps_data.hpp), .dump/.lammpstrj/dump.* LAMMPS dumps of
// one frame (core/io/lammps_dump.hpp), anything else is the text format (core/io/text_particles.hpp).
// Each carries one ParticleData.
#include <array>
#include <filesystem>

#include "core/io/particle_data.hpp"

namespace polydem::io {

/// Read by extension (see above); a dump must hold exactly one frame (InputError otherwise).
/// `defaultBoundaries` only matters for text files (snapshots always store their boundaries).
ParticleData readParticles(const std::filesystem::path& file, std::array<Boundary, 3> defaultBoundaries = kAllPeriodic);

/// Write by extension (see above): HDF5 with its XDMF sidecar, LAMMPS data, a one-frame dump, else text.
void writeParticles(const std::filesystem::path& file, const ParticleData& data);

/// True for names readParticles()/writeParticles() treat as the text format (not HDF5, not LAMMPS).
bool isTextPath(const std::filesystem::path& file);

/// True for .h5/.hdf5 (any case): the extensions readParticles()/writeParticles() treat as HDF5.
bool isHdf5Path(const std::filesystem::path& file);

}  // namespace polydem::io
