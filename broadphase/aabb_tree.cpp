// Dynamic AABB tree broad phase; design notes and references in aabb_tree.hpp.
#include "broadphase/aabb_tree.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

#include "broadphase/morton_order.hpp"
#include "core/errors.hpp"

namespace polydem::broadphase {

Index AabbTree::allocate() {
  Index n;
  if (freeList_ >= 0) {
    n = freeList_;
    freeList_ = parent_[static_cast<std::size_t>(n)];
  } else {
    n = static_cast<Index>(nodes_.size());
    nodes_.emplace_back();
    parent_.push_back(-1);
    height_.push_back(0);
  }
  parent_[static_cast<std::size_t>(n)] = -1;
  height_[static_cast<std::size_t>(n)] = 0;
  return n;
}

void AabbTree::release(Index n) {
  parent_[static_cast<std::size_t>(n)] = freeList_;
  height_[static_cast<std::size_t>(n)] = -1;
  freeList_ = n;
}

double AabbTree::area(const Node& n) const {
  const double h = 2.0 * n.rmax;
  const double ex = n.hi[0] - n.lo[0] + h, ey = n.hi[1] - n.lo[1] + h, ez = n.hi[2] - n.lo[2] + h;
  return 2.0 * (ex * ey + ey * ez + ez * ex);
}

double AabbTree::unionArea(const Node& a, const Node& b) const {
  Node u;
  for (int k = 0; k < 3; ++k) {
    u.lo[k] = std::min(a.lo[k], b.lo[k]);
    u.hi[k] = std::max(a.hi[k], b.hi[k]);
  }
  u.rmax = std::max(a.rmax, b.rmax);
  return area(u);
}

void AabbTree::refit(Index n) {
  Node& nd = nodes_[static_cast<std::size_t>(n)];
  const Node& a = nodes_[static_cast<std::size_t>(nd.child1)];
  const Node& b = nodes_[static_cast<std::size_t>(nd.child2)];
  for (int k = 0; k < 3; ++k) {
    nd.lo[k] = std::min(a.lo[k], b.lo[k]);
    nd.hi[k] = std::max(a.hi[k], b.hi[k]);
  }
  nd.rmax = std::max(a.rmax, b.rmax);
  height_[static_cast<std::size_t>(n)] =
      1 + std::max(height_[static_cast<std::size_t>(nd.child1)], height_[static_cast<std::size_t>(nd.child2)]);
}

void AabbTree::setFatBox(Index leaf, const double* x) {
  Node& nd = nodes_[static_cast<std::size_t>(leaf)];
  for (int k = 0; k < 3; ++k) {
    nd.lo[k] = x[k] - margin_;
    nd.hi[k] = x[k] + margin_;
  }
}

Index AabbTree::buildRange(const SphereView& spheres, Index first, Index last) {
  const Index n = allocate();  // pre-order: a parent before its children
  if (last - first == 1) {
    const Index i = keys_[static_cast<std::size_t>(first)].second;
    Node& nd = nodes_[static_cast<std::size_t>(n)];
    nd.child1 = -1;
    nd.child2 = i;
    nd.rmax = spheres.radius[i];
    setFatBox(n, spheres.centre.col(i).data());
    leafOf_[static_cast<std::size_t>(i)] = n;
    return n;
  }
  // The median split keeps the two halves within one sphere of each other, so heights differ by at
  // most one: a valid AVL tree for the incremental updates.
  const Index mid = first + (last - first) / 2;
  const Index a = buildRange(spheres, first, mid);
  const Index b = buildRange(spheres, mid, last);
  nodes_[static_cast<std::size_t>(n)].child1 = a;
  nodes_[static_cast<std::size_t>(n)].child2 = b;
  parent_[static_cast<std::size_t>(a)] = n;
  parent_[static_cast<std::size_t>(b)] = n;
  refit(n);
  return n;
}

void AabbTree::doBuild(const SphereView& spheres) {
  const Index n = spheres.count();
  margin_ = 0.5 * skin_;
  tolerance_ = 1e-12 * (box_.lengths().maxCoeff() + 4.0 * maxRadius_ + 2.0 * skin_ + 2.0 * margin_);
  nodes_.clear();
  parent_.clear();
  height_.clear();
  freeList_ = -1;
  root_ = -1;
  reinsertions_ = rotations_ = 0;
  leafOf_.resize(static_cast<std::size_t>(n));
  if (n == 0) return;
  nodes_.reserve(static_cast<std::size_t>(2 * n - 1));
  parent_.reserve(nodes_.capacity());
  height_.reserve(nodes_.capacity());
  mortonOrder(spheres, box_, keys_);
  root_ = buildRange(spheres, 0, n);
  if (stack_.size() < static_cast<std::size_t>(height()) + 2) stack_.resize(static_cast<std::size_t>(height()) + 2);
}

void AabbTree::rotate(Index a) {
  if (isLeaf(a)) return;
  const Index b = nodes_[static_cast<std::size_t>(a)].child1;
  const Index c = nodes_[static_cast<std::size_t>(a)].child2;
  auto h = [&](Index n) { return height_[static_cast<std::size_t>(n)]; };
  const bool imbalanced = std::abs(h(b) - h(c)) > 1;
  // A rotation swaps `out` (a child of a) with `grand` (a child of `keep`, a's other child); keep
  // then holds `out` and `other`.
  struct Move {
    Index keep, out, grand, other;
    double gain;
    bool balanced;
    int skew;  // |height difference| at a afterwards
  };
  Move best{-1, -1, -1, -1, 0.0, false, 0};
  bool found = false;
  auto consider = [&](Index keep, Index out) {
    if (isLeaf(keep)) return;
    const Node& k = nodes_[static_cast<std::size_t>(keep)];
    for (int side = 0; side < 2; ++side) {
      const Index grand = side == 0 ? k.child1 : k.child2;
      const Index other = side == 0 ? k.child2 : k.child1;
      const int keepHeight = 1 + std::max(h(out), h(other));
      Move m{keep,
             out,
             grand,
             other,
             area(k) - unionArea(nodes_[static_cast<std::size_t>(out)], nodes_[static_cast<std::size_t>(other)]),
             std::abs(h(out) - h(other)) <= 1 && std::abs(h(grand) - keepHeight) <= 1,
             std::abs(h(grand) - keepHeight)};
      if (imbalanced) {
        // Restore the balance; among the rotations that do, the one with the best area.
        const bool better = !found || (m.balanced && !best.balanced) ||
                            (m.balanced == best.balanced && (m.balanced ? m.gain > best.gain : m.skew < best.skew));
        if (better) {
          best = m;
          found = true;
        }
      } else if (m.balanced && 1 + std::max(h(grand), keepHeight) <= h(a) && m.gain > 1e-9 * area(k) &&
                 (!found || m.gain > best.gain)) {
        // Area rotations never make `a` taller, so one insertion or removal changes any height by at
        // most one and a single restoring rotation per node keeps the AVL balance.
        best = m;
        found = true;
      }
    }
  };
  consider(c, b);
  consider(b, c);
  if (!found) return;
  Node& na = nodes_[static_cast<std::size_t>(a)];
  (na.child1 == best.out ? na.child1 : na.child2) = best.grand;
  parent_[static_cast<std::size_t>(best.grand)] = a;
  Node& nk = nodes_[static_cast<std::size_t>(best.keep)];
  (nk.child1 == best.grand ? nk.child1 : nk.child2) = best.out;
  parent_[static_cast<std::size_t>(best.out)] = best.keep;
  refit(best.keep);
  ++rotations_;
}

void AabbTree::fixUpwards(Index n) {
  while (n >= 0) {
    rotate(n);
    refit(n);
    n = parent_[static_cast<std::size_t>(n)];
  }
}

void AabbTree::insertLeaf(Index leaf) {
  if (root_ < 0) {
    root_ = leaf;
    parent_[static_cast<std::size_t>(leaf)] = -1;
    return;
  }
  // Descend to the leaf whose pairing adds the least area: at each node, the child with the smaller
  // branch cost (area of child + leaf, less the child's own area for an internal child; Catto 2019).
  // Unlike Box2D we do not stop at an internal node: pairing the leaf with a whole subtree would
  // unbalance the new parent by more than one rotation can repair, and the AVL bound is what makes
  // update() O(log N) per move.
  Index s = root_;
  {
    const Node& l = nodes_[static_cast<std::size_t>(leaf)];
    auto branchCost = [&](Index c) {
      const Node& cn = nodes_[static_cast<std::size_t>(c)];
      const double u = unionArea(cn, l);
      return isLeaf(c) ? u : u - area(cn);
    };
    while (!isLeaf(s)) {
      const Node& nd = nodes_[static_cast<std::size_t>(s)];
      s = branchCost(nd.child1) <= branchCost(nd.child2) ? nd.child1 : nd.child2;
    }
  }
  const Index oldParent = parent_[static_cast<std::size_t>(s)];
  const Index p = allocate();  // reuses the node the matching removal freed: no growth in steady state
  parent_[static_cast<std::size_t>(p)] = oldParent;
  nodes_[static_cast<std::size_t>(p)].child1 = s;
  nodes_[static_cast<std::size_t>(p)].child2 = leaf;
  parent_[static_cast<std::size_t>(s)] = p;
  parent_[static_cast<std::size_t>(leaf)] = p;
  if (oldParent >= 0) {
    Node& op = nodes_[static_cast<std::size_t>(oldParent)];
    (op.child1 == s ? op.child1 : op.child2) = p;
  } else {
    root_ = p;
  }
  fixUpwards(p);
}

void AabbTree::removeLeaf(Index leaf) {
  if (leaf == root_) {
    root_ = -1;
    return;
  }
  const Index p = parent_[static_cast<std::size_t>(leaf)];
  const Index g = parent_[static_cast<std::size_t>(p)];
  const Node& np = nodes_[static_cast<std::size_t>(p)];
  const Index sibling = np.child1 == leaf ? np.child2 : np.child1;
  parent_[static_cast<std::size_t>(sibling)] = g;
  if (g >= 0) {
    Node& ng = nodes_[static_cast<std::size_t>(g)];
    (ng.child1 == p ? ng.child1 : ng.child2) = sibling;
  } else {
    root_ = sibling;
  }
  release(p);
  parent_[static_cast<std::size_t>(leaf)] = -1;
  if (g >= 0) fixUpwards(g);
}

void AabbTree::doUpdate(const SphereView& spheres, std::span<const Index> moved) {
  for (Index i : moved) {
    const Index leaf = leafOf_[static_cast<std::size_t>(i)];
    const double* x = spheres.centre.col(i).data();
    const Node& nd = nodes_[static_cast<std::size_t>(leaf)];
    bool inside = true;
    for (int k = 0; k < 3; ++k) inside = inside && x[k] >= nd.lo[k] && x[k] <= nd.hi[k];
    if (inside) continue;  // the fat box still holds the centre: the tree stays exact
    removeLeaf(leaf);
    setFatBox(leaf, x);
    insertLeaf(leaf);
    ++reinsertions_;
  }
  if (root_ >= 0 && stack_.size() < static_cast<std::size_t>(height()) + 2) {
    stack_.resize(static_cast<std::size_t>(height()) + 2);  // buffers grow rather than fail
  }
}

int AabbTree::height() const { return root_ < 0 ? -1 : height_[static_cast<std::size_t>(root_)]; }

void AabbTree::imagesOf(const double* x, double radius, Images& out) const {
  double shifts[3][3];
  int count[3];
  for (int k = 0; k < 3; ++k) {
    count[k] = 0;
    shifts[k][count[k]++] = 0.0;
    if (!box_.periodic(k)) continue;
    if (x[k] - radius < 0.0) shifts[k][count[k]++] = box_.length(k);
    if (x[k] + radius > box_.length(k)) shifts[k][count[k]++] = -box_.length(k);
  }
  out.count = 0;
  for (int a = 0; a < count[0]; ++a)
    for (int b = 0; b < count[1]; ++b)
      for (int c = 0; c < count[2]; ++c) {
        double* s = out.shift[out.count++];
        s[0] = shifts[0][a];
        s[1] = shifts[1][b];
        s[2] = shifts[2][c];
      }
}

template <bool kCount, class Visit>
void AabbTree::query(const SphereView& spheres, Index i, const double* shift, double reach, Index minRank,
                     std::uint64_t& tests, std::uint64_t& visits, Visit&& visit) const {
  const double* x = spheres.centre.col(i).data();
  const double ri = spheres.radius[i];
  const double q[3] = {x[0] + shift[0], x[1] + shift[1], x[2] + shift[2]};
  const double base = ri + reach + tolerance_;
  Index* stack = stack_.data();
  int top = 0;
  stack[top++] = root_;
  while (top > 0) {
    const Index id = stack[--top];
    const Node& nd = nodes_[static_cast<std::size_t>(id)];
    const bool leaf = nd.child1 < 0;
    if (minRank >= 0 ? nd.maxRank <= minRank : leaf && nd.child2 == i) continue;
    if constexpr (kCount) ++visits;
    double d2 = 0.0;
    for (int k = 0; k < 3; ++k) {
      const double d = std::max(std::max(nd.lo[k] - q[k], q[k] - nd.hi[k]), 0.0);
      d2 += d * d;
    }
    const double limit = base + nd.rmax;
    if (d2 > limit * limit) continue;
    if (leaf) {
      const Index j = nd.child2;
      if constexpr (kCount) ++tests;
      if (spheresWithinReach(box_, x, ri, spheres.centre.col(j).data(), spheres.radius[j], reach)) visit(j);
    } else {
      stack[top++] = nd.child2;
      stack[top++] = nd.child1;
    }
  }
}

template <bool kCount>
void AabbTree::pairsImpl(const SphereView& spheres, std::vector<Pair>& out) const {
  const Index n = spheres.count();
  const double rootRadius = nodes_[static_cast<std::size_t>(root_)].rmax;
  // Depth-first ranks: a subtree's leaves have consecutive ranks, its maxRank the last of them.
  order_.resize(static_cast<std::size_t>(n));
  preorder_.clear();
  {
    Index next = 0;
    Index* stack = stack_.data();
    int top = 0;
    stack[top++] = root_;
    while (top > 0) {
      const Index id = stack[--top];
      const Node& nd = nodes_[static_cast<std::size_t>(id)];
      if (nd.child1 < 0) {
        nd.maxRank = next;
        order_[static_cast<std::size_t>(next++)] = nd.child2;
      } else {
        preorder_.push_back(id);
        stack[top++] = nd.child2;
        stack[top++] = nd.child1;
      }
    }
    for (auto it = preorder_.rbegin(); it != preorder_.rend(); ++it) {  // children before parents
      const Node& nd = nodes_[static_cast<std::size_t>(*it)];
      nd.maxRank = std::max(nodes_[static_cast<std::size_t>(nd.child1)].maxRank,
                            nodes_[static_cast<std::size_t>(nd.child2)].maxRank);
    }
  }
  std::uint64_t tests = 0, visits = 0;
  Images images;
  for (Index r = 0; r + 1 < n; ++r) {
    const Index i = order_[static_cast<std::size_t>(r)];
    auto emit = [&](Index j) { out.push_back(i < j ? Pair{i, j} : Pair{j, i}); };
    imagesOf(spheres.centre.col(i).data(), spheres.radius[i] + rootRadius + skin_ + tolerance_, images);
    if (images.count == 1) {
      query<kCount>(spheres, i, images.shift[0], skin_, r, tests, visits, emit);
      continue;
    }
    // A sphere reached through two images (a periodic length of exactly 2 cut-offs) is reported once.
    found_.clear();
    for (int k = 0; k < images.count; ++k) {
      query<kCount>(spheres, i, images.shift[k], skin_, r, tests, visits, [&](Index j) { found_.push_back(j); });
    }
    std::sort(found_.begin(), found_.end());
    found_.erase(std::unique(found_.begin(), found_.end()), found_.end());
    for (Index j : found_) emit(j);
  }
  if constexpr (kCount) {
    counters_.pairTests += tests;
    counters_.cellAccesses += visits;
  }
}

void AabbTree::findPairs(const SphereView& spheres, std::vector<Pair>& out) const {
  out.clear();
  if (root_ < 0) return;
  if (counting_) {
    pairsImpl<true>(spheres, out);
  } else {
    pairsImpl<false>(spheres, out);
  }
}

void AabbTree::findNeighbours(const SphereView& spheres, Index i, double reach, std::vector<Index>& out) const {
  out.clear();
  if (!(reach >= 0.0 && reach <= skin_)) {
    throw ConfigError(fmt::format("findNeighbours: reach {} must lie in [0, skin = {}]", reach, skin_));
  }
  if (i < 0 || i >= static_cast<Index>(leafOf_.size())) {
    throw ConfigError(fmt::format("findNeighbours: particle {} out of range [0, {})", i, leafOf_.size()));
  }
  Images images;
  imagesOf(spheres.centre.col(i).data(),
           spheres.radius[i] + nodes_[static_cast<std::size_t>(root_)].rmax + reach + tolerance_, images);
  std::uint64_t tests = 0, visits = 0;
  for (int k = 0; k < images.count; ++k) {
    query<false>(spheres, i, images.shift[k], reach, -1, tests, visits, [&](Index j) { out.push_back(j); });
  }
  std::sort(out.begin(), out.end());
  if (images.count > 1) out.erase(std::unique(out.begin(), out.end()), out.end());
}

std::size_t AabbTree::memoryBytes() const {
  return nodes_.capacity() * sizeof(Node) + parent_.capacity() * sizeof(Index) + height_.capacity() * sizeof(int) +
         leafOf_.capacity() * sizeof(Index) + keys_.capacity() * sizeof(keys_[0]) + stack_.capacity() * sizeof(Index) +
         (found_.capacity() + order_.capacity() + preorder_.capacity()) * sizeof(Index);
}

std::string AabbTree::describe() const {
  return fmt::format("aabb-tree {} leaves, height {}, margin {:.4g}; since the build {} re-insertions, {} rotations",
                     leafOf_.size(), height(), margin_, reinsertions_, rotations_);
}

void AabbTree::validate(const SphereView& spheres) const {
  const Index n = spheres.count();
  if (static_cast<Index>(leafOf_.size()) != n) throw std::logic_error("aabb-tree: leaf count differs from N");
  if (n == 0) {
    if (root_ >= 0) throw std::logic_error("aabb-tree: a root without spheres");
    return;
  }
  if (root_ < 0 || parent_[static_cast<std::size_t>(root_)] != -1) throw std::logic_error("aabb-tree: bad root");
  std::vector<Index> seen(static_cast<std::size_t>(n), 0);
  std::vector<Index> todo{root_};
  std::size_t reachable = 0;
  while (!todo.empty()) {
    const Index id = todo.back();
    todo.pop_back();
    ++reachable;
    const Node& nd = nodes_[static_cast<std::size_t>(id)];
    const int hgt = height_[static_cast<std::size_t>(id)];
    if (nd.child1 < 0) {
      const Index j = nd.child2;
      if (j < 0 || j >= n) throw std::logic_error(fmt::format("aabb-tree: leaf {} holds sphere {}", id, j));
      ++seen[static_cast<std::size_t>(j)];
      if (leafOf_[static_cast<std::size_t>(j)] != id)
        throw std::logic_error(fmt::format("aabb-tree: leafOf {} stale", j));
      if (hgt != 0) throw std::logic_error(fmt::format("aabb-tree: leaf {} has height {}", id, hgt));
      if (nd.rmax != spheres.radius[j]) throw std::logic_error(fmt::format("aabb-tree: leaf radius of {} wrong", j));
      for (int k = 0; k < 3; ++k) {
        const double x = spheres.centre(k, j);
        if (x < nd.lo[k] || x > nd.hi[k])
          throw std::logic_error(fmt::format("aabb-tree: sphere {} left its fat box", j));
      }
      continue;
    }
    const Index a = nd.child1, b = nd.child2;
    for (Index c : {a, b}) {
      if (parent_[static_cast<std::size_t>(c)] != id)
        throw std::logic_error(fmt::format("aabb-tree: parent of {} wrong", c));
      const Node& cn = nodes_[static_cast<std::size_t>(c)];
      for (int k = 0; k < 3; ++k) {
        if (cn.lo[k] < nd.lo[k] || cn.hi[k] > nd.hi[k])
          throw std::logic_error(fmt::format("aabb-tree: node {} unbounded", id));
      }
      if (cn.rmax > nd.rmax) throw std::logic_error(fmt::format("aabb-tree: r_max of node {} too small", id));
      todo.push_back(c);
    }
    const int ha = height_[static_cast<std::size_t>(a)], hb = height_[static_cast<std::size_t>(b)];
    if (hgt != 1 + std::max(ha, hb)) throw std::logic_error(fmt::format("aabb-tree: height of node {} wrong", id));
    if (std::abs(ha - hb) > 1) throw std::logic_error(fmt::format("aabb-tree: node {} out of AVL balance", id));
  }
  for (Index j = 0; j < n; ++j) {
    if (seen[static_cast<std::size_t>(j)] != 1)
      throw std::logic_error(fmt::format("aabb-tree: sphere {} in {} leaves", j, seen[static_cast<std::size_t>(j)]));
  }
  std::size_t free = 0;
  for (Index f = freeList_; f >= 0; f = parent_[static_cast<std::size_t>(f)]) ++free;
  if (reachable + free != nodes_.size()) throw std::logic_error("aabb-tree: nodes leaked from the pool");
}

}  // namespace polydem::broadphase
