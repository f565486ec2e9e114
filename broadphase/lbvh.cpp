// Linear BVH broad phase; design notes and references in lbvh.hpp.
#include "broadphase/lbvh.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "broadphase/morton_order.hpp"
#include "core/errors.hpp"

namespace polydem::broadphase {

namespace {

// Karras 2012, Sec. 4: delta(i, j) = length of the longest common prefix of the keys of leaves i and
// j, -1 outside [0, m); equal keys fall back to the common prefix of the indices (32 more bits).
inline int commonPrefix(const std::vector<std::uint64_t>& key, Index m, Index i, Index j) {
  if (j < 0 || j >= m) return -1;
  const std::uint64_t a = key[static_cast<std::size_t>(i)], b = key[static_cast<std::size_t>(j)];
  if (a != b) return std::countl_zero(a ^ b);
  return 64 + std::countl_zero(static_cast<std::uint32_t>(i ^ j));
}
}  // namespace

void Lbvh::setLeafSize(int size) {
  if (size < 1) throw ConfigError(fmt::format("lbvh: leaf size must be >= 1, got {}", size));
  leafSize_ = size;
}

void Lbvh::setRebuildFactor(double factor) {
  if (!(factor > 1.0)) throw ConfigError(fmt::format("lbvh: rebuild factor must be > 1, got {}", factor));
  rebuildFactor_ = factor;
}

double Lbvh::nodeCost(const Node& n) const {
  // A small sphere's query box (r_min + skin around its centre) meets the node's box when the centre
  // lies in the box dilated by r_min + skin: V times the expected visits of such a query.
  const double h = 2.0 * (minRadius_ + skin_);
  const double dx = static_cast<double>(n.hi[0]) - n.lo[0], dy = static_cast<double>(n.hi[1]) - n.lo[1],
               dz = static_cast<double>(n.hi[2]) - n.lo[2];
  return (dx + h) * (dy + h) * (dz + h);
}

void Lbvh::boundLeaf(Index node) {
  Node& nd = nodes_[static_cast<std::size_t>(node)];
  const Index first = -1 - nd.right;
  double lo[3], hi[3];
  for (int k = 0; k < 3; ++k) {
    lo[k] = std::numeric_limits<double>::infinity();
    hi[k] = -std::numeric_limits<double>::infinity();
  }
  for (Index t = first; t < nd.end; ++t) {
    const double* p = packed_.data() + 4 * static_cast<std::ptrdiff_t>(t);
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], p[k] - p[3]);
      hi[k] = std::max(hi[k], p[k] + p[3]);
    }
  }
  for (int k = 0; k < 3; ++k) {
    nd.lo[k] = roundDown(lo[k]);
    nd.hi[k] = roundUp(hi[k]);
  }
}

void Lbvh::boundInternal(Index node) {
  Node& nd = nodes_[static_cast<std::size_t>(node)];
  const Node& a = nodes_[static_cast<std::size_t>(node) + 1];
  const Node& b = nodes_[static_cast<std::size_t>(nd.right)];
  for (int k = 0; k < 3; ++k) {
    nd.lo[k] = std::min(a.lo[k], b.lo[k]);
    nd.hi[k] = std::max(a.hi[k], b.hi[k]);
  }
  nd.end = b.end;
}

void Lbvh::refitAll() {
  quality_ = 0.0;
  for (Index p = static_cast<Index>(nodes_.size()) - 1; p >= 0; --p) {  // children after parents
    if (isLeaf(nodes_[static_cast<std::size_t>(p)])) {
      boundLeaf(p);
    } else {
      boundInternal(p);
    }
    quality_ += nodeCost(nodes_[static_cast<std::size_t>(p)]);
  }
}

