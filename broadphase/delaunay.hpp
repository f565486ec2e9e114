#pragma once
// Regular (weighted Delaunay) triangulation broad phase on CGAL.
//
// Points are the centres with weights R^2, R = r + skin / 2 (plus a round-off margin), so two balls
// of radius R intersect exactly when the spheres are within the skin. Why edges plus a walk suffice:
// if balls B_i and B_j intersect, take z on the segment between the centres where the power
// distances to i and j agree (pi(z) <= 0). Walking from j towards z through power cells, the power
// distance of z strictly decreases cell by cell (it changes by -2 (q - z).(s' - s) at each facet),
// so every vertex on that walk has a ball containing z, hence intersecting B_i; likewise from i. So
// the vertices whose balls meet B_i form a connected subgraph of the triangulation containing i:
// a breadth-first walk from i that only expands through vertices whose ball meets B_i finds every
// neighbour, output-sensitively (no bound with the largest radius needed).
//
// Hidden points (power cell empty, e.g. a small sphere deep inside a large one) are not vertices.
// They are triangulated again in a second layer, whose hidden points go to a third, and so on. For a
// point h hidden in layer b, the balls of layer b meeting B_h are again connected (along any segment
// inside B_h the owner of each point has a ball containing it), starting at nearest_power_vertex(x_h).
// So within-layer pairs come from the walk and cross-layer pairs from the walk of the point in the
// higher layer over every lower layer. Exact; the property suite checks it.
//
// Periodic axes: explicit images of every point within R + R_max of a periodic face (CGAL's
// Periodic_3_regular_triangulation_3 needs a cubic box and weights below a fraction of it; images work
// for any box). Walks start from originals (and from hidden images, which may own a cross-layer pair).
//
// update(): a moved vertex whose surrounding cells stay positively oriented and locally regular is
// relocated in place (filtered relocation); otherwise CGAL's move() (remove + insert). Images move
// with their particle, or are removed and reinserted when it enters or leaves a face layer. Only the
// moved particles' rows of the pair list are recomputed. If some point is hidden (removing a vertex
// could expose it), a move would hide one, or more than a fifth of the particles moved
// (setMaxMovedFraction), it rebuilds instead.
// The weighted Delaunay family of broad phases: Krijgsman, Ogarko & Luding, Comp. Part. Mech. 1 (2014) 357
// (Ogarko's thesis §2.2.1); periodicity by replicating the box: Ogarko & Luding, Soft Matter 9 (2013) 9530
// (thesis §3.3.3).
#include <memory>
#include <vector>

#include "broadphase/broad_phase.hpp"
#include "broadphase/pair_table.hpp"

namespace polydem::broadphase {

class Delaunay final : public BroadPhase {
 public:
  Delaunay();
  ~Delaunay() override;
  Delaunay(Delaunay&&) noexcept;
  Delaunay& operator=(Delaunay&&) noexcept;

  std::string_view name() const override { return "delaunay"; }
  Capabilities capabilities() const override { return {.complete = true, .incremental = true}; }
  void findPairs(const SphereView& spheres, std::vector<Pair>& out) const override;
  void findNeighbours(const SphereView& spheres, Index i, double reach, std::vector<Index>& out) const override;
  std::size_t memoryBytes() const override;
  std::string describe() const override;

  struct Stats {
    Index points = 0;           ///< triangulated points: particles plus periodic images
    Index images = 0;           ///< periodic images among them
    int layers = 0;             ///< triangulations (1 + levels of hidden points)
    Index hidden = 0;           ///< points hidden in the first layer
    std::size_t visits = 0;     ///< vertices examined by the walks of the last build/update
    std::size_t moves = 0;      ///< incremental updates (no rebuild)
    std::size_t inPlace = 0;    ///< vertices relocated without combinatorial change (filter passed)
    std::size_t cgalMoves = 0;  ///< vertices moved with CGAL's move()
    std::size_t rebuilds = 0;   ///< updates that fell back to a rebuild
  };
  const Stats& stats() const { return stats_; }
  /// update() moves vertices while at most this fraction of the particles moved, else rebuilds
  /// (default 0.2, about the measured break-even: an incremental move costs ~5 rebuilds per
  /// particle; 1 forces incremental updates whenever possible, for benchmarks).
  void setMaxMovedFraction(double fraction) { maxMovedFraction_ = fraction; }
  /// Check every triangulation with CGAL's is_valid() and the vertex bookkeeping (tests; slow).
  bool validate() const;

 protected:
  void doBuild(const SphereView& spheres) override;
  void doUpdate(const SphereView& spheres, std::span<const Index> moved) override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  PairTable table_;
  Stats stats_;
  double maxMovedFraction_ = 0.2;
};

}  // namespace polydem::broadphase
