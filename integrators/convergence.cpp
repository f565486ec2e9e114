#include "integrators/convergence.hpp"

#include <algorithm>
#include <cmath>

namespace polydem::integrators {

std::int64_t stepsForSameTime(std::int64_t steps, double baseStepsPerContact, double stepsPerContact) {
  return static_cast<std::int64_t>(std::llround(static_cast<double>(steps) * stepsPerContact / baseStepsPerContact));
}

ConvergenceError convergenceError(const RunEnd& run, const RunEnd& reference, bool dissipationFree, const Box& box,
                                  double minRadius) {
  ConvergenceError error;
  const double scale = std::abs(dissipationFree ? run.initialEnergy : reference.initialEnergy);
  const double diff = dissipationFree ? std::abs(run.finalEnergy - run.initialEnergy)
                                      : std::abs(run.finalEnergy - reference.finalEnergy);
  error.energy =
      scale > 0.0 ? std::optional<double>(diff / scale) : (diff == 0.0 ? std::optional<double>(0.0) : std::nullopt);
  for (Eigen::Index i = 0; i < run.positions.cols(); ++i) {
    error.position =
        std::max(error.position, box.minimumImageAny(run.positions.col(i) - reference.positions.col(i)).norm());
  }
  error.position /= minRadius;
  return error;
}

}  // namespace polydem::integrators
