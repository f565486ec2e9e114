#pragma once
// Dynamic AABB tree broad phase (the game-physics dynamic bounding-volume tree).
//
// One leaf per sphere holding a fattened box around its centre, [x - m, x + m] with margin
// m = skin / 2 (Catto, "Dynamic Bounding Volume Hierarchies", GDC 2019; Box2D's dynamic tree). Each
// node also stores the largest radius below it, so sphere i visits a node when its centre is within
// r_i + r_max(node) + skin of the node's box; boxes contain the centres, so the search is exact and
// the candidates are filtered with spheresWithinReach on the minimum image.
//
// update(moved) is incremental: a moved sphere whose centre is still inside its fat box costs
// nothing; otherwise its leaf is removed and re-inserted around the new centre, O(log N) each, so
// update() is O(|moved| log N). Insertion descends to the leaf sibling by the branch cost of Catto
// 2019 (the child whose union with the new leaf adds the least surface area; surface area of the
// node box dilated by its r_max), always down to a leaf so that AVL rebalancing applies. On the way back up every
// ancestor is re-bounded and may be rotated: one of its children swaps with a grandchild (the four tree rotations of
// Kopta et al., "Fast, effective BVH updates for animated scenes", I3D 2012; Bittner, Hapala & Havran, Comput. Graph.
// Forum 32 (2013) 85 optimise trees by such local moves). Rotation heuristic: a node whose children's heights differ by
// more than one takes the rotation that restores the AVL balance (as Box2D's tree balances by height), so the height
// stays O(log N); otherwise it takes the rotation that most reduces the area of the rebuilt child, among those that
// keep the AVL balance.
//
// build() is a bulk build: Morton order of the centres, split at the median, which is balanced, so
// incremental updates start from a valid AVL tree. findPairs first ranks the leaves in depth-first
// order (O(N); each node then knows the largest rank below it), then runs one stack-based traversal
// per sphere in rank order that skips subtrees of lower rank, so each pair is found once and queries
// follow the tree through space; periodic boundaries image the query. Nodes live in a pool with a free
// list: steady-state updates and queries do not allocate.
#include <cstdint>
#include <vector>

#include "broadphase/broad_phase.hpp"

namespace polydem::broadphase {

class AabbTree final : public BroadPhase {
 public:
  std::string_view name() const override { return "aabb-tree"; }
  Capabilities capabilities() const override { return {.complete = true, .incremental = true}; }
  void findPairs(const SphereView& spheres, std::vector<Pair>& out) const override;
  void findNeighbours(const SphereView& spheres, Index i, double reach, std::vector<Index>& out) const override;
  std::size_t memoryBytes() const override;
  std::string describe() const override;

  /// Leaves re-inserted by update() since the last build (moves that left their fat box).
  std::uint64_t reinsertions() const { return reinsertions_; }
  /// Rotations applied since the last build.
  std::uint64_t rotations() const { return rotations_; }
  /// Height of the tree (a single leaf has height 0; -1 when empty).
  int height() const;
  /// Check every invariant (bounds, r_max, parent links, heights, AVL balance, fat boxes holding the
  /// centres, one leaf per sphere); throws std::logic_error. For tests.
  void validate(const SphereView& spheres) const;

 protected:
  void doBuild(const SphereView& spheres) override;
  /// O(|moved| log N): re-inserts only the spheres that left their fat boxes.
  void doUpdate(const SphereView& spheres, std::span<const Index> moved) override;

 private:
  struct Node {
    double lo[3], hi[3];    // leaf: fat box of the centre; internal: union of the children (m)
    double rmax;            // largest radius below (m)
    Index child1;           // -1 for a leaf
    Index child2;           // leaf: the sphere
    mutable Index maxRank;  // set by findPairs: the largest depth-first rank of a leaf below
  };
  bool isLeaf(Index n) const { return nodes_[static_cast<std::size_t>(n)].child1 < 0; }
  Index allocate();
  void release(Index n);
  Index buildRange(const SphereView& spheres, Index first, Index last);
  void refit(Index n);
  /// Surface area of the box of `n` dilated by its r_max: the insertion and rotation cost.
  double area(const Node& n) const;
  double unionArea(const Node& a, const Node& b) const;
  void insertLeaf(Index leaf);
  void removeLeaf(Index leaf);
  /// Re-bound and rotate every node from n up to the root.
  void fixUpwards(Index n);
  void rotate(Index a);
  void setFatBox(Index leaf, const double* x);
  struct Images {
    double shift[27][3];
    int count;
  };
  void imagesOf(const double* x, double radius, Images& out) const;
  template <bool kCount, class Visit>
  /// minRank >= 0: only leaves of higher depth-first rank (findPairs); < 0: every leaf but i's.
  void query(const SphereView& spheres, Index i, const double* shift, double reach, Index minRank, std::uint64_t& tests,
             std::uint64_t& visits, Visit&& visit) const;
  template <bool kCount>
  void pairsImpl(const SphereView& spheres, std::vector<Pair>& out) const;

  double margin_ = 0.0;     // skin / 2 (m)
  double tolerance_ = 0.0;  // absolute slack on box tests (m): rounding of imaged coordinates
  Index root_ = -1;
  Index freeList_ = -1;  // free nodes chained through parent_
  std::vector<Node> nodes_;
  std::vector<Index> parent_;
  std::vector<int> height_;    // -1 for a free node
  std::vector<Index> leafOf_;  // leaf node per sphere
  std::uint64_t reinsertions_ = 0, rotations_ = 0;
  // Build scratch.
  std::vector<std::pair<std::uint64_t, Index>> keys_;
  // Query scratch.
  mutable std::vector<Index> stack_;
  mutable std::vector<Index> found_;
  mutable std::vector<Index> order_;     // sphere per depth-first leaf rank
  mutable std::vector<Index> preorder_;  // internal nodes in depth-first order
};

}  // namespace polydem::broadphase
