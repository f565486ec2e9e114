#pragma once
// Particle files by extension: .h5/.hdf5 (any case) are HDF5 snapshots (core/io/hdf5_snapshot.hpp),
// anything else is the text format (core/io/text_particles.hpp). Both carry one ParticleData.
#include <array>
#include <filesystem>

#include "core/io/particle_data.hpp"

namespace polydem::io {

/// Read by extension: .h5/.hdf5 (any case) -> readSnapshot(), anything else -> readText().
/// `defaultBoundaries` only matters for text files (snapshots always store their boundaries).
ParticleData readParticles(const std::filesystem::path& file, std::array<Boundary, 3> defaultBoundaries = kAllPeriodic);

/// Write by extension: .h5/.hdf5 (any case) -> writeSnapshot() (plus XDMF sidecar), else writeText().
void writeParticles(const std::filesystem::path& file, const ParticleData& data);

/// True for .h5/.hdf5 (any case): the extensions readParticles()/writeParticles() treat as HDF5.
bool isHdf5Path(const std::filesystem::path& file);

}  // namespace polydem::io
