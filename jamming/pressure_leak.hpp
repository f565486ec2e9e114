#pragma once
// The pressure-leak test for jamming (A. Donev, "Jammed Packings of Hard Particles", PhD thesis, Princeton
// University (2006), §9.3.1, Fig. 9.3): run plain event-driven dynamics (no growth) on the final packing
// for thousands of collisions per particle and watch the block-averaged reduced pressure and the
// displacement of the spheres from where they started. A jammed packing keeps its pressure and its
// backbone stays inside its jamming polytope (displacements of the order of the jamming gap); a packing
// that is not truly jammed leaks pressure slowly while its spheres drift away from the initial
// configuration. Donev used it instead of the LP test for packings jammed to delta = 1e-15 .. 1e-12 and
// N > ~1000, where his LP library was neither accurate nor large enough, and found that the two signals
// always agreed.
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/box.hpp"
#include "core/types.hpp"
#include "edmd/hard_sphere_system.hpp"
#include "jamming/contact_network.hpp"
#include "jamming/verdict.hpp"

namespace polydem::jamming {

struct LeakTestOptions {
  double collisionsPerParticle = 1e4;  ///< length of the run
  int blocks = 20;                     ///< pressure and displacements are reported per block
  /// A leak: the mean pressure of the last quarter of the blocks below that of the first quarter by more
  /// than this (relative). A jammed packing's block pressures scatter by ~1/sqrt(collisions per block).
  double pressureTolerance = 1e-3;
  /// A drift: the mean backbone displacement of the last quarter of the blocks exceeds this factor times
  /// the largest block value of the first half. Inside a jamming polytope it saturates within the first
  /// block; growth linear in time gives 1.75.
  double driftFactor = 1.5;
  std::uint64_t seed = 1;  ///< Maxwell-Boltzmann velocities, thermal speed 1
  edmd::SystemOptions system;
  std::function<void(const std::string&)> progress;  ///< one line per block
};

struct LeakBlock {
  double collisionsPerParticle = 0.0;  ///< at the end of the block, since the start
  double pressure = 0.0;               ///< reduced pressure PV / (N kT) of the block
  /// Backbone spheres, from the start, in own diameters, after subtracting the backbone's mean
  /// displacement (a rigid translation of the backbone is no unjamming motion).
  double meanDisplacement = 0.0;
  double maxDisplacement = 0.0;
  Index maxSphere = -1;
};

struct LeakTestResult {
  std::vector<LeakBlock> blocks;
  double pressureChange = 0.0;  ///< last-quarter mean / first-quarter mean - 1
  double driftRatio = 1.0;      ///< last-quarter mean displacement / largest block value of the first half
  bool leaks = false;
  /// NotTested when the test cannot apply: no spheres, nothing collided (the pressure is undefined), or
  /// no sphere watched (every sphere a rattler: a gas keeps its pressure without being jammed).
  JammingVerdict outcome = JammingVerdict::NotTested;
  std::string verdict;
  edmd::EventCounts counts;
  double seconds = 0.0;
};

/// Runs the test on the spheres (centres inside the box; `rattler` marks the spheres whose
/// displacements are not watched, e.g. ContactNetwork::rattler; empty = watch all). Throws ConfigError
/// for bad options and SimulationError from the dynamics (an overlap or a watchdog). No spheres: an empty
/// result, NotTested.
LeakTestResult testPressureLeak(const Eigen::Matrix3Xd& position, const Eigen::VectorXd& radius, const Box& box,
                                const std::vector<char>& rattler, const LeakTestOptions& options);

/// The test without sphere `removed` (a deliberate defect: the hole of a backbone sphere): the last sphere
/// takes its number, so block maxSphere indices refer to that renumbering. removed < 0: testPressureLeak
/// itself. Throws ConfigError unless removed < N.
LeakTestResult testPressureLeakWithout(const Eigen::Matrix3Xd& position, const Eigen::VectorXd& radius, const Box& box,
                                       const std::vector<char>& rattler, Index removed, const LeakTestOptions& options);

}  // namespace polydem::jamming