void Lbvh::doBuild(const SphereView& spheres) {
  ++rebuilds_;
  const Index n = spheres.count();
  tolerance_ = 1e-12 * (box_.lengths().maxCoeff() + 4.0 * maxRadius_ + 2.0 * skin_);
  // Every value rounded to float (a box bound, possibly imaged) is below M = 2 L + 4 r_max + 4 skin in
  // magnitude, where rounding to nearest errs by at most 2^-24 M: a margin of 2^-22 M rounds outward.
  floatMargin_ = 0x1p-22 * (2.0 * box_.lengths().maxCoeff() + 4.0 * maxRadius_ + 4.0 * skin_);
  sorted_.resize(static_cast<std::size_t>(n));
  slotOf_.resize(static_cast<std::size_t>(n));
  packed_.resize(4, n);
  // Columns x, y, z, r per slot, each padded by two far-away zero-radius slots.
  columnStride_ = static_cast<std::size_t>(n) + 2;
  columns_.resize(4 * columnStride_);
  for (std::size_t k = 0; k < 4; ++k) {
    for (std::size_t t = static_cast<std::size_t>(n); t < columnStride_; ++t)
      columns_[k * columnStride_ + t] = k < 3 ? 1e300 : 0.0;
  }
  nodes_.clear();
  parent_.clear();
  leafNode_.clear();
  depth_ = 0;
  quality_ = builtQuality_ = 0.0;
  if (n == 0) return;

  mortonOrder(spheres, box_, keys_);  // ties broken by index: the tree does not depend on the sort's stability
  for (Index s = 0; s < n; ++s) {
    const Index i = keys_[static_cast<std::size_t>(s)].second;
    sorted_[static_cast<std::size_t>(s)] = i;
    slotOf_[static_cast<std::size_t>(i)] = s;
    packed_.col(s) << spheres.centre(0, i), spheres.centre(1, i), spheres.centre(2, i), spheres.radius[i];
    for (std::size_t k = 0; k < 4; ++k) columns_[k * columnStride_ + static_cast<std::size_t>(s)] = packed_(k, s);
  }

  // Leaves: runs of leafSize_ consecutive slots, keyed by their first sphere's code.
  const Index b = leafSize_;
  const Index m = (n + b - 1) / b;
  leafKey_.resize(static_cast<std::size_t>(m));
  for (Index l = 0; l < m; ++l) leafKey_[static_cast<std::size_t>(l)] = keys_[static_cast<std::size_t>(l * b)].first;

  // Karras 2012, Fig. 4: internal node i spans leaves [min(i, j), max(i, j)] and splits at gamma.
  childLeft_.resize(static_cast<std::size_t>(std::max<Index>(m - 1, 0)));
  childRight_.resize(childLeft_.size());
  for (Index i = 0; i + 1 < m; ++i) {
    auto delta = [&](Index j) { return commonPrefix(leafKey_, m, i, j); };
    const Index d = delta(i + 1) > delta(i - 1) ? 1 : -1;
    const int deltaMin = delta(i - d);
    std::int64_t lmax = 2;
    while (i + lmax * d >= 0 && i + lmax * d < m && delta(static_cast<Index>(i + lmax * d)) > deltaMin) lmax *= 2;
    Index l = 0;
    for (std::int64_t t = lmax / 2; t >= 1; t /= 2) {
      const std::int64_t j = i + (l + t) * d;
      if (j >= 0 && j < m && delta(static_cast<Index>(j)) > deltaMin) l += static_cast<Index>(t);
    }
    const Index j = i + l * d;
    const int deltaNode = delta(j);
    Index s = 0;
    Index t = l;
    do {
      t = (t + 1) / 2;
      if (delta(i + (s + t) * d) > deltaNode) s += t;
    } while (t > 1);
    const Index gamma = i + s * d + std::min<Index>(d, 0);
    childLeft_[static_cast<std::size_t>(i)] = std::min(i, j) == gamma ? -1 - gamma : gamma;
    childRight_[static_cast<std::size_t>(i)] = std::max(i, j) == gamma + 1 ? -1 - (gamma + 1) : gamma + 1;
  }

  // Pre-order relayout: the left child of node p is p + 1.
  nodes_.resize(static_cast<std::size_t>(2 * m - 1));
  parent_.resize(nodes_.size());
  leafNode_.resize(static_cast<std::size_t>(m));
  work_.clear();
  work_.push_back({m > 1 ? 0 : -1, -1, false, 0});
  Index next = 0;
  while (!work_.empty()) {
    const Pending item = work_.back();
    work_.pop_back();
    const Index p = next++;
    parent_[static_cast<std::size_t>(p)] = item.parent;
    if (item.isRight) nodes_[static_cast<std::size_t>(item.parent)].right = p;
    depth_ = std::max(depth_, item.depth);
    Node& nd = nodes_[static_cast<std::size_t>(p)];
    if (item.karras < 0) {
      const Index leaf = -1 - item.karras;
      nd.right = -1 - leaf * b;
      nd.end = std::min(n, (leaf + 1) * b);
      leafNode_[static_cast<std::size_t>(leaf)] = p;
    } else {
      nd.right = 0;  // set when the right child is placed
      work_.push_back({childRight_[static_cast<std::size_t>(item.karras)], p, true, item.depth + 1});
      work_.push_back({childLeft_[static_cast<std::size_t>(item.karras)], p, false, item.depth + 1});
    }
  }
  refitAll();
  builtQuality_ = quality_;
  if (stack_.size() < static_cast<std::size_t>(depth_) + 2) stack_.resize(static_cast<std::size_t>(depth_) + 2);
}

