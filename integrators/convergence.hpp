#pragma once
// Convergence sweeps (`polydem relax --sweep dt-factor=... | skin=...`): the same start run with several
// time steps or skins over the same simulated time, each compared with a reference.
//
// The error rule: a dissipation-free scene (DemSettings::dissipationFree) conserves energy, so its
// energy error is the relative drift of the run itself, |E_end - E_0| / |E_0|; any other scene is
// compared with the reference run (the finest time step), |E_end - E_end,ref| / |E_0,ref|. The position
// error is the largest minimum-image distance between the run's and the reference's final centres, in
// units of the smallest radius. Velocity Verlet is second order, so the energy error of a
// dissipation-free run falls as dt^2 (Allen & Tildesley, Computer Simulation of Liquids, 2nd ed.,
// Oxford 2017, ch. 3).
#include <Eigen/Core>
#include <cstdint>
#include <optional>

#include "core/box.hpp"

namespace polydem::integrators {

/// Steps at `stepsPerContact` (dt = t_c,min / f) that cover the simulated time of `steps` steps at
/// `baseStepsPerContact`, rounded to the nearest integer.
std::int64_t stepsForSameTime(std::int64_t steps, double baseStepsPerContact, double stepsPerContact);

/// The end of one run of a sweep: its total energies (J) and the final centres in id order (3 x N).
struct RunEnd {
  double initialEnergy = 0.0;
  double finalEnergy = 0.0;
  Eigen::Ref<const Eigen::Matrix3Xd> positions;
};

struct ConvergenceError {
  /// Relative energy error; nullopt when the energy scale is 0 and the energies differ (undefined).
  std::optional<double> energy;
  double position = 0.0;  ///< largest |x - x_ref| / minRadius (minimum image on periodic axes)
};

/// The error of `run` against `reference` by the rule above. `run` and `reference` hold the same
/// particles (same count, same id order). O(N).
ConvergenceError convergenceError(const RunEnd& run, const RunEnd& reference, bool dissipationFree, const Box& box,
                                  double minRadius);

}  // namespace polydem::integrators
