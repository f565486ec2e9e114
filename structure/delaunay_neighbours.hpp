#pragma once
// Neighbour lists for structure analysis: the edges of the weighted Delaunay (regular) triangulation of
// the centres with weights r^2 (the power / Laguerre tessellation's face neighbours), each neighbour
// with the explicit vector to the image that is the neighbour (Ogarko's thesis §3.3.3, §4.2: "the
// neighbours are the edges of the weighted Delaunay triangulation; periodicity by replicating the box").
//
// Periodic axes: instead of replicating the whole box 27 times, only images within a shell of thickness
// t outside the periodic faces are triangulated (O(N) for t of a few spacings). The shell is verified:
// a cell with an original vertex is a cell of the infinite periodic triangulation when no point outside
// the replicated region can have negative power with respect to its orthosphere (centre z, power
// radius rho^2), i.e. when every periodic face of the region is at least sqrt(rho^2 + r_max^2) from z.
// If some cell fails, t doubles and the triangulation is redone (dilute gases need a few spacings).
// Walled axes get no images. Points hidden by larger overlapping spheres (power cell empty) have no
// neighbours; packings without overlaps have none.
#include <Eigen/Core>
#include <vector>

#include "core/box.hpp"
#include "core/particle_store.hpp"
#include "core/types.hpp"

namespace polydem::structure {

/// Neighbours as CSR rows: particle i's neighbours are entries start[i] .. start[i + 1] - 1, sorted by
/// (neighbour, displacement); `displacement` is x_j' - x_i for the image j' of j that is the neighbour
/// (so a small periodic box can list the same j twice, for two images).
struct NeighbourList {
  std::vector<Index> start;       ///< N + 1 offsets
  std::vector<Index> neighbour;   ///< particle index j per entry
  Eigen::Matrix3Xd displacement;  ///< 3 x entries, m
  double imageShell = 0.0;        ///< shell thickness used (m); 0 without periodic axes
  int attempts = 0;               ///< triangulations built (shell doublings + 1)
  Index unverifiedCells = 0;      ///< cells whose orthosphere reached beyond the shell when giving up
  Index hidden = 0;               ///< particles without a power cell (overlapped by larger ones)

  Index count() const { return start.empty() ? 0 : static_cast<Index>(start.size()) - 1; }
  Index degree(Index i) const { return start[i + 1] - start[i]; }
  Index entries() const { return static_cast<Index>(neighbour.size()); }
  /// Mean number of neighbours per particle.
  double meanDegree() const { return count() ? double(entries()) / count() : 0.0; }
};

struct NeighbourOptions {
  double imageShell = 0.0;  ///< initial shell thickness (m); 0 = 2 (V/N)^(1/3) + 2 r_max
};

/// Weighted Delaunay neighbours (weights r^2), periodic axes by a verified shell of images (see top).
/// Expected O(N log N) (CGAL Regular_triangulation_3, exact predicates). Throws ConfigError for
/// non-finite centres, non-positive radii, or when built without CGAL.
NeighbourList delaunayNeighbours(const SphereView& spheres, const Box& box, const NeighbourOptions& options = {});

/// Every j with minimum-image centre distance <= cutoff (m), each once, via the minimum image (needs
/// cutoff < L / 2 on periodic axes, else ConfigError). O(N^2): reference neighbour shells for tests
/// and small lattices (e.g. the 12 nearest neighbours of FCC that the literature q6 values assume).
NeighbourList cutoffNeighbours(const SphereView& spheres, const Box& box, double cutoff);

/// Throw ConfigError naming the first particle with a non-finite centre or a non-positive / non-finite radius.
void requireValidSpheres(const SphereView& spheres, const char* what);

}  // namespace polydem::structure
