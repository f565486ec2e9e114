#include "edmd/event_queue.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace polydem::edmd {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
// Buckets per kHeapTarget keys: the buckets span about this many update intervals of every particle.
constexpr double kSpan = 4.0;
}  // namespace

void EventQueue::reset(Index count) {
  // Node k sits at byte 16 (k + 3) from a 64-byte boundary: children 4k+1..4k+4 start at 64 (k + 1).
  storage_.assign(static_cast<std::size_t>(count) + 8, Node{0.0, 0});
  const auto base = reinterpret_cast<std::uintptr_t>(storage_.data());
  const std::uintptr_t aligned = (base + 63) & ~std::uintptr_t{63};
  offset_ = (aligned + 48 - base) / sizeof(Node);  // < 7 nodes (malloc aligns to at least 16 bytes)
  const std::size_t n = static_cast<std::size_t>(count);
  size_ = count;
  heapSize_ = count;
  key_.assign(n, kInf);
  slot_.resize(n);
  buckets_ = 0;
  clearLists();
  current_ = 0;
  spread_ = false;
  base_ = 0.0;
  width_ = 0.0;
  inverseWidth_ = 0.0;
  updates_ = 0;
  tuneTime_ = 0.0;
  Node* const heap = nodes();
  for (Index i = 0; i < count; ++i) {  // equal keys in index order: a valid heap
    heap[i] = {kInf, i};
    slot_[static_cast<std::size_t>(i)] = i;
  }
}

void EventQueue::assign(const std::vector<double>& keys) {
  const double width = width_;
  const std::int64_t rebuilds = rebuilds_;
  reset(static_cast<Index>(keys.size()));
  std::copy(keys.begin(), keys.end(), key_.begin());
  if (width > 0.0) {
    rebuild(width);
  } else {
    Node* const heap = nodes();
    for (std::size_t i = 0; i < keys.size(); ++i) heap[i].key = keys[i];
    heapify();
  }
  rebuilds_ = rebuilds;
  tuneTime_ = size_ > 0 ? topKey() : 0.0;
}

std::int64_t EventQueue::placeOf(double key) const {
  if (!spread_) return -1;
  if (!(key < kInf)) return buckets_;
  const double d = (key - base_) * inverseWidth_;  // monotone in key: the buckets keep the order
  if (d < static_cast<double>(current_ + 1)) return -1;
  if (d < static_cast<double>(buckets_)) return static_cast<std::int64_t>(d);
  return buckets_;
}

void EventQueue::place(Index particle) {
  const std::int64_t to = placeOf(key_[static_cast<std::size_t>(particle)]);
  if (to >= 0) {
    listPush(to, particle);
    return;
  }
  const std::size_t k = static_cast<std::size_t>(heapSize_++);
  nodes()[k] = Node{key_[static_cast<std::size_t>(particle)], particle};
  slot_[static_cast<std::size_t>(particle)] = static_cast<Index>(k);
}

void EventQueue::update(Index particle, double key) {
  const std::size_t p = static_cast<std::size_t>(particle);
  key_[p] = key;
  const std::int64_t to = placeOf(key);
  const Index s = slot_[p];
  if (s >= 0) {
    if (to < 0) {
      Node& node = nodes()[s];
      const double old = node.key;
      node.key = key;
      if (key < old) {
        siftUp(static_cast<std::size_t>(s));
      } else if (key > old) {
        siftDown(static_cast<std::size_t>(s));
      }
    } else {
      heapErase(static_cast<std::size_t>(s));
      listPush(to, particle);
      if (heapSize_ == 0) refill();
    }
  } else if (to < 0) {
    heapPush(particle);  // its list entry is now stale
  } else if (tagOf(to) != s) {
    listPush(to, particle);
  }  // else: still in its list, whose entry stays valid
  if (++updates_ >= size_) tune();
  if (entries_ > 3 * static_cast<std::int64_t>(size_) + 1024) {
    ++compactions_;
    spreadAll();
  }
}

