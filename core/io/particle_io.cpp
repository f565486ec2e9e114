// Particle files by extension, see particle_io.hpp.
#include "core/io/particle_io.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <string>

#include "core/errors.hpp"
#include "core/io/hdf5_snapshot.hpp"
#include "core/io/lammps_data.hpp"
#include "core/io/lammps_dump.hpp"
#include "core/io/text_particles.hpp"

namespace polydem::io {

bool isHdf5Path(const std::filesystem::path& file) {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext == ".h5" || ext == ".hdf5";
}

bool isTextPath(const std::filesystem::path& file) {
  return !isHdf5Path(file) && !isLammpsDataPath(file) && !isLammpsDumpPath(file);
}

ParticleData readParticles(const std::filesystem::path& file, std::array<Boundary, 3> defaultBoundaries) {
  if (isHdf5Path(file)) return readSnapshot(file);
  if (isLammpsDataPath(file)) return readLammpsData(file, defaultBoundaries);
  if (isLammpsDumpPath(file)) {
    std::vector<ParticleData> frames = readLammpsDump(file);
    if (frames.size() != 1) {
      throw InputError(
          fmt::format("{}: a LAMMPS dump of {} frames; a particle file is one configuration: take one "
                      "with `polydem convert {} ONE.h5 --frame K`",
                      file.string(), frames.size(), file.string()));
    }
    return std::move(frames.front());
  }
  return readText(file, defaultBoundaries);
}

void writeParticles(const std::filesystem::path& file, const ParticleData& data) {
  if (isHdf5Path(file)) {
    writeSnapshot(file, data);
  } else if (isLammpsDataPath(file)) {
    writeLammpsData(file, data);
  } else if (isLammpsDumpPath(file)) {
    writeLammpsDump(file, std::span<const ParticleData>(&data, 1));
  } else {
    writeText(file, data);
  }
}

}  // namespace polydem::io
