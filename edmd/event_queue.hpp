#pragma once
// Indexed (4-ary) min-heap holding exactly one key (event time) per particle, Donev 2006
// (thesis), §3.4.1 and Algorithm 2, step 9: heap size = N, operations top, and
// update of an arbitrary particle's key (the partner of a collision, the claimed particle of a
// prediction) in O(log N). Nodes carry (key, particle) side by side so sifting touches one array, and
// the array starts 3 nodes before a 64-byte boundary so that the 4 children of every node (16-byte
// nodes 4k+1..4k+4) fill exactly one cache line: a sift level is one line, not two.
// Rejected: a calendar queue (faster for huge N, but its bucket width must track a collision rate that
// spans twelve decades during a compression) and several events per particle (Donev 2006, §3.4.1).
#include <cstddef>
#include <vector>

#include "core/huge_pages.hpp"
#include "core/types.hpp"

namespace polydem::edmd {

class EventQueue {
 public:
  /// `count` particles, every key +inf. O(N).
  void reset(Index count);
  /// Rebuild from the given keys (one per particle, same count as reset). O(N).
  void assign(const std::vector<double>& keys);
  Index size() const { return size_; }
  bool empty() const { return size_ == 0; }
  /// Particle with the smallest key (ties: any). Precondition: not empty.
  Index top() const { return nodes()[0].particle; }
  double topKey() const { return nodes()[0].key; }
  /// The particle most likely to be on top after the top's key grows: the smallest child of the root
  /// (the top itself if it has none). O(1); a prefetch hint for the event loop.
  Index runnerUp() const;
  double key(Index particle) const { return nodes()[static_cast<std::size_t>(position_[particle])].key; }
  /// Set a particle's key and restore the heap order. O(log N).
  void update(Index particle, double key);
  /// Heap order and position index consistent; throws std::logic_error (tests).
  void validate() const;

 private:
  static constexpr std::size_t kArity = 4;
  struct Node {
    double key;
    Index particle;
  };
  void siftUp(std::size_t k);
  void siftDown(std::size_t k);
  // Heap node k is storage_[offset_ + k]; offset_ puts node 0 at 48 mod 64 bytes (a copied queue stays
  // correct, only possibly misaligned).
  Node* nodes() { return storage_.data() + offset_; }
  const Node* nodes() const { return storage_.data() + offset_; }
  LargeVector<Node> storage_;
  std::size_t offset_ = 0;
  Index size_ = 0;
  LargeVector<Index> position_;
};

}  // namespace polydem::edmd