void Lbvh::doUpdate(const SphereView& spheres, std::span<const Index> moved) {
  if (nodes_.empty()) return;
  for (Index i : moved) {
    const Index slot = slotOf_[static_cast<std::size_t>(i)];
    packed_.col(slot).head<3>() = spheres.centre.col(i);
    for (std::size_t k = 0; k < 3; ++k) columns_[k * columnStride_ + static_cast<std::size_t>(slot)] = packed_(k, slot);
  }
  if (static_cast<double>(moved.size()) * (depth_ + 1) > static_cast<double>(nodes_.size())) {
    refitAll();  // many moved: one O(M) sweep is cheaper than the paths
  } else {
    // Re-bound each moved sphere's leaf and its ancestors, stopping where a box did not change.
    for (Index i : moved) {
      Index p = leafNode_[static_cast<std::size_t>(slotOf_[static_cast<std::size_t>(i)] / leafSize_)];
      while (p >= 0) {
        Node& nd = nodes_[static_cast<std::size_t>(p)];
        const Node before = nd;
        quality_ -= nodeCost(nd);
        if (isLeaf(nd)) {
          boundLeaf(p);
        } else {
          boundInternal(p);
        }
        quality_ += nodeCost(nd);
        if (std::equal(before.lo, before.lo + 3, nd.lo) && std::equal(before.hi, before.hi + 3, nd.hi)) break;
        p = parent_[static_cast<std::size_t>(p)];
      }
    }
  }
  if (quality_ > rebuildFactor_ * builtQuality_) doBuild(spheres);
}