// ---------------------------------------------------------------------------------------------------
// The heap of near keys. A 4-ary heap: half the levels of a binary one, and the four children of a node
// share a cache line, so a sift touches fewer lines; the smallest child is picked without branches
// (which child wins is unpredictable).

void EventQueue::siftUp(std::size_t k) {
  Node* const heap = nodes();
  const Node node = heap[k];
  while (k > 0) {
    const std::size_t parent = (k - 1) / kArity;
    if (!before(node, heap[parent])) break;
    heap[k] = heap[parent];
    slot_[static_cast<std::size_t>(heap[k].particle)] = static_cast<Index>(k);
    k = parent;
  }
  heap[k] = node;
  slot_[static_cast<std::size_t>(node.particle)] = static_cast<Index>(k);
}

void EventQueue::siftDown(std::size_t k) {
  Node* const heap = nodes();
  const Node node = heap[k];
  const std::size_t n = static_cast<std::size_t>(heapSize_);
  for (;;) {
    const std::size_t first = kArity * k + 1;
    if (first >= n) break;
    // The next level's line is one of the four children's child lines; fetch all four while this level's
    // minimum is found, so that the levels' loads overlap instead of following one another.
    const std::size_t grand = kArity * first + 1;
    if (grand < n) {
      for (std::size_t c = 0; c < kArity; ++c) __builtin_prefetch(heap + std::min(grand + kArity * c, n - 1));
    }
    std::size_t best = first;
    if (first + kArity <= n) {
      const std::size_t a = first + static_cast<std::size_t>(before(heap[first + 1], heap[first]));
      const std::size_t b = first + 2 + static_cast<std::size_t>(before(heap[first + 3], heap[first + 2]));
      best = before(heap[b], heap[a]) ? b : a;
    } else {
      for (std::size_t c = first + 1; c < n; ++c) best = before(heap[c], heap[best]) ? c : best;
    }
    if (!before(heap[best], node)) break;
    heap[k] = heap[best];
    slot_[static_cast<std::size_t>(heap[k].particle)] = static_cast<Index>(k);
    k = best;
  }
  heap[k] = node;
  slot_[static_cast<std::size_t>(node.particle)] = static_cast<Index>(k);
}

void EventQueue::heapPush(Index particle) {
  const std::size_t k = static_cast<std::size_t>(heapSize_++);
  nodes()[k] = Node{key_[static_cast<std::size_t>(particle)], particle};
  siftUp(k);
}

void EventQueue::heapErase(std::size_t k) {
  Node* const heap = nodes();
  const std::size_t last = static_cast<std::size_t>(--heapSize_);
  if (k == last) return;
  heap[k] = heap[last];
  if (k > 0 && before(heap[k], heap[(k - 1) / kArity])) {
    siftUp(k);
  } else {
    siftDown(k);
  }
}

void EventQueue::heapify() {
  const std::size_t n = static_cast<std::size_t>(heapSize_);
  Node* const heap = nodes();
  for (std::size_t k = 0; k < n; ++k) slot_[static_cast<std::size_t>(heap[k].particle)] = static_cast<Index>(k);
  if (n < 2) return;
  for (std::size_t k = (n - 2) / kArity + 1; k-- > 0;) siftDown(k);
}

// ---------------------------------------------------------------------------------------------------
// Bucket lists and their hand-over to the heap

void EventQueue::listPush(std::int64_t list, Index particle) {
  ListEnds& ends = lists_[static_cast<std::size_t>(list)];
  if (ends.tail < 0 || ends.fill == kChunkEntries) {
    Index c = free_;
    if (c >= 0) {
      free_ = pool_[static_cast<std::size_t>(c)].next;
    } else {
      c = static_cast<Index>(pool_.size());
      pool_.emplace_back();
    }
    pool_[static_cast<std::size_t>(c)].next = -1;
    if (ends.tail < 0) {
      ends.head = c;
    } else {
      pool_[static_cast<std::size_t>(ends.tail)].next = c;
    }
    ends.tail = c;
    ends.fill = 0;
  }
  pool_[static_cast<std::size_t>(ends.tail)].entry[ends.fill++] = particle;
  ++entries_;
  slot_[static_cast<std::size_t>(particle)] = tagOf(list);
}

