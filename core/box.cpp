#include "core/box.hpp"

#include <fmt/format.h>

#include <cmath>

#include "core/errors.hpp"

namespace polydem {

Box::Box() : Box(Eigen::Vector3d::Ones(), {Boundary::Periodic, Boundary::Periodic, Boundary::Periodic}) {}

Box::Box(const Eigen::Vector3d& lengths, const std::array<Boundary, 3>& boundaries)
    : lengths_(lengths), halfLengths_(0.5 * lengths), boundaries_(boundaries) {
  constexpr const char* kAxis = "xyz";
  for (int k = 0; k < 3; ++k) {
    if (!(std::isfinite(lengths[k]) && lengths[k] > 0.0)) {
      throw ConfigError(
          fmt::format("box length along {} must be a positive finite number, got {}", kAxis[k], lengths[k]));
    }
  }
}

Box Box::cubic(double length, Boundary boundary) {
  return Box(Eigen::Vector3d::Constant(length), {boundary, boundary, boundary});
}

Eigen::Vector3d Box::minimumImageAny(Eigen::Vector3d d) const {
  for (int k = 0; k < 3; ++k) {
    if (periodic(k)) d[k] -= lengths_[k] * std::round(d[k] / lengths_[k]);
  }
  return d;
}

Eigen::Vector3d Box::wrap(Eigen::Vector3d x) const {
  for (int k = 0; k < 3; ++k) {
    if (!periodic(k)) continue;
    const double length = lengths_[k];
    const double folded = x[k] - length * std::floor(x[k] / length);
    if (folded >= 0.0 && folded < length) {
      x[k] = folded;  // the common case: a particle a few box lengths at most from the primary cell
      continue;
    }
    // The quick fold left [0, L): round-off of the product for a far image (x = -1e41, L = 10; where the
    // spacing of doubles near x exceeds L, any point of the cell is as good as another), x / L overflowing
    // for a tiny L, or floor(x / L) rounding up for x just below L. fmod is exact, so the remainder lies in
    // (-L, L); adding L to a tiny negative one can round to L, which folds onto 0.
    double exact = std::fmod(x[k], length);
    if (exact < 0.0) exact += length;
    x[k] = exact < length ? exact : 0.0;
  }
  return x;
}

bool Box::contains(const Eigen::Vector3d& x) const {
  for (int k = 0; k < 3; ++k) {
    if (!(x[k] >= 0.0)) return false;  // also rejects NaN
    if (periodic(k) ? !(x[k] < lengths_[k]) : !(x[k] <= lengths_[k])) return false;
  }
  return true;
}

std::string Box::describe() const {
  std::string kinds;
  if (fullyPeriodic()) {
    kinds = "periodic";
  } else if (!periodic(0) && !periodic(1) && !periodic(2)) {
    kinds = "walled";
  } else {
    std::string walls, periodicAxes;
    for (int k = 0; k < 3; ++k) (periodic(k) ? periodicAxes : walls) += "xyz"[k];
    kinds = fmt::format("walls({}) periodic({})", walls, periodicAxes);
  }
  return fmt::format("{} {:g} x {:g} x {:g}", kinds, lengths_[0], lengths_[1], lengths_[2]);
}

}  // namespace polydem