void Lbvh::imagesOf(const double* lo, const double* hi, Images& out) const {
  const Node& root = nodes_.front();
  double shifts[3][3];
  int count[3];
  for (int k = 0; k < 3; ++k) {
    count[k] = 0;
    shifts[k][count[k]++] = 0.0;
    if (!box_.periodic(k)) continue;
    // The image at +L meets boxes near L, the image at -L boxes near 0: only where the root's box is.
    const double length = box_.length(k);
    if (lo[k] + length <= root.hi[k]) shifts[k][count[k]++] = length;
    if (hi[k] - length >= root.lo[k]) shifts[k][count[k]++] = -length;
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

void Lbvh::toQuery(const double* lo, const double* hi, const double* shift, QueryBox& q) const {
  for (int k = 0; k < 3; ++k) {
    q.lo[k] = roundDown(lo[k] + shift[k]);
    q.hi[k] = roundUp(hi[k] + shift[k]);
  }
  q.lo[3] = q.hi[3] = 0.0f;
}

std::uint64_t Lbvh::candidateLeaves(const QueryBox& q, Index minEnd) const {
  // Children are tested before they are pushed, so every popped node is known to meet the query;
  // the left child (id + 1) is descended into directly. Nodes ending at or before minEnd hold only
  // leaves at or before the querying leaf in Morton order and are cut whole.
  std::uint64_t visits = 1;
  const Node* nodes = nodes_.data();
  if (!(nodes[0].end > minEnd && overlaps(nodes[0], q))) return visits;
  Index* stack = stack_.data();
  int top = 0;
  Index id = 0;
  for (;;) {
    const Node& nd = nodes[id];
    if (nd.right < 0) {
      candidates_.push_back(id);
    } else {
      const Index l = id + 1, r = nd.right;
      visits += 2;
      const bool goLeft = nodes[l].end > minEnd && overlaps(nodes[l], q);
      const bool goRight = overlaps(nodes[r], q);  // its end is the parent's, > minEnd
      if (goLeft) {
        if (goRight) stack[top++] = r;
        id = l;
        continue;
      }
      if (goRight) {
        id = r;
        continue;
      }
    }
    if (top == 0) break;
    id = stack[--top];
  }
  return visits;
}

template <bool kCount>
void Lbvh::pairsImpl(std::vector<Pair>& out) const {
  const Index n = static_cast<Index>(sorted_.size());
  const double* p = packed_.data();
  const double dilation = skin_ + tolerance_;
  const double skin = skin_;
  std::uint64_t tests = 0, visits = 0;
  auto emit = [&](Index s, Index t) {
    const Index i = sorted_[static_cast<std::size_t>(s)], j = sorted_[static_cast<std::size_t>(t)];
    out.push_back(i < j ? Pair{i, j} : Pair{j, i});
  };
  // Without images (the leaf's dilated box meets no image of the root's box) no pair of the leaf's
  // spheres reaches across a periodic face, and there the plain difference is the minimum image of
  // every pair within reach (|d_k| <= 2 r_max + skin <= L_k / 2): the direct test is exact.
  auto directPair = [&](const double* a, const double* b) {
    const double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    const double limit = (a[3] + b[3]) + skin;
    return dx * dx + dy * dy + dz * dz <= limit * limit;
  };
  const double* cx = columns_.data();
  const double* cy = cx + columnStride_;
  const double* cz = cy + columnStride_;
  const double* cr = cz + columnStride_;
  Images images;
  QueryBox sphereBox[27];
  constexpr int kLanes = 4;  // one SSE register of floats
  alignas(16) float laneLo[3][kLanes], laneHi[3][kLanes];
  for (const Index leafId : leafNode_) {
    const Node& leaf = nodes_[static_cast<std::size_t>(leafId)];
    const Index first = -1 - leaf.right, end = leaf.end;
    // The leaf's box (its spheres' boxes) dilated by the skin meets every box of a sphere that one of
    // its spheres reaches.
    double lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
      lo[k] = static_cast<double>(leaf.lo[k]) - dilation;
      hi[k] = static_cast<double>(leaf.hi[k]) + dilation;
    }
    imagesOf(lo, hi, images);
    const bool directInside = images.count == 1;
    for (Index s = first; s < end; ++s) {  // pairs inside the leaf
      const double* ps = p + 4 * static_cast<std::ptrdiff_t>(s);
      for (Index t = s + 1; t < end; ++t) {
        const double* pt = p + 4 * static_cast<std::ptrdiff_t>(t);
        if constexpr (kCount) ++tests;
        if (directInside ? directPair(ps, pt) : spheresWithinReach(box_, ps, ps[3], pt, pt[3], skin)) emit(s, t);
      }
    }
    if (end == n) continue;
    candidates_.clear();
    // An image that meets no later leaf is dropped: no pair with a later leaf reaches through it.
    // (Pairs inside the leaf, above, kept every image.)
    int kept = 0;
    for (int k = 0; k < images.count; ++k) {
      QueryBox q;
      toQuery(lo, hi, images.shift[k], q);
      const std::size_t before = candidates_.size();
      visits += candidateLeaves(q, end);
      if (k == 0 || candidates_.size() > before) {
        for (int a = 0; a < 3; ++a) images.shift[kept][a] = images.shift[k][a];
        ++kept;
      }
    }
    images.count = kept;
    if (candidates_.empty()) continue;
    const bool direct = images.count == 1;
    if (direct) {
      // Up to 4 spheres of the leaf at once: their boxes against each candidate leaf's box as
      // one vector of tests, then the pair tests for the lanes that met it.
      for (Index s0 = first; s0 < end; s0 += kLanes) {
        const int lanes = static_cast<int>(std::min<Index>(kLanes, end - s0));
        for (int l = 0; l < kLanes; ++l) {
          if (l < lanes) {
            const double* ps = p + 4 * static_cast<std::ptrdiff_t>(s0 + l);
            const double reach = ps[3] + dilation;
            for (int k = 0; k < 3; ++k) {
              laneLo[k][l] = roundDown(ps[k] - reach);
              laneHi[k][l] = roundUp(ps[k] + reach);
            }
          } else {
            for (int k = 0; k < 3; ++k) {  // an empty box meets nothing
              laneLo[k][l] = std::numeric_limits<float>::infinity();
              laneHi[k][l] = -std::numeric_limits<float>::infinity();
            }
          }
        }
#if defined(__SSE2__)
        const __m128 lx = _mm_load_ps(laneLo[0]), ly = _mm_load_ps(laneLo[1]), lz = _mm_load_ps(laneLo[2]);
        const __m128 hx = _mm_load_ps(laneHi[0]), hy = _mm_load_ps(laneHi[1]), hz = _mm_load_ps(laneHi[2]);
#endif
        for (const Index c : candidates_) {
          const Node& cn = nodes_[static_cast<std::size_t>(c)];
          if constexpr (kCount) visits += static_cast<std::uint64_t>(lanes);
#if defined(__SSE2__)
          const __m128 mx =
              _mm_and_ps(_mm_cmple_ps(_mm_set1_ps(cn.lo[0]), hx), _mm_cmpge_ps(_mm_set1_ps(cn.hi[0]), lx));
          const __m128 my =
              _mm_and_ps(_mm_cmple_ps(_mm_set1_ps(cn.lo[1]), hy), _mm_cmpge_ps(_mm_set1_ps(cn.hi[1]), ly));
          const __m128 mz =
              _mm_and_ps(_mm_cmple_ps(_mm_set1_ps(cn.lo[2]), hz), _mm_cmpge_ps(_mm_set1_ps(cn.hi[2]), lz));
          auto mask = static_cast<unsigned>(_mm_movemask_ps(_mm_and_ps(_mm_and_ps(mx, my), mz)));
#else
          unsigned mask = 0;
          for (int l = 0; l < kLanes; ++l) {
            const bool meet = (cn.lo[0] <= laneHi[0][l]) & (cn.hi[0] >= laneLo[0][l]) & (cn.lo[1] <= laneHi[1][l]) &
                              (cn.hi[1] >= laneLo[1][l]) & (cn.lo[2] <= laneHi[2][l]) & (cn.hi[2] >= laneLo[2][l]);
            mask |= static_cast<unsigned>(meet) << l;
          }
#endif
          while (mask != 0) {
            const Index s = s0 + std::countr_zero(mask);
            mask &= mask - 1;
            const double* ps = p + 4 * static_cast<std::ptrdiff_t>(s);
            const Index t0 = -1 - cn.right;
            if constexpr (kCount) tests += static_cast<std::uint64_t>(cn.end - t0);
#if defined(__SSE2__)
            // Two pair tests per step on the slot-ordered columns, with directPair's operations in
            // its order (so the same results); the column past the last slot is padding.
            const __m128d sx = _mm_set1_pd(ps[0]), sy = _mm_set1_pd(ps[1]), sz = _mm_set1_pd(ps[2]);
            const __m128d sr = _mm_set1_pd(ps[3]), sk = _mm_set1_pd(skin);
            for (Index t = t0; t < cn.end; t += 2) {
              const __m128d dx = _mm_sub_pd(sx, _mm_loadu_pd(cx + t)), dy = _mm_sub_pd(sy, _mm_loadu_pd(cy + t)),
                            dz = _mm_sub_pd(sz, _mm_loadu_pd(cz + t));
              const __m128d d2 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(dx, dx), _mm_mul_pd(dy, dy)), _mm_mul_pd(dz, dz));
              const __m128d limit = _mm_add_pd(_mm_add_pd(sr, _mm_loadu_pd(cr + t)), sk);
              const int hit = _mm_movemask_pd(_mm_cmple_pd(d2, _mm_mul_pd(limit, limit)));
              if (hit != 0) [[unlikely]] {
                if (hit & 1) emit(s, t);
                if ((hit & 2) && t + 1 < cn.end) emit(s, t + 1);
              }
            }
#else
            for (Index t = t0; t < cn.end; ++t) {
              if (directPair(ps, p + 4 * static_cast<std::ptrdiff_t>(t))) emit(s, t);
            }
#endif
          }
        }
      }
      continue;
    }
    // A leaf reached through two images (a periodic length of exactly 2 cut-offs) is tested once.
    std::sort(candidates_.begin(), candidates_.end());
    candidates_.erase(std::unique(candidates_.begin(), candidates_.end()), candidates_.end());
    for (Index s = first; s < end; ++s) {
      const double* ps = p + 4 * static_cast<std::ptrdiff_t>(s);
      const double reach = ps[3] + dilation;
      const double slo[3] = {ps[0] - reach, ps[1] - reach, ps[2] - reach};
      const double shi[3] = {ps[0] + reach, ps[1] + reach, ps[2] + reach};
      for (int k = 0; k < images.count; ++k) toQuery(slo, shi, images.shift[k], sphereBox[k]);
      for (const Index c : candidates_) {
        const Node& cn = nodes_[static_cast<std::size_t>(c)];
        // The sphere's own box against the candidate leaf's, through every image. Met only
        // unshifted, no pair of the two reaches across a face (it would meet through that image):
        // the plain difference is exact there.
        if constexpr (kCount) visits += static_cast<std::uint64_t>(images.count);
        const bool plain = overlaps(cn, sphereBox[0]);
        bool imaged = false;
        for (int k = 1; k < images.count; ++k) imaged |= overlaps(cn, sphereBox[k]);
        if (!imaged) {
          if (!plain) continue;
          for (Index t = -1 - cn.right; t < cn.end; ++t) {
            const double* pt = p + 4 * static_cast<std::ptrdiff_t>(t);
            if constexpr (kCount) ++tests;
            if (directPair(ps, pt)) emit(s, t);
          }
          continue;
        }
        for (Index t = -1 - cn.right; t < cn.end; ++t) {
          const double* pt = p + 4 * static_cast<std::ptrdiff_t>(t);
          if constexpr (kCount) ++tests;
          if (spheresWithinReach(box_, ps, ps[3], pt, pt[3], skin)) emit(s, t);
        }
      }
    }
  }
  if constexpr (kCount) {
    counters_.pairTests += tests;
    counters_.cellAccesses += visits;
  }
}

