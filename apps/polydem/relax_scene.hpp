#pragma once
// Scene files for `polydem relax` (TOML). Every key is documented in examples/relax_uv10.toml. Reading
// is strict: unknown sections or keys, missing required keys, wrong types and out-of-range values are
// ConfigErrors naming the key ("run.dt_factor must be >= 5, got 2").
//
//   [particles]  file = "x.txt" | count, distribution, rmin, omega, alpha, sigma, median,
//                large_fraction, fraction_kind, sampling, packing_fraction, seed; density
//   [box]        boundaries = "periodic" | "walls" | "periodic,periodic,wall"; aspect = [1, 1, 1]
//   [contact]    law, stiffness, stiffness_scaling, damping, restitution, gamma_n, friction,
//                tangential_stiffness_ratio, tangential_damping_ratio, reference_velocity
//   [velocities] initial = "impact" | "file" | "zero"; overlap = 0.01; seed
//   [compression] packing_fraction, growth_rate, damping, max_overlap, max_steps   (optional)
//   [run]        steps, dt_factor, dt, allow_unstable_dt, skin, broadphase, gravity, viscous_damping,
//                dashpot_velocity, check_interval, max_overlap_fraction, energy_tolerance, kernel, spatial_sort,
//                threads, progress_interval
//   [output]     snapshot, snapshot_interval, timeseries, timeseries_interval, final, arrays, contacts,
//                checkpoint, checkpoint_interval, checkpoint_seconds
//
// defaultSceneToml() prints every key with the default the reader uses (`polydem relax --print-defaults`);
// tests/apps/relax_scene_test.cpp checks that examples/relax_uv10.toml states the same defaults.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/size_distribution.hpp"
#include "integrators/dem_simulation.hpp"
#include "integrators/soft_compression.hpp"

namespace polydem::app {

/// Defaults of the scene reader that have no home in a library struct (the others come from
/// DistributionSpec, ContactParameters, DemSettings, CompressionSettings).
inline constexpr const char* kDefaultBroadPhase = "auto";  ///< the cost model picks the backend
inline constexpr std::int64_t kDefaultSnapshotInterval = 1000;
inline constexpr double kDefaultCheckpointSeconds = 600.0;

struct RelaxScene {
  std::filesystem::path source;  ///< the scene file (relative paths in it are relative to its folder)
  // particles
  std::string particleFile;  ///< empty: generate
  Index count = 0;
  DistributionSpec distribution;
  std::string sampling = "systematic";
  double packingFraction = 0.3;
  std::uint64_t seed = 1;
  double density = 1.0;
  // box
  std::array<Boundary, 3> boundaries = {Boundary::Periodic, Boundary::Periodic, Boundary::Periodic};
  bool boundariesGiven = false;  ///< box.boundaries was in the scene (a particle file must then agree)
  Eigen::Vector3d aspect = Eigen::Vector3d::Ones();
  // velocities
  std::string initialVelocities = "impact";  ///< impact (1% rule) | file | zero
  double impactOverlap = 0.01;
  std::uint64_t velocitySeed = 1;
  // compression
  std::optional<integrators::CompressionSettings> compression;
  // run
  integrators::DemSettings dem;
  std::int64_t steps = 0;
  double progressInterval = 5.0;  ///< seconds between progress lines; 0 = none
  // output
  std::string snapshot;                                      ///< path pattern with {step}; empty = none
  std::int64_t snapshotInterval = kDefaultSnapshotInterval;  ///< 0 = only at the end
  std::string timeseries;                                    ///< CSV path; empty = none
  std::int64_t timeseriesInterval = 100;
  std::string finalState;                                ///< particle file; empty = none
  std::vector<std::string> snapshotArrays;               ///< optional snapshot arrays (kSnapshotArrays)
  bool contacts = false;                                 ///< a contact file beside every snapshot
  std::string checkpoint;                                ///< HDF5 checkpoint file (relax --resume); empty = none
  std::int64_t checkpointInterval = 0;                   ///< steps between checkpoints; 0 = none by steps
  double checkpointSeconds = kDefaultCheckpointSeconds;  ///< wall-clock seconds between checkpoints; 0 = none

  /// Resolve a path from the scene file relative to the scene's folder.
  std::filesystem::path resolve(const std::string& path) const;
};

/// Read a scene file, then apply `overrides` ("section.key=value", value parsed as TOML, bare words as
/// strings) before validation. Throws ConfigError (bad content) or InputError (unreadable, TOML syntax
/// errors with line and column).
RelaxScene loadRelaxScene(const std::filesystem::path& file, const std::vector<std::string>& overrides = {});

/// Every key with its real default, as a valid TOML scene (required keys get an example value and say
/// so; the optional [compression] section is commented out). `polydem relax --print-defaults`.
std::string defaultSceneToml();

/// Same from TOML text (tests).
RelaxScene parseRelaxScene(const std::string& text, const std::vector<std::string>& overrides = {},
                           const std::filesystem::path& source = "scene.toml");

}  // namespace polydem::app
