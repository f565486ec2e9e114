#pragma once
// The event calendar: one key (event time) per particle, Donev 2006 (thesis), §3.4.1 and Algorithm 2,
// step 9, with the near future in a small heap and the rest in time buckets (the layout of the bounded
// event calendars of Paul, J. Comput. Phys. 221 (2007) 615, used by Smallenburg's EDMD codes).
//
// Keys at or before the end of the current bucket sit in an indexed 4-ary min-heap (nodes (key, particle)
// side by side; the array starts 3 nodes before a 64-byte boundary so that the 4 children of a node fill
// one cache line); later keys wait, unsorted, in bucket lists of width w, and keys beyond the last bucket
// (and +inf) in an overflow list. When the heap runs empty the next non-empty bucket moves into it; when
// the buckets run out the overflow is spread over a new range.
//
// A list is a chain of 64-byte chunks of 15 particle indices (from one pool, reused through a free list),
// and leaving a list is lazy: the particle's slot says where it is now, and an entry whose particle's slot
// names another place (or that repeats a particle already taken) is stale and skipped when its list is
// emptied. So a key update that leaves a list writes nothing there (and one that stays in its bucket
// nothing at all), a push stores into one line without loading from it, and emptying a list reads its
// entries a chunk at a time, their particles' keys and slots loading in parallel. A doubly linked list
// through the particles made both a chain of dependent cache misses: 8% of the run time at 10^5 particles
// for the emptying alone. Stale entries are bounded: when the lists hold more than 3N + 1024 entries they
// are rebuilt from the keys (O(N), at most once per 2N updates). The bucket index
// floor((t - base) / w) is monotone in t, so every heap key precedes every bucketed key and the pop order
// is exactly that of one heap ordered by (key, particle): ties go to the lower particle index, so the
// order does not depend on the history of the structure (the test compares it with an ordered set).
//
// The width follows the measured rate of key updates: every `count` updates it is set to about
// kHeapTarget / rate (the heap then holds some tens of keys) when it is off by more than 2x, by a rebuild
// in O(N); a compression changes the collision rate by decades, a little at a time. Until the first
// measurement (and whenever no time has passed) every finite key stays in the heap, which is the plain
// heap of before.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/huge_pages.hpp"
#include "core/types.hpp"

namespace polydem::edmd {

class EventQueue {
 public:
  /// `count` particles, every key +inf. O(N).
  void reset(Index count);
  /// Rebuild from the given keys (one per particle). O(N). Keeps the bucket width measured so far.
  void assign(const std::vector<double>& keys);
  Index size() const { return size_; }
  bool empty() const { return size_ == 0; }
  /// Particle with the smallest key (ties: the lowest index). Precondition: not empty.
  Index top() const { return nodes()[0].particle; }
  double topKey() const { return nodes()[0].key; }
  /// The particle most likely to be on top after the top's key grows: the smallest child of the heap's
  /// root other than `skip` (the top's collision partner, whose key grows too; the top itself if there is
  /// no such child). O(1); a prefetch hint for the event loop.
  Index runnerUp(Index skip = -1) const {
    const Node* const heap = nodes();
    const std::size_t last = std::min<std::size_t>(kArity, heapSize_ > 0 ? static_cast<std::size_t>(heapSize_) - 1 : 0);
    std::size_t best = 0;
    for (std::size_t c = 1; c <= last; ++c) {
      const bool better = heap[c].particle != skip && (best == 0 || before(heap[c], heap[best]));
      best = better ? c : best;
    }
    return heap[best].particle;
  }
  double key(Index particle) const { return key_[static_cast<std::size_t>(particle)]; }
  /// Set a particle's key and restore the order. O(1) for a key beyond the current bucket, O(log h)
  /// in the heap of h near keys.
  void update(Index particle, double key);
  /// Heap order, bucket membership, links and the position index consistent; throws std::logic_error.
  void validate() const;

