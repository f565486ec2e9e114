#pragma once
// Particle data <-> the dict form of a particle file (io.cpp), shared by the binding files.
#include "core/io/particle_data.hpp"
#include "python/convert.hpp"

namespace polydem::python {

/// positions (N, 3), radii, id, velocities / angular_velocities (or None), box, time, attributes (copies).
py::dict particleDict(const io::ParticleData& data);
/// The inverse; positions, radii and box required, id defaults to 0..N-1. Throws ConfigError naming the key.
io::ParticleData particleData(const py::dict& d);
/// A particle dict, or a file name read as `polydem analyze FILE` reads it (GIL released); `name` receives
/// "packing" or the file name, for messages.
io::ParticleData particlesFrom(const py::object& packing, std::string& name);

}  // namespace polydem::python
