#pragma once
// Linear bounding-volume hierarchy (LBVH) broad phase.
//
// Spheres are sorted along a Morton (Z-order) curve of their centres and cut into leaves of
// `leafSize` consecutive spheres; the binary radix tree over the leaves' keys is built with Karras'
// per-node range/split search (Karras, "Maximizing parallelism in the construction of BVHs, octrees,
// and k-d trees", HPG 2012, Sec. 4), which is O(M log M) for M leaves here because it
// runs sequentially. Duplicate keys are disambiguated by the leaf index, as Karras does (Sec. 4).
// The tree is then laid out in depth-first pre-order (left child = next node), so a traversal walks
// memory forwards. Each node (32 bytes) stores the box of the spheres below it (centre -+ radius, not
// the centres' box dilated by the largest radius, which a single large sphere would inflate in every
// direction), in float rounded outward by a margin above the rounding error so no pair is lost;
// a box test is two 16-byte SSE compares. Pairs within reach have overlapping boxes once one of them
// is dilated by the skin, so every test is box against box (Howard et al., Comput. Phys. Commun. 203
// (2016) 45, use one tree with per-particle search radii; here the radius is in the box).
//
// findPairs: one traversal per leaf, with the leaf's box dilated by the skin, that only looks at
// leaves later in Morton order (every node knows the end of its slot range, so earlier subtrees are
// cut whole); children are tested before they are pushed on a fixed stack of depth + 2 entries. It
// collects the candidate leaves; each candidate leaf's box is then tested against the boxes of up to
// four of the querying leaf's spheres at once (one SSE compare per axis), and a sphere that meets it
// is tested against the leaf's spheres two at a time (SSE2 doubles on x, y, z, r columns in slot
// order, the scalar test's operations in its order). findNeighbours(i) is one traversal with sphere
// i's box alone.
//
// Periodic boundaries: the query is imaged (up to 27 images), never the tree, and only where the
// shifted query meets the root's box; an image whose traversal meets no later leaf is dropped. A
// leaf left with no image has no pair across a periodic face, and there the plain difference is the
// minimum image of every pair within reach (|d_k| <= 2 r_max + skin <= L_k / 2), so its pairs are
// tested by the plain difference; otherwise a sphere that meets a candidate leaf through an image
// is tested with spheresWithinReach (minimum image), and one that meets it only unshifted by the
// plain difference.
//
// update(): refit. Moved spheres' leaves and their ancestors are re-bounded (O(|moved| log M)); the
// topology is kept. Rebuild rule: the tree is rebuilt from scratch when the summed volume of the
// node boxes dilated by r_min + skin, which is V times the expected number of node visits of a
// small sphere's query (the proximity analogue of MacDonald &
// Booth's surface-area heuristic, The Visual Computer 6 (1990) 153), exceeds `rebuildFactor`
// (default 1.5) times its value right after the last build.
//
// Leaf size 4 is Howard et al.'s default and kept: by callgrind instruction counts of build + find
// (N = 30000, packing 0.3, uniform volume omega 10 and 100, bidisperse omega 10) leaves of 2 cost
// 10-16% more and leaves of 8 8-14% more (scripts/backends_report.sh takes lbvh:B to time it).
// `auto` does not consider trees: no validated model of their cost exists yet
// (docs/benchmarks/backends/README.md).
#include <cstdint>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#include <vector>

#include "broadphase/broad_phase.hpp"

namespace polydem::broadphase {

class Lbvh final : public BroadPhase {
 public:
  std::string_view name() const override { return "lbvh"; }
  Capabilities capabilities() const override { return {.complete = true, .incremental = true}; }
  void findPairs(const SphereView& spheres, std::vector<Pair>& out) const override;
  void findNeighbours(const SphereView& spheres, Index i, double reach, std::vector<Index>& out) const override;
  std::size_t memoryBytes() const override;
  std::string describe() const override;

  /// Spheres per leaf (>= 1, default 4 as in Howard et al. 2016). Takes effect at the next build.
  void setLeafSize(int size);
  int leafSize() const { return leafSize_; }
  /// Rebuild when the tree's cost proxy grows beyond this factor (> 1) of its post-build value.
  void setRebuildFactor(double factor);
  /// Full builds so far (build() calls plus rebuilds triggered by update()).
  std::uint64_t rebuilds() const { return rebuilds_; }
  /// Cost proxy now over its value after the last build (1 right after a build).
  double qualityRatio() const { return builtQuality_ > 0.0 ? quality_ / builtQuality_ : 1.0; }
  int depth() const { return depth_; }
  /// Check the tree against the spheres (bounds contain centres and radii, ranges, parents); throws
  /// std::logic_error. For tests.
  void validate(const SphereView& spheres) const;

