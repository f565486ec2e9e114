#pragma once
// The in-memory record of one configuration as stored in a particle file (ParticleData), shared by the
// formats below it: plain text (core/io/text_particles.hpp) and HDF5 snapshots (core/io/hdf5_snapshot.hpp).
// core/io/particle_io.hpp picks the format from the file extension.
#include <Eigen/Core>
#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/box.hpp"
#include "core/types.hpp"

namespace polydem::io {

/// An optional per-particle output array (force, contact count, ...): `values` is components x N with
/// 1 or 3 components. HDF5 snapshots store it as /particles/NAME, LAMMPS dumps as extra columns; the
/// text format does not hold it.
struct ParticleArray {
  std::string name;
  Eigen::MatrixXd values;
};

/// One configuration as stored in a file. Positions, velocities and radii in SI units.
struct ParticleData {
  Box box;
  Eigen::Matrix3Xd position;                        ///< 3 x N
  Eigen::VectorXd radius;                           ///< N
  std::optional<Eigen::Matrix3Xd> velocity;         ///< 3 x N; present if the file had velocities
  std::optional<Eigen::Matrix3Xd> angularVelocity;  ///< 3 x N, rad/s; present if the file had them
  std::vector<Index> id;                            ///< N, unique, >= 0
  double time = 0.0;                                ///< s
  std::map<std::string, std::string> attributes;    ///< scene parameters, free-form key -> value
  std::vector<ParticleArray> arrays;                ///< optional output arrays, in the order written

  Index count() const { return static_cast<Index>(radius.size()); }
};

inline constexpr std::array<Boundary, 3> kAllPeriodic = {Boundary::Periodic, Boundary::Periodic, Boundary::Periodic};

/// Throw ConfigError unless position, velocity and angularVelocity (3 x N, if present), id (N) and every
/// array (1 or 3 x N, a unique non-empty name of letters, digits and '_') match radius (N).
/// Writers call it; the values themselves are not checked (a blown-up state may still be worth saving).
void requireConsistentSizes(const ParticleData& data);

}  // namespace polydem::io
