#include "integrators/verlet_list.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "core/errors.hpp"

namespace polydem::integrators {

VerletList::VerletList(std::unique_ptr<broadphase::BroadPhase> backend, double skin)
    : backend_(std::move(backend)), skin_(skin) {
  if (!backend_) throw ConfigError("VerletList: no broad-phase backend");
  if (!(skin >= 0.0 && std::isfinite(skin))) {
    throw ConfigError(fmt::format("run.skin must be a finite number >= 0, got {}", skin));
  }
}

void VerletList::build(const SphereView& spheres, const Box& box) {
  const Index n = spheres.count();
  backend_->build(spheres, box, skin_);
  backend_->findPairs(spheres, pairs_);
  ++builds_;

  // CSR by i (counting sort, stable), then each short row sorted by j: canonical (i, j) order.
  list_.offset.assign(static_cast<std::size_t>(n) + 1, 0);
  for (const broadphase::Pair& p : pairs_) ++list_.offset[static_cast<std::size_t>(p.i) + 1];
  for (Index i = 0; i < n; ++i) list_.offset[i + 1] += list_.offset[i];
  fill_.assign(list_.offset.begin(), list_.offset.end() - 1);
  list_.neighbour.resize(pairs_.size());
  for (const broadphase::Pair& p : pairs_) list_.neighbour[static_cast<std::size_t>(fill_[p.i]++)] = p.j;
  for (Index i = 0; i < n; ++i) {
    Index* begin = list_.neighbour.data() + list_.offset[i];
    Index* end = list_.neighbour.data() + list_.offset[i + 1];
    // Rows hold a handful of entries: insertion sort beats std::sort here.
    for (Index* a = begin + 1; a < end; ++a) {
      const Index value = *a;
      Index* b = a;
      while (b > begin && *(b - 1) > value) {
        *b = *(b - 1);
        --b;
      }
      *b = value;
    }
  }

  // Wall candidates: particles within the skin of a non-periodic face.
  list_.wallParticle.clear();
  list_.wallFace.clear();
  if (box.hasWalls()) {
    for (Index i = 0; i < n; ++i) {
      const double r = spheres.radius[i];
      for (int axis = 0; axis < 3; ++axis) {
        if (box.periodic(axis)) continue;
        const double x = spheres.centre(axis, i);
        if (x - r <= skin_) {
          list_.wallParticle.push_back(i);
          list_.wallFace.push_back(static_cast<std::int8_t>(2 * axis));
        }
        if (box.length(axis) - x - r <= skin_) {
          list_.wallParticle.push_back(i);
          list_.wallFace.push_back(static_cast<std::int8_t>(2 * axis + 1));
        }
      }
    }
  }
  if (blocks_ > 1) list_.buildBlocks(blocks_);
  reference_ = spheres.centre;  // same size after the first build: no allocation
  referenceRadius_ = spheres.radius;
}

void VerletList::keys(std::span<const Index> ids, std::vector<std::uint64_t>& pairKeys,
                      std::vector<std::uint64_t>& wallKeys) const {
  pairKeys.resize(list_.neighbour.size());
  const Index n = list_.particleCount();
  for (Index i = 0; i < n; ++i) {
    for (Index c = list_.offset[i]; c < list_.offset[i + 1]; ++c) {
      pairKeys[static_cast<std::size_t>(c)] = contact::pairKey(ids[i], ids[list_.neighbour[c]]);
    }
  }
  wallKeys.resize(list_.wallParticle.size());
  for (std::size_t c = 0; c < wallKeys.size(); ++c) {
    wallKeys[c] = contact::wallKey(ids[list_.wallParticle[c]], list_.wallFace[c]);
  }
}

std::size_t VerletList::memoryBytes() const {
  return backend_->memoryBytes() + list_.memoryBytes() + pairs_.capacity() * sizeof(broadphase::Pair) +
         fill_.capacity() * sizeof(Index) +
         static_cast<std::size_t>(reference_.size() + referenceRadius_.size()) * sizeof(double);
}

void VerletList::validate(const SphereView& spheres, const Box& box) const {
  const Index n = spheres.count();
  if (list_.particleCount() != n) throw std::logic_error("VerletList: row count differs from the sphere count");
  std::size_t expected = 0;
  for (Index i = 0; i < n; ++i) {
    Index previous = i;
    for (Index c = list_.offset[i]; c < list_.offset[i + 1]; ++c) {
      const Index j = list_.neighbour[c];
      if (j <= previous) throw std::logic_error(fmt::format("VerletList: row {} not ascending above i", i));
      if (!broadphase::withinReach(spheres, box, i, j, skin_)) {
        throw std::logic_error(fmt::format("VerletList: pair ({}, {}) is not within the skin", i, j));
      }
      previous = j;
    }
    for (Index j = i + 1; j < n; ++j) expected += broadphase::withinReach(spheres, box, i, j, skin_) ? 1 : 0;
  }
  if (expected != list_.pairCount()) {
    throw std::logic_error(fmt::format("VerletList: {} pairs listed, {} within the skin", list_.pairCount(), expected));
  }
}

}  // namespace polydem::integrators