void EventQueue::clearLists() {
  lists_.assign(static_cast<std::size_t>(buckets_) + 1, ListEnds{});
  pool_.clear();  // keeps its capacity
  free_ = -1;
  entries_ = 0;
}

void EventQueue::drainList(std::int64_t list, std::vector<Index>& out) {
  ListEnds& ends = lists_[static_cast<std::size_t>(list)];
  out.clear();
  for (Index c = ends.head; c >= 0;) {
    const Chunk& chunk = pool_[static_cast<std::size_t>(c)];
    if (chunk.next >= 0) __builtin_prefetch(&pool_[static_cast<std::size_t>(chunk.next)]);
    out.insert(out.end(), chunk.entry, chunk.entry + (c == ends.tail ? ends.fill : kChunkEntries));
    c = chunk.next;
  }
  if (ends.head >= 0) {  // the whole chain goes to the front of the free list
    pool_[static_cast<std::size_t>(ends.tail)].next = free_;
    free_ = ends.head;
  }
  ends = ListEnds{};
  entries_ -= static_cast<std::int64_t>(out.size());
}

void EventQueue::refill() {
  constexpr std::size_t kAhead = 8;  // entries whose slot and key are requested ahead of their test
  while (heapSize_ == 0) {
    while (++current_ < buckets_ && lists_[static_cast<std::size_t>(current_)].head < 0) {
    }
    if (current_ < buckets_) {
      drainList(current_, drained_);
      const Index tag = tagOf(current_);
      Node* const heap = nodes();
      const std::size_t m = drained_.size();
      for (std::size_t k = 0; k < m; ++k) {
        if (k + kAhead < m) {
          const std::size_t q = static_cast<std::size_t>(drained_[k + kAhead]);
          __builtin_prefetch(&slot_[q]);
          __builtin_prefetch(&key_[q]);
        }
        const std::size_t p = static_cast<std::size_t>(drained_[k]);
        if (slot_[p] != tag) continue;  // stale, or taken already
        slot_[p] = heapSize_;
        heap[heapSize_++] = Node{key_[p], drained_[k]};
      }
      heapify();
      continue;  // every entry may have been stale: then the next bucket
    }
    // The buckets are used up: spread the overflow over a new range from its earliest finite key.
    drainList(buckets_, drained_);
    const Index tag = tagOf(buckets_);
    double earliest = kInf;
    std::size_t valid = 0;
    for (const Index p : drained_) {  // keep each member once, marked as taken (slot 0 until placed)
      const std::size_t up = static_cast<std::size_t>(p);
      if (slot_[up] != tag) continue;
      slot_[up] = 0;
      drained_[valid++] = p;
      earliest = std::min(earliest, key_[up]);
    }
    drained_.resize(valid);
    if (valid == 0) return;                 // nothing left (no particles)
    if (earliest == kInf) spread_ = false;  // only +inf left: they all go to the heap
    base_ = earliest;
    current_ = 0;
    for (const Index p : drained_) place(p);
    heapify();
  }
}

void EventQueue::rebuild(double width) {
  ++rebuilds_;
  width_ = width;
  inverseWidth_ = 1.0 / width;
  const double lists = std::ceil(kSpan * static_cast<double>(size_) / kHeapTarget);
  buckets_ = static_cast<std::int64_t>(std::max(16.0, lists));
  spreadAll();
}

