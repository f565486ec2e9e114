#include "parallel/decomposition.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/errors.hpp"

namespace polydem::parallel {

Decomposition Decomposition::brick(const Box& box, int ranks) {
  if (ranks < 1) throw ConfigError(fmt::format("decomposition: {} ranks", ranks));
  Decomposition d;
  d.box_ = box;
  d.kind_ = DecompositionKind::Brick;
  const Eigen::Vector3d& L = box.lengths();
  double best = std::numeric_limits<double>::infinity();
  for (int px = 1; px <= ranks; ++px) {
    if (ranks % px != 0) continue;
    for (int py = 1; py <= ranks / px; ++py) {
      if ((ranks / px) % py != 0) continue;
      const std::array<int, 3> p = {px, py, ranks / px / py};
      double area = 0.0;
      for (int k = 0; k < 3; ++k) {
        const int cuts = p[k] == 1 ? 0 : (box.periodic(k) ? p[k] : p[k] - 1);
        area += cuts * L[(k + 1) % 3] * L[(k + 2) % 3];
      }
      // Ties (a cube into 8: 2 x 2 x 2 or 1 x 2 x 4) go to the most even split, then to the first found.
      const int spread = std::max({p[0], p[1], p[2]});
      const bool tie = std::isfinite(best) && std::abs(area - best) <= 1e-12 * best;
      if ((area < best && !tie) || (tie && spread < std::max({d.dims_[0], d.dims_[1], d.dims_[2]}))) {
        best = area;
        d.dims_ = p;
      }
    }
  }
  d.regions_.resize(static_cast<std::size_t>(ranks));
  for (int q = 0; q < ranks; ++q) {
    const int c[3] = {q % d.dims_[0], (q / d.dims_[0]) % d.dims_[1], q / (d.dims_[0] * d.dims_[1])};
    Region& r = d.regions_[static_cast<std::size_t>(q)];
    for (int k = 0; k < 3; ++k) {
      r.lo[k] = L[k] * c[k] / d.dims_[k];
      r.hi[k] = L[k] * (c[k] + 1) / d.dims_[k];
    }
  }
  return d;
}

Decomposition Decomposition::bisection(const Box& box, int ranks, const WeightBelow& weightBelow) {
  if (ranks < 1) throw ConfigError(fmt::format("decomposition: {} ranks", ranks));
  Decomposition d;
  d.box_ = box;
  d.kind_ = DecompositionKind::Bisection;
  d.regions_.resize(static_cast<std::size_t>(ranks));
  Region all;
  for (int k = 0; k < 3; ++k) all.hi[k] = box.length(k);
  d.build(all, 0, ranks, weightBelow);
  return d;
}

int Decomposition::build(const Region& region, int a, int b, const WeightBelow& weightBelow) {
  const int index = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  if (b - a == 1) {
    nodes_[static_cast<std::size_t>(index)].axis = -1;
    nodes_[static_cast<std::size_t>(index)].rank = a;
    regions_[static_cast<std::size_t>(a)] = region;
    return index;
  }
  const int k = (b - a) / 2;
  int axis = 0;
  for (int c = 1; c < 3; ++c) {
    if (region.hi[c] - region.lo[c] > region.hi[axis] - region.lo[axis]) axis = c;
  }
  const double total = weightBelow(region, axis, std::numeric_limits<double>::infinity());
  const double target = total * static_cast<double>(k) / static_cast<double>(b - a);
  double lo = region.lo[axis], hi = region.hi[axis];
  double cut = 0.5 * (lo + hi);
  if (total > 0.0) {
    for (int it = 0; it < 60; ++it) {
      const double mid = 0.5 * (lo + hi);
      if (weightBelow(region, axis, mid) < target) {
        lo = mid;
      } else {
        hi = mid;
      }
    }
    cut = hi;
  }
  Region left = region, right = region;
  left.hi[axis] = cut;
  right.lo[axis] = cut;
  nodes_[static_cast<std::size_t>(index)].axis = axis;
  nodes_[static_cast<std::size_t>(index)].cut = cut;
  const int l = build(left, a, a + k, weightBelow);
  const int r = build(right, a + k, b, weightBelow);
  nodes_[static_cast<std::size_t>(index)].left = l;
  nodes_[static_cast<std::size_t>(index)].right = r;
  return index;
}

int Decomposition::owner(const double* x) const {
  if (kind_ == DecompositionKind::Brick) {
    int c[3];
    for (int k = 0; k < 3; ++k) {
      const double u = x[k] / box_.length(k) * dims_[k];
      const int ck = std::isfinite(u) ? static_cast<int>(std::clamp(std::floor(u), 0.0, dims_[k] - 1.0)) : 0;
      c[k] = ck;
    }
    return c[0] + dims_[0] * (c[1] + dims_[1] * c[2]);
  }
  int n = 0;
  while (nodes_[static_cast<std::size_t>(n)].axis >= 0) {
    const Node& node = nodes_[static_cast<std::size_t>(n)];
    n = x[node.axis] < node.cut ? node.left : node.right;
  }
  return nodes_[static_cast<std::size_t>(n)].rank;
}

double Decomposition::distanceSquared(const double* x, int rank) const {
  const Region& r = regions_[static_cast<std::size_t>(rank)];
  double dsq = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double lo = r.lo[k], hi = r.hi[k], L = box_.length(k);
    if (lo <= 0.0 && hi >= L) continue;  // the region spans the axis
    const double d = intervalDistance(x[k], lo, hi, L, box_.periodic(k));
    dsq += d * d;
  }
  return dsq;
}

std::string Decomposition::describe() const {
  if (kind_ == DecompositionKind::Brick) return fmt::format("brick grid {} x {} x {}", dims_[0], dims_[1], dims_[2]);
  return "recursive coordinate bisection";
}

}  // namespace polydem::parallel