 protected:
  void doBuild(const SphereView& spheres) override;
  void doUpdate(const SphereView& spheres, std::span<const Index> moved) override;

 private:
  // 32 bytes: the box of the spheres below (centre -+ radius), in float rounded outward so no pair
  // is lost, and the tree links.
  struct alignas(32) Node {
    float lo[3];  // box of the spheres below (m)
    Index end;    // one past the last slot below
    float hi[3];
    Index right;  // internal: right child (left child is this + 1); leaf: -1 - first slot
  };
  struct alignas(16) QueryBox {
    float lo[4], hi[4];  // the fourth lane is not compared
  };
  static bool isLeaf(const Node& n) { return n.right < 0; }
  static bool overlaps(const Node& n, const QueryBox& q) {
#if defined(__SSE2__)
    // lo and hi are each one 16-byte load (the fourth lane, end or right, is masked off).
    const __m128 meet = _mm_and_ps(_mm_cmple_ps(_mm_load_ps(n.lo), _mm_load_ps(q.hi)),
                                   _mm_cmpge_ps(_mm_load_ps(n.hi), _mm_load_ps(q.lo)));
    return (_mm_movemask_ps(meet) & 7) == 7;
#else
    return (n.lo[0] <= q.hi[0]) & (n.hi[0] >= q.lo[0]) & (n.lo[1] <= q.hi[1]) & (n.hi[1] >= q.lo[1]) &
           (n.lo[2] <= q.hi[2]) & (n.hi[2] >= q.lo[2]);
#endif
  }
  /// Float bounds at or below / above v (v - or + a margin that exceeds the rounding error).
  float roundDown(double v) const { return static_cast<float>(v - floatMargin_); }
  float roundUp(double v) const { return static_cast<float>(v + floatMargin_); }
  /// The box [lo, hi] shifted by `shift` and rounded outward to float.
  void toQuery(const double* lo, const double* hi, const double* shift, QueryBox& q) const;
  void boundLeaf(Index node);
  void boundInternal(Index node);
  double nodeCost(const Node& n) const;
  void refitAll();
  /// Periodic images of a query box [lo, hi] that may meet the root's box: shifts[k] for k < count
  /// (the first is the unshifted query).
  struct Images {
    double shift[27][3];
    int count;
  };
  void imagesOf(const double* lo, const double* hi, Images& out) const;
  /// Leaves whose box meets q, among those after slot `minEnd` (-1: all), appended to candidates_ in
  /// pre-order; returns the node box tests made.
  std::uint64_t candidateLeaves(const QueryBox& q, Index minEnd) const;
  template <bool kCount>
  void pairsImpl(std::vector<Pair>& out) const;

  int leafSize_ = 4;
  double rebuildFactor_ = 1.5;
  std::uint64_t rebuilds_ = 0;
  double quality_ = 0.0, builtQuality_ = 0.0;
  double tolerance_ = 0.0;    // absolute slack on box tests (m): rounding of imaged coordinates
  double floatMargin_ = 0.0;  // added outward before rounding a bound to float (m)
  int depth_ = 0;
  std::vector<Node> nodes_;      // pre-order; root at 0
  std::vector<Index> parent_;    // per node (-1 for the root)
  std::vector<Index> leafNode_;  // node of leaf l (slots [l * leafSize, ...))
  std::vector<Index> sorted_;    // particle per slot (Morton order)
  std::vector<Index> slotOf_;    // slot per particle
  Eigen::Matrix4Xd packed_;      // x, y, z, r per slot
  std::vector<double> columns_;  // the same as four columns (x, y, z, r) of columnStride_ slots each
  std::size_t columnStride_ = 0;
  // Build scratch (capacity kept: no allocation in steady state).
  std::vector<std::pair<std::uint64_t, Index>> keys_;
  std::vector<std::uint64_t> leafKey_;
  std::vector<Index> childLeft_, childRight_;  // Karras layout: >= 0 internal, < 0 leaf (-1 - l)
  struct Pending {
    Index karras;  // node in the Karras layout (>= 0 internal, < 0 leaf)
    Index parent;  // its parent in pre-order (-1 for the root)
    bool isRight;
    int depth;
  };
  std::vector<Pending> work_;  // pre-order relayout stack
  // Query scratch.
  mutable std::vector<Index> stack_;
  mutable std::vector<Index> candidates_;
};

}  // namespace polydem::broadphase
