#pragma once
// Which rank owns which part of the box (docs/parallel.md). Two kinds, each giving every rank an axis-aligned
// region and an owner by position (decided at neighbour-list builds only):
//
// - Brick grid: P = px * py * pz equal slabs per axis, rank = cx + px (cy + py cz), the factorisation with the
//   least cut area (a periodic axis cut into p slabs has p interfaces, a walled one p - 1).
// - Recursive coordinate bisection (Berger & Bokhari, IEEE Trans. Comput. 36 (1987) 570): the ranks [a, b) of a
//   region split into halves k = (b - a) / 2 and b - a - k; the region is cut across its longest edge where the
//   weight below the cut is k / (b - a) of the region's (bisection on the cut coordinate, 60 halvings). The
//   weight comes from a callback, a global sum, so every rank builds the same tree.
//
// Nothing here depends on MPI. The decomposition never changes a result (docs/parallel.md): only who computes.
#include <algorithm>
#include <array>
#include <functional>
#include <string>
#include <vector>

#include "core/box.hpp"

namespace polydem::parallel {

enum class DecompositionKind { Brick, Bisection };

/// Distance from coordinate x (in [0, L]) to the interval [lo, hi] of an axis of length L, through the periodic
/// image when `periodic`.
inline double intervalDistance(double x, double lo, double hi, double L, bool periodic) {
  if (x < lo) {
    const double d = lo - x;
    return periodic ? std::min(d, x + L - hi) : d;
  }
  if (x > hi) {
    const double d = x - hi;
    return periodic ? std::min(d, L - x + lo) : d;
  }
  return 0.0;
}

/// An axis-aligned part of the box: lo <= x < hi per axis (x <= hi where hi is the box's upper face).
struct Region {
  std::array<double, 3> lo = {0.0, 0.0, 0.0}, hi = {0.0, 0.0, 0.0};
};

class Decomposition {
 public:
  /// Total weight of the particles inside `region` with x[axis] < cut (every particle of the region for
  /// cut = +inf). Must return the same value on every rank.
  using WeightBelow = std::function<double(const Region& region, int axis, double cut)>;

  /// The brick grid of `ranks` >= 1 over `box`.
  static Decomposition brick(const Box& box, int ranks);
  /// Recursive coordinate bisection of `box` into `ranks` >= 1 regions of equal weight. O(ranks * 60) calls.
  static Decomposition bisection(const Box& box, int ranks, const WeightBelow& weightBelow);

  DecompositionKind kind() const { return kind_; }
  int ranks() const { return static_cast<int>(regions_.size()); }
  /// The rank whose region holds x (inside the box; non-finite coordinates go to a valid rank).
  int owner(const double* x) const;
  const Region& region(int rank) const { return regions_[static_cast<std::size_t>(rank)]; }
  /// Squared distance from x (inside the box) to `rank`'s region, through the periodic images. O(1).
  double distanceSquared(const double* x, int rank) const;
  /// "brick grid 2 x 2 x 1" or "recursive coordinate bisection".
  std::string describe() const;

 private:
  struct Node {
    int axis = 0;      ///< leaf: -1
    double cut = 0.0;  ///< x[axis] < cut: left child
    int left = -1, right = -1;
    int rank = -1;  ///< leaf: the rank
  };
  int build(const Region& region, int a, int b, const WeightBelow& weightBelow);

  Box box_;
  DecompositionKind kind_ = DecompositionKind::Brick;
  std::array<int, 3> dims_ = {1, 1, 1};  ///< brick grid
  std::vector<Node> nodes_;              ///< bisection tree, root first
  std::vector<Region> regions_;
};

}  // namespace polydem::parallel
