#include "integrators/verlet_list.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "broadphase/parallel.hpp"
#include "core/errors.hpp"

namespace polydem::integrators {

VerletList::VerletList(std::unique_ptr<broadphase::BroadPhase> backend, double skin)
    : backend_(std::move(backend)), skin_(skin), outerSkin_(skin) {
  if (!backend_) throw ConfigError("VerletList: no broad-phase backend");
  if (!(skin >= 0.0 && std::isfinite(skin))) {
    throw ConfigError(fmt::format("run.skin must be a finite number >= 0, got {}", skin));
  }
}

void VerletList::setOuterSkin(double outer) {
  if (!(outer >= skin_ && std::isfinite(outer))) {
    throw ConfigError(fmt::format("outer skin must be finite and >= the skin {}, got {}", skin_, outer));
  }
  outerSkin_ = outer;
}

void VerletList::setThreads(int threads) {
  if (threads < 1) throw ConfigError(fmt::format("run.threads must be >= 1, got {}", threads));
  threads_ = threads;
  backend_->setThreads(threads);
}

namespace {

/// Sort the entries [begin, end) of one row (distinct values). Rows hold a handful of entries, where
/// insertion sort beats std::sort; the rows of the few large spheres of a wide distribution hold hundreds.
void sortRow(Index* begin, Index* end) {
  if (end - begin > 48) {
    std::sort(begin, end);
    return;
  }
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

/// Gap between a sphere (centre coordinate x along the face's axis, radius r) and wall face `face` (2 axis:
/// the face at 0, 2 axis + 1: the face at L): the one wall-candidate criterion of fill() and cutFromOuter().
double wallGap(const Box& box, int face, double x, double r) {
  return (face % 2 == 0 ? x : box.length(face / 2) - x) - r;
}

}  // namespace

void VerletList::build(const SphereView& spheres, const Box& box) {
  backend_->build(spheres, box, outerSkin_);
  backend_->findPairChunks(spheres, pairs_);
  ++builds_;
  if (twoLevel()) {
    fill(spheres, box, outerSkin_, outer_);
    outerReference_ = spheres.centre;
    cutFromOuter(spheres, box);
    return;
  }
  fill(spheres, box, skin_, list_);
  finish(spheres);
}

void VerletList::refine(const SphereView& spheres, const Box& box) {
  if (!twoLevel()) throw std::logic_error("VerletList::refine: one-level list (no outer skin)");
  cutFromOuter(spheres, box);
  ++refines_;
}

void cutList(const contact::ContactList& outer, const SphereView& spheres, const Box& box, double skin,
             contact::ContactList& target) {
  const Index n = spheres.count();
  target.offset.resize(static_cast<std::size_t>(n) + 1);
  target.neighbour.resize(outer.neighbour.size());  // buffers only grow
  Index k = 0;
  target.offset[0] = 0;
  for (Index i = 0; i < n; ++i) {
    for (Index c = outer.offset[i]; c < outer.offset[i + 1]; ++c) {
      // Written always, kept by advancing k: about half the outer candidates are within the skin, at random,
      // so a branch here mispredicts once per two candidates.
      const Index j = outer.neighbour[c];
      target.neighbour[static_cast<std::size_t>(k)] = j;
      k += static_cast<Index>(broadphase::withinReach(spheres, box, i, j, skin));
    }
    target.offset[static_cast<std::size_t>(i) + 1] = k;
  }
  target.neighbour.resize(static_cast<std::size_t>(k));
  target.wallParticle.clear();
  target.wallFace.clear();
  for (std::size_t c = 0; c < outer.wallParticle.size(); ++c) {
    const Index i = outer.wallParticle[c];
    const int face = outer.wallFace[c];
    if (wallGap(box, face, spheres.centre(face / 2, i), spheres.radius[i]) <= skin) {
      target.wallParticle.push_back(i);
      target.wallFace.push_back(static_cast<std::int8_t>(face));
    }
  }
}

void VerletList::cutFromOuter(const SphereView& spheres, const Box& box) {
  cutList(outer_, spheres, box, skin_, list_);
  finish(spheres);
}

double VerletList::outerDrift(const Eigen::Matrix3Xd& centres) const {
  double first = 0.0, second = 0.0;
  const Index n = centres.cols();
  if (outerReference_.cols() != n) return std::numeric_limits<double>::infinity();
  for (Index i = 0; i < n; ++i) {
    const double dsq = (centres.col(i) - outerReference_.col(i)).squaredNorm();
    if (!std::isfinite(dsq)) return std::numeric_limits<double>::infinity();
    if (dsq > second) {
      second = std::min(dsq, first);
      first = std::max(dsq, first);
    }
  }
  return std::sqrt(first) + std::sqrt(second);
}

void VerletList::finish(const SphereView& spheres) {
  if (blocks_ > 1) list_.buildBlocks(blocks_);
  reference_ = spheres.centre;  // same size after the first build: no allocation
  referenceRadius_ = spheres.radius;
}

void VerletList::fill(const SphereView& spheres, const Box& box, double reach, contact::ContactList& target) {
  const Index n = spheres.count();

  // CSR by i (a stable counting sort of the pairs), then each row sorted by j: canonical (i, j) order.
  // Several threads: each owns a contiguous range of rows and scans every chunk for the pairs of its rows
  // (no atomics; the pairs' cell order keeps the range test predictable), so the rows are filled in the
  // serial order, and the pairs are read once per thread.
  const std::size_t chunks = pairs_.size();
  const int parts = broadphase::parallel::chunkCount(threads_, static_cast<std::size_t>(n)) > 1
                        ? broadphase::parallel::usable(threads_)
                        : 1;
  target.offset.assign(static_cast<std::size_t>(n) + 1, 0);
  Index* offset = target.offset.data();
  broadphase::parallel::forEachRange(threads_, static_cast<std::size_t>(n), static_cast<std::size_t>(parts),
                                     [&](std::size_t lo, std::size_t hi) {
                                       for (std::size_t k = 0; k < chunks; ++k) {
                                         for (const broadphase::Pair& p : pairs_[k]) {
                                           if (static_cast<std::size_t>(p.i) - lo < hi - lo) ++offset[p.i + 1];
                                         }
                                       }
                                     });
  for (Index i = 0; i < n; ++i) offset[i + 1] += offset[i];
  fill_.assign(target.offset.begin(), target.offset.end() - 1);
  target.neighbour.resize(static_cast<std::size_t>(offset[n]));
  Index* neighbour = target.neighbour.data();
  Index* fill = fill_.data();
  broadphase::parallel::forEachRange(threads_, static_cast<std::size_t>(n), static_cast<std::size_t>(parts),
                                     [&](std::size_t lo, std::size_t hi) {
                                       for (std::size_t k = 0; k < chunks; ++k) {
                                         for (const broadphase::Pair& p : pairs_[k]) {
                                           if (static_cast<std::size_t>(p.i) - lo < hi - lo) {
                                             neighbour[fill[p.i]++] = p.j;
                                           }
                                         }
                                       }
                                     });
  const std::size_t rowParts = broadphase::parallel::chunkCount(threads_, static_cast<std::size_t>(n));
  broadphase::parallel::forEachRange(threads_, static_cast<std::size_t>(n), rowParts,
                                     [&](std::size_t b, std::size_t e) {
                                       for (std::size_t i = b; i < e; ++i) {
                                         sortRow(neighbour + offset[i], neighbour + offset[i + 1]);
                                       }
                                     });

  // Wall candidates: particles within the skin of a non-periodic face.
  target.wallParticle.clear();
  target.wallFace.clear();
  if (box.hasWalls()) {
    for (Index i = 0; i < n; ++i) {
      const double r = spheres.radius[i];
      for (int axis = 0; axis < 3; ++axis) {
        if (box.periodic(axis)) continue;
        const double x = spheres.centre(axis, i);
        for (const int face : {2 * axis, 2 * axis + 1}) {
          if (wallGap(box, face, x, r) <= reach) {
            target.wallParticle.push_back(i);
            target.wallFace.push_back(static_cast<std::int8_t>(face));
          }
        }
      }
    }
  }
}

void VerletList::keys(std::span<const Index> ids, std::vector<std::uint64_t>& pairKeys,
                      std::vector<std::uint64_t>& wallKeys) const {
  pairKeys.resize(list_.neighbour.size());
  const Index n = list_.particleCount();
  const std::size_t parts = broadphase::parallel::chunkCount(threads_, static_cast<std::size_t>(n));
  broadphase::parallel::forEachRange(threads_, static_cast<std::size_t>(n), parts, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      for (Index c = list_.offset[i]; c < list_.offset[i + 1]; ++c) {
        pairKeys[static_cast<std::size_t>(c)] = contact::pairKey(ids[i], ids[list_.neighbour[c]]);
      }
    }
  });
  wallKeys.resize(list_.wallParticle.size());
  for (std::size_t c = 0; c < wallKeys.size(); ++c) {
    wallKeys[c] = contact::wallKey(ids[list_.wallParticle[c]], list_.wallFace[c]);
  }
}

std::size_t VerletList::adviseHugePages(HugePageAdvice& advice, std::size_t slot) const {
  advice.apply(slot++, reference_.data(), static_cast<std::size_t>(reference_.size()) * sizeof(double));
  advice.apply(slot++, list_.offset.data(), list_.offset.capacity() * sizeof(Index));
  advice.apply(slot++, list_.neighbour.data(), list_.neighbour.capacity() * sizeof(Index));
  return slot;
}

std::size_t VerletList::memoryBytes() const {
  return backend_->memoryBytes() + list_.memoryBytes() + outer_.memoryBytes() + pairs_.memoryBytes() +
         fill_.capacity() * sizeof(Index) +
         static_cast<std::size_t>(reference_.size() + referenceRadius_.size() + outerReference_.size()) *
             sizeof(double);
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
