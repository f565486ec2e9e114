// Particle files by extension, see particle_io.hpp.
#include "core/io/particle_io.hpp"

#include <algorithm>
#include <cctype>
#include <string>

#include "core/io/hdf5_snapshot.hpp"
#include "core/io/text_particles.hpp"

namespace polydem::io {

bool isHdf5Path(const std::filesystem::path& file) {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext == ".h5" || ext == ".hdf5";
}

ParticleData readParticles(const std::filesystem::path& file, std::array<Boundary, 3> defaultBoundaries) {
  if (isHdf5Path(file)) return readSnapshot(file);
  return readText(file, defaultBoundaries);
}

void writeParticles(const std::filesystem::path& file, const ParticleData& data) {
  if (isHdf5Path(file)) {
    writeSnapshot(file, data);
  } else {
    writeText(file, data);
  }
}

}  // namespace polydem::io
