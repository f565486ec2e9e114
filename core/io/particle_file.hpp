#pragma once
// Particle files, the header callers include: the record of one configuration (particle_data.hpp), the
// text format (text_particles.hpp) and the by-extension dispatch readParticles()/writeParticles()
// (particle_io.hpp). HDF5 snapshots themselves are in hdf5_snapshot.hpp.
#include "core/io/particle_data.hpp"
#include "core/io/particle_io.hpp"
#include "core/io/text_particles.hpp"