  /// Bucket width now (0: no width measured yet, every finite key in the heap).
  double bucketWidth() const { return width_; }
  /// Keys in the heap now.
  Index heapSize() const { return heapSize_; }
  /// Width rebuilds so far (tests, counters).
  std::int64_t rebuilds() const { return rebuilds_; }
  /// Rebuilds that only dropped stale list entries (tests).
  std::int64_t compactions() const { return compactions_; }
  /// List entries held now, stale ones included (tests: bounded by 3N + 1024).
  std::int64_t listEntries() const { return entries_; }

  /// Keys the heap is meant to hold on average.
  static constexpr double kHeapTarget = 48.0;

 private:
  static constexpr std::size_t kArity = 4;
  struct Node {
    double key;
    Index particle;
  };
  // (key, particle) lexicographic, without branches on the result.
  static bool before(const Node& a, const Node& b) {
    return (a.key < b.key) | ((a.key == b.key) & (a.particle < b.particle));
  }
  // -1: the heap; 0..buckets-1: that bucket; buckets: the overflow.
  std::int64_t placeOf(double key) const;
  void place(Index particle);  // by key_, into a list or appended to the heap (heap order not restored)
  static Index tagOf(std::int64_t list) { return static_cast<Index>(-list - 1); }  // slot_ of a list member
  void siftUp(std::size_t k);
  void siftDown(std::size_t k);
  void heapPush(Index particle);
  void heapErase(std::size_t k);
  void heapify();
  void listPush(std::int64_t list, Index particle);
  void clearLists();
  /// Take the whole list (its entries to `out`, stale ones included) and return its chunks to the pool.
  void drainList(std::int64_t list, std::vector<Index>& out);
  void refill();  // the heap is empty: move the next non-empty bucket (or the spread overflow) into it
  void rebuild(double width);
  void spreadAll();  // every key placed again from the earliest one (stale entries dropped); O(N)
  void tune();

  Node* nodes() { return storage_.data() + offset_; }
  const Node* nodes() const { return storage_.data() + offset_; }
  LargeVector<Node> storage_;
  std::size_t offset_ = 0;
  Index size_ = 0;
  Index heapSize_ = 0;
  LargeVector<double> key_;
  // slot_[p] >= 0: heap position; < 0: list -slot_[p] - 1 (a bucket, or the overflow = buckets_).
  LargeVector<Index> slot_;
  static constexpr int kChunkEntries = 15;
  struct alignas(64) Chunk {
    Index next;                  // next chunk of the list (or of the free list); -1: none
    Index entry[kChunkEntries];  // full, except in a list's tail chunk
  };
  // The fill of the tail chunk is kept here, not in the chunk, so that a push only stores into the chunk
  // (a chunk written long ago is usually out of cache; a load from it would stall the event loop).
  struct ListEnds {
    Index head = -1, tail = -1;  // chunks; -1: empty
    Index fill = 0;              // entries in the tail chunk
    Index unused = 0;
  };
  LargeVector<Chunk> pool_;
  Index free_ = -1;              // first free chunk
  std::vector<ListEnds> lists_;  // at least buckets_ + 1; entries may be stale (see above)
  std::vector<Index> drained_;   // a list's entries while they are moved
  std::int64_t entries_ = 0;     // entries in all lists
  std::int64_t compactions_ = 0;
  std::int64_t buckets_ = 0;  // lists 0..buckets_-1 are buckets, list buckets_ the overflow
  std::int64_t current_ = 0;  // keys with floor((t - base_) / width_) <= current_ are in the heap
  bool spread_ = false;       // false: every key (+inf too) in the heap, no lists in use
  double base_ = 0.0, width_ = 0.0, inverseWidth_ = 0.0;
  std::int64_t updates_ = 0, rebuilds_ = 0;
  double tuneTime_ = 0.0;
};

}  // namespace polydem::edmd
