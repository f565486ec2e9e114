#include "edmd/event_queue.hpp"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

namespace polydem::edmd {

void EventQueue::reset(Index count) {
  // Node k sits at byte 16 (k + 3) from a 64-byte boundary: children 4k+1..4k+4 start at 64 (k + 1).
  storage_.assign(static_cast<std::size_t>(count) + 8, Node{0.0, 0});
  const auto base = reinterpret_cast<std::uintptr_t>(storage_.data());
  const std::uintptr_t aligned = (base + 63) & ~std::uintptr_t{63};
  offset_ = (aligned + 48 - base) / sizeof(Node);  // < 7 nodes (malloc aligns to at least 16 bytes)
  Node* const heap = nodes();
  size_ = count;
  position_.resize(static_cast<std::size_t>(count));
  for (Index i = 0; i < count; ++i) {
    heap[i] = {std::numeric_limits<double>::infinity(), i};
    position_[static_cast<std::size_t>(i)] = i;
  }
}

void EventQueue::assign(const std::vector<double>& keys) {
  reset(static_cast<Index>(keys.size()));
  Node* const heap = nodes();
  for (std::size_t i = 0; i < keys.size(); ++i) heap[i].key = keys[i];
  for (std::size_t k = static_cast<std::size_t>(size_) / kArity + 1; k-- > 0;) siftDown(k);
}

Index EventQueue::runnerUp() const {
  const Node* const heap = nodes();
  const std::size_t n = static_cast<std::size_t>(size_);
  if (n <= 1) return heap[0].particle;
  std::size_t best = 1;
  for (std::size_t c = 2; c <= std::min<std::size_t>(kArity, n - 1); ++c)
    best = heap[c].key < heap[best].key ? c : best;
  return heap[best].particle;
}

void EventQueue::update(Index particle, double key) {
  Node* const heap = nodes();
  const std::size_t k = static_cast<std::size_t>(position_[static_cast<std::size_t>(particle)]);
  const double old = heap[k].key;
  heap[k].key = key;
  if (key < old) {
    siftUp(k);
  } else if (key > old) {
    siftDown(k);
  }
}

// A 4-ary heap: half the levels of a binary one, and the four children of a node share a cache line
// (16-byte nodes), so a sift touches fewer lines; the smallest child is picked without branches (which
// child wins is unpredictable, and a mispredicted branch per level was a tenth of the event loop).
void EventQueue::siftUp(std::size_t k) {
  Node* const heap = nodes();
  const Node node = heap[k];
  while (k > 0) {
    const std::size_t parent = (k - 1) / kArity;
    if (!(node.key < heap[parent].key)) break;
    heap[k] = heap[parent];
    position_[static_cast<std::size_t>(heap[k].particle)] = static_cast<Index>(k);
    k = parent;
  }
  heap[k] = node;
  position_[static_cast<std::size_t>(node.particle)] = static_cast<Index>(k);
}

void EventQueue::siftDown(std::size_t k) {
  Node* const heap = nodes();
  const Node node = heap[k];
  const std::size_t n = static_cast<std::size_t>(size_);
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
      const std::size_t a = first + static_cast<std::size_t>(heap[first + 1].key < heap[first].key);
      const std::size_t b = first + 2 + static_cast<std::size_t>(heap[first + 3].key < heap[first + 2].key);
      best = heap[b].key < heap[a].key ? b : a;
    } else {
      for (std::size_t c = first + 1; c < n; ++c) best = heap[c].key < heap[best].key ? c : best;
    }
    if (!(heap[best].key < node.key)) break;
    heap[k] = heap[best];
    position_[static_cast<std::size_t>(heap[k].particle)] = static_cast<Index>(k);
    k = best;
  }
  heap[k] = node;
  position_[static_cast<std::size_t>(node.particle)] = static_cast<Index>(k);
}

void EventQueue::validate() const {
  const Node* const heap = nodes();
  for (std::size_t k = 0; k < static_cast<std::size_t>(size_); ++k) {
    if (position_[static_cast<std::size_t>(heap[k].particle)] != static_cast<Index>(k)) {
      throw std::logic_error("event queue: position index of particle " + std::to_string(heap[k].particle) +
                             " is stale");
    }
    if (k > 0 && heap[k].key < heap[(k - 1) / kArity].key) {
      throw std::logic_error("event queue: heap order violated at node " + std::to_string(k));
    }
  }
}

}  // namespace polydem::edmd
