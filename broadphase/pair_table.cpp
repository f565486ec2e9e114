#include "broadphase/pair_table.hpp"

#include <algorithm>

namespace polydem::broadphase {

void PairTable::assign(std::vector<Pair>&& raw, Index count) {
  count_ = count;
  std::sort(raw.begin(), raw.end());
  raw.erase(std::unique(raw.begin(), raw.end()), raw.end());
  pairs_.swap(raw);
  raw.clear();
  adjacencyValid_ = false;
}

void PairTable::replaceRows(const std::vector<char>& dropped, std::vector<Pair>& extra) {
  std::sort(extra.begin(), extra.end());
  extra.erase(std::unique(extra.begin(), extra.end()), extra.end());
  merged_.clear();
  merged_.reserve(pairs_.size() + extra.size());
  auto e = extra.begin();
  for (const Pair& p : pairs_) {
    if (dropped[p.i] || dropped[p.j]) continue;
    for (; e != extra.end() && *e < p; ++e) merged_.push_back(*e);
    if (e != extra.end() && *e == p) ++e;  // kept pair also re-found (cannot happen, but stay unique)
    merged_.push_back(p);
  }
  merged_.insert(merged_.end(), e, extra.end());
  pairs_.swap(merged_);
  adjacencyValid_ = false;
}

void PairTable::buildAdjacency() const {
  start_.assign(static_cast<std::size_t>(count_) + 1, 0);
  for (const Pair& p : pairs_) {
    ++start_[p.i + 1];
    ++start_[p.j + 1];
  }
  for (Index i = 0; i < count_; ++i) start_[i + 1] += start_[i];
  adjacent_.resize(2 * pairs_.size());
  std::vector<Index> fill(start_.begin(), start_.end() - 1);
  // Pairs are sorted by (i, j): row i receives its j > i in ascending order after its j < i, which
  // arrive ascending too (they come from earlier rows), so every row ends up sorted.
  for (const Pair& p : pairs_) {
    adjacent_[fill[p.i]++] = p.j;
    adjacent_[fill[p.j]++] = p.i;
  }
  adjacencyValid_ = true;
}

void PairTable::neighbours(const SphereView& spheres, const Box& box, Index i, double reach,
                           std::vector<Index>& out) const {
  out.clear();
  if (!adjacencyValid_) buildAdjacency();
  for (Index k = start_[i]; k < start_[i + 1]; ++k) {
    const Index j = adjacent_[k];
    if (withinReach(spheres, box, i, j, reach)) out.push_back(j);
  }
}

std::size_t PairTable::memoryBytes() const {
  return pairs_.capacity() * sizeof(Pair) + merged_.capacity() * sizeof(Pair) +
         (start_.capacity() + adjacent_.capacity()) * sizeof(Index);
}

}  // namespace polydem::broadphase