void Lbvh::findPairs(const SphereView&, std::vector<Pair>& out) const {
  out.clear();
  if (nodes_.empty()) return;
  if (counting_) {
    pairsImpl<true>(out);
  } else {
    pairsImpl<false>(out);
  }
}

void Lbvh::findNeighbours(const SphereView&, Index i, double reach, std::vector<Index>& out) const {
  out.clear();
  if (!(reach >= 0.0 && reach <= skin_)) {
    throw ConfigError(fmt::format("findNeighbours: reach {} must lie in [0, skin = {}]", reach, skin_));
  }
  if (i < 0 || i >= static_cast<Index>(slotOf_.size())) {
    throw ConfigError(fmt::format("findNeighbours: particle {} out of range [0, {})", i, slotOf_.size()));
  }
  const Index slot = slotOf_[static_cast<std::size_t>(i)];
  const double* x = packed_.data() + 4 * static_cast<std::ptrdiff_t>(slot);
  const double d = x[3] + reach + tolerance_;
  const double lo[3] = {x[0] - d, x[1] - d, x[2] - d}, hi[3] = {x[0] + d, x[1] + d, x[2] + d};
  Images images;
  imagesOf(lo, hi, images);
  candidates_.clear();
  for (int k = 0; k < images.count; ++k) {
    QueryBox q;
    toQuery(lo, hi, images.shift[k], q);
    candidateLeaves(q, -1);
  }
  for (const Index c : candidates_) {
    const Node& cn = nodes_[static_cast<std::size_t>(c)];
    for (Index t = -1 - cn.right; t < cn.end; ++t) {
      const double* pt = packed_.data() + 4 * static_cast<std::ptrdiff_t>(t);
      if (t != slot && spheresWithinReach(box_, x, x[3], pt, pt[3], reach))
        out.push_back(sorted_[static_cast<std::size_t>(t)]);
    }
  }
  std::sort(out.begin(), out.end());
  if (images.count > 1) out.erase(std::unique(out.begin(), out.end()), out.end());
}

