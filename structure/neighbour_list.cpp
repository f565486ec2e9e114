// Distance-cutoff neighbours (reference shells for tests) and input validation shared by the structure
// analyses. The Delaunay neighbours live in delaunay_neighbours.cpp (CGAL).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/errors.hpp"
#include "polydem/config.hpp"
#include "structure/delaunay_neighbours.hpp"

namespace polydem::structure {

void requireValidSpheres(const SphereView& spheres, const char* what) {
  const Index n = spheres.count();
  if (spheres.centre.cols() != n) {
    throw ConfigError(fmt::format("{}: {} centres but {} radii", what, spheres.centre.cols(), n));
  }
  for (Index i = 0; i < n; ++i) {
    if (!spheres.centre.col(i).allFinite()) {
      throw ConfigError(fmt::format("{}: particle {} has a non-finite centre", what, i));
    }
    const double r = spheres.radius[i];
    if (!(r > 0.0) || !std::isfinite(r)) {
      throw ConfigError(fmt::format("{}: particle {} has radius {}, expected a finite value > 0", what, i, r));
    }
  }
}

NeighbourList cutoffNeighbours(const SphereView& spheres, const Box& box, double cutoff) {
  requireValidSpheres(spheres, "cutoffNeighbours");
  if (!(cutoff > 0.0) || !std::isfinite(cutoff)) {
    throw ConfigError(fmt::format("cutoffNeighbours: cutoff must be finite and > 0, got {}", cutoff));
  }
  for (int k = 0; k < 3; ++k) {
    if (box.periodic(k) && !(cutoff < 0.5 * box.length(k))) {
      throw ConfigError(fmt::format(
          "cutoffNeighbours: cutoff {} is not below half the periodic box length {} along axis {}: the minimum "
          "image would miss neighbours; use a larger box",
          cutoff, box.length(k), "xyz"[k]));
    }
  }
  const Index n = spheres.count();
  NeighbourList out;
  out.start.assign(static_cast<std::size_t>(n) + 1, 0);
  std::vector<Eigen::Vector3d> vectors;
  const double c2 = cutoff * cutoff;
  for (Index i = 0; i < n; ++i) {
    for (Index j = 0; j < n; ++j) {
      if (j == i) continue;
      const Eigen::Vector3d d = box.minimumImageAny(spheres.centre.col(j) - spheres.centre.col(i));
      if (d.squaredNorm() <= c2) {
        out.neighbour.push_back(j);
        vectors.push_back(d);
      }
    }
    out.start[i + 1] = static_cast<Index>(out.neighbour.size());
  }
  out.displacement.resize(3, static_cast<Eigen::Index>(vectors.size()));
  for (std::size_t k = 0; k < vectors.size(); ++k) out.displacement.col(static_cast<Eigen::Index>(k)) = vectors[k];
  out.attempts = 1;
  return out;
}

#if !POLYDEM_WITH_CGAL
NeighbourList delaunayNeighbours(const SphereView&, const Box&, const NeighbourOptions&) {
  throw ConfigError(
      "delaunayNeighbours: polydem was built without CGAL (POLYDEM_WITH_CGAL=OFF); reconfigure "
      "with -DPOLYDEM_WITH_CGAL=ON for Delaunay neighbours");
}
#endif

}  // namespace polydem::structure
