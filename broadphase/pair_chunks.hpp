#pragma once
// Pairs found in chunks of work: a threaded findPairs fills one buffer per chunk (cells or slots of the
// index, in the order the serial search visits them), so that the chunks concatenated in order are
// exactly the serial output, whatever the thread count. VerletList reads the chunks directly (no
// concatenated copy); BroadPhase::findPairs concatenates them.
//
// Buffers only grow. A chunk whose pairs come within 3/4 of its capacity reserves twice its size, so that
// the small fluctuations of a DEM run's pair counts between rebuilds never reallocate once warmed up.
#include <algorithm>
#include <cstddef>
#include <vector>

#include "broadphase/broad_phase.hpp"

namespace polydem::broadphase {

class PairChunks {
 public:
  /// Start a search of `count` chunks (>= 1): every chunk emptied, capacities kept.
  void reset(std::size_t count) {
    if (chunks_.size() < count) chunks_.resize(count);
    used_ = count;
    for (std::size_t k = 0; k < used_; ++k) chunks_[k].clear();
  }
  std::size_t size() const { return used_; }
  std::vector<Pair>& operator[](std::size_t k) { return chunks_[k]; }
  const std::vector<Pair>& operator[](std::size_t k) const { return chunks_[k]; }

  /// Pairs in all chunks.
  std::size_t pairCount() const {
    std::size_t total = 0;
    for (std::size_t k = 0; k < used_; ++k) total += chunks_[k].size();
    return total;
  }
  /// Reserve headroom in chunk k after it was filled (see the top of the file).
  void keepHeadroom(std::size_t k) {
    std::vector<Pair>& c = chunks_[k];
    if (4 * c.size() > 3 * c.capacity()) c.reserve(2 * c.size());
  }
  /// The chunks in order into `out` (cleared first).
  void concatenate(std::vector<Pair>& out) const {
    out.clear();
    out.reserve(pairCount());
    for (std::size_t k = 0; k < used_; ++k) out.insert(out.end(), chunks_[k].begin(), chunks_[k].end());
  }
  std::size_t memoryBytes() const {
    std::size_t bytes = chunks_.capacity() * sizeof(std::vector<Pair>);
    for (const std::vector<Pair>& c : chunks_) bytes += c.capacity() * sizeof(Pair);
    return bytes;
  }

 private:
  std::vector<std::vector<Pair>> chunks_;
  std::size_t used_ = 0;
};

}  // namespace polydem::broadphase