std::size_t Lbvh::memoryBytes() const {
  return nodes_.capacity() * sizeof(Node) + parent_.capacity() * sizeof(Index) + leafNode_.capacity() * sizeof(Index) +
         sorted_.capacity() * sizeof(Index) + slotOf_.capacity() * sizeof(Index) +
         static_cast<std::size_t>(packed_.size()) * sizeof(double) + columns_.capacity() * sizeof(double) +
         keys_.capacity() * sizeof(keys_[0]) + leafKey_.capacity() * sizeof(std::uint64_t) +
         (childLeft_.capacity() + childRight_.capacity()) * sizeof(Index) + work_.capacity() * sizeof(Pending) +
         stack_.capacity() * sizeof(Index) + candidates_.capacity() * sizeof(Index);
}

std::string Lbvh::describe() const {
  return fmt::format(
      "lbvh {} spheres, {} leaves of <= {}, depth {}, cost proxy {:.3g}x of the last build (rebuild "
      "above {:g}x), {} builds",
      sorted_.size(), leafNode_.size(), leafSize_, depth_, qualityRatio(), rebuildFactor_, rebuilds_);
}

void Lbvh::validate(const SphereView& spheres) const {
  const Index n = spheres.count();
  if (static_cast<Index>(sorted_.size()) != n) throw std::logic_error("lbvh: slot count differs from N");
  for (Index s = 0; s < n; ++s) {
    const Index i = sorted_[static_cast<std::size_t>(s)];
    if (slotOf_[static_cast<std::size_t>(i)] != s) throw std::logic_error(fmt::format("lbvh: slot of {} is stale", i));
    for (int k = 0; k < 3; ++k) {
      if (packed_(k, s) != spheres.centre(k, i)) throw std::logic_error(fmt::format("lbvh: stale centre of {}", i));
    }
  }
  if (n == 0) {
    if (!nodes_.empty()) throw std::logic_error("lbvh: nodes without spheres");
    return;
  }
  std::vector<Index> covered(static_cast<std::size_t>(n), 0);
  for (std::size_t p = 0; p < nodes_.size(); ++p) {
    const Node& nd = nodes_[p];
    auto inside = [&](const Node& c) {
      for (int k = 0; k < 3; ++k) {
        if (c.lo[k] < nd.lo[k] || c.hi[k] > nd.hi[k]) return false;
      }
      return true;
    };
    if (isLeaf(nd)) {
      for (Index t = -1 - nd.right; t < nd.end; ++t) {
        ++covered[static_cast<std::size_t>(t)];
        for (int k = 0; k < 3; ++k) {
          if (packed_(k, t) - packed_(3, t) < nd.lo[k] || packed_(k, t) + packed_(3, t) > nd.hi[k]) {
            throw std::logic_error(fmt::format("lbvh: sphere of slot {} outside its leaf box", t));
          }
        }
      }
    } else {
      const Node& a = nodes_[p + 1];
      const Node& b = nodes_[static_cast<std::size_t>(nd.right)];
      if (parent_[p + 1] != static_cast<Index>(p) ||
          parent_[static_cast<std::size_t>(nd.right)] != static_cast<Index>(p)) {
        throw std::logic_error(fmt::format("lbvh: parent links of node {} broken", p));
      }
      if (!inside(a) || !inside(b)) throw std::logic_error(fmt::format("lbvh: node {} does not bound its children", p));
      if (nd.end != b.end) throw std::logic_error(fmt::format("lbvh: slot range of node {} wrong", p));
    }
  }
  for (Index s = 0; s < n; ++s) {
    if (covered[static_cast<std::size_t>(s)] != 1)
      throw std::logic_error(fmt::format("lbvh: slot {} not in one leaf", s));
  }
}

}  // namespace polydem::broadphase