void EventQueue::spreadAll() {
  clearLists();
  double earliest = kInf;
  for (std::size_t p = 0; p < static_cast<std::size_t>(size_); ++p) earliest = std::min(earliest, key_[p]);
  spread_ = earliest < kInf;
  base_ = spread_ ? earliest : 0.0;
  current_ = 0;
  heapSize_ = 0;
  for (Index p = 0; p < size_; ++p) place(p);
  heapify();
  if (heapSize_ == 0) refill();
}

void EventQueue::tune() {
  const double now = topKey();
  const double span = now - tuneTime_;
  if (span > 0.0 && span < kInf) {
    const double width = kHeapTarget * span / static_cast<double>(updates_);
    if (!spread_ || width > 2.0 * width_ || width < 0.5 * width_) rebuild(width);
  }
  updates_ = 0;
  tuneTime_ = topKey();
}

void EventQueue::validate() const {
  const Node* const heap = nodes();
  const auto fail = [](const std::string& what) { throw std::logic_error("event queue: " + what); };
  if (size_ > 0 && heapSize_ == 0) fail("the heap is empty while keys are queued");
  for (std::size_t k = 0; k < static_cast<std::size_t>(heapSize_); ++k) {
    const Index p = heap[k].particle;
    if (slot_[static_cast<std::size_t>(p)] != static_cast<Index>(k)) {
      fail("position index of particle " + std::to_string(p) + " is stale");
    }
    if (heap[k].key != key_[static_cast<std::size_t>(p)]) {
      fail("heap key of particle " + std::to_string(p) + " differs from its key");
    }
    if (k > 0 && before(heap[k], heap[(k - 1) / kArity])) fail("heap order violated at node " + std::to_string(k));
    if (placeOf(heap[k].key) >= 0) fail("particle " + std::to_string(p) + " is in the heap but belongs in a list");
  }
  Index listed = 0;
  std::vector<char> seen(static_cast<std::size_t>(size_), 0);
  std::int64_t entries = 0;
  for (std::int64_t list = 0; list <= buckets_; ++list) {
    const ListEnds& ends = lists_[static_cast<std::size_t>(list)];
    if (!spread_ && ends.head >= 0) fail("a list holds entries while every key belongs in the heap");
    Index last = -1;
    for (Index c = ends.head; c >= 0; c = pool_[static_cast<std::size_t>(c)].next) {
      if (c >= static_cast<Index>(pool_.size())) fail("a list links to a chunk outside the pool");
      const Chunk& chunk = pool_[static_cast<std::size_t>(c)];
      const int count = c == ends.tail ? ends.fill : kChunkEntries;
      if (count < 1 || count > kChunkEntries) fail("a chunk has a bad entry count");
      if (++entries > 3 * static_cast<std::int64_t>(size_) + 1024 + kChunkEntries) fail("a list has a cycle");
      entries += count - 1;
      for (int k = 0; k < count; ++k) {
        const Index p = chunk.entry[k];
        if (p < 0 || p >= size_) fail("a list holds particle " + std::to_string(p) + " of " + std::to_string(size_));
        const std::size_t up = static_cast<std::size_t>(p);
        if (slot_[up] != tagOf(list) || seen[up] != 0) continue;  // stale or repeated: skipped when emptied
        seen[up] = 1;
        ++listed;
        if (placeOf(key_[up]) != list) fail("particle " + std::to_string(p) + " is in the wrong bucket");
      }
      last = c;
    }
    if (last != ends.tail) fail("the tail of a list is stale");
  }
  if (entries != entries_) fail("the list entry count is stale");
  if (entries_ > 3 * static_cast<std::int64_t>(size_) + 1024) fail("stale list entries were not dropped");
  for (std::size_t p = 0; p < static_cast<std::size_t>(size_); ++p) {
    if (slot_[p] < 0 && seen[p] == 0) fail("particle " + std::to_string(p) + " is missing from its list");
  }
  if (listed + heapSize_ != size_)
    fail("keys lost: " + std::to_string(listed + heapSize_) + " of " + std::to_string(size_));
}

}  // namespace polydem::edmd
