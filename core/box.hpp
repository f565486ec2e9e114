#pragma once
// Simulation box [0, Lx) x [0, Ly) x [0, Lz). Each axis is periodic or bounded by two hard walls.
#include <Eigen/Core>
#include <array>
#include <string>

namespace polydem {

enum class Boundary { Periodic, Wall };

class Box {
 public:
  /// Unit cube, periodic on every axis.
  Box();
  /// Rectangular box with the given edge lengths (m) and per-axis boundaries. Throws ConfigError for
  /// non-positive or non-finite lengths.
  Box(const Eigen::Vector3d& lengths, const std::array<Boundary, 3>& boundaries);
  /// Cube of edge `length` with the same boundary on every axis.
  static Box cubic(double length, Boundary boundary);

  const Eigen::Vector3d& lengths() const { return lengths_; }
  double length(int axis) const { return lengths_[axis]; }
  Boundary boundary(int axis) const { return boundaries_[axis]; }
  bool periodic(int axis) const { return boundaries_[axis] == Boundary::Periodic; }
  bool fullyPeriodic() const { return periodic(0) && periodic(1) && periodic(2); }
  bool hasWalls() const { return !fullyPeriodic(); }
  double volume() const { return lengths_.prod(); }

  /// Minimum-image displacement for a difference of two positions inside the box (|d_k| < L_k on
  /// periodic axes). Odd: minimumImage(-d) == -minimumImage(d) exactly, so pair tests are symmetric.
  Eigen::Vector3d minimumImage(Eigen::Vector3d d) const {
    for (int k = 0; k < 3; ++k) {
      if (!periodic(k)) continue;
      if (d[k] > halfLengths_[k]) {
        d[k] -= lengths_[k];
      } else if (d[k] < -halfLengths_[k]) {
        d[k] += lengths_[k];
      }
    }
    return d;
  }

  /// Minimum image of an arbitrary displacement (any magnitude), by rounding.
  Eigen::Vector3d minimumImageAny(Eigen::Vector3d d) const;

  /// Map a position into [0, L) along periodic axes; walled axes are left alone.
  Eigen::Vector3d wrap(Eigen::Vector3d x) const;

  /// True when x lies in the primary cell: [0, L_k) on periodic axes, [0, L_k] on walled axes.
  bool contains(const Eigen::Vector3d& x) const;

  /// "periodic 10 x 10 x 10" or "walls(x,y) periodic(z) 4 x 4 x 8" for messages and reports.
  std::string describe() const;

  bool operator==(const Box& other) const { return lengths_ == other.lengths_ && boundaries_ == other.boundaries_; }

 private:
  Eigen::Vector3d lengths_;
  Eigen::Vector3d halfLengths_;
  std::array<Boundary, 3> boundaries_;
};

}  // namespace polydem
