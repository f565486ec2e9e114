#include "edmd/event_queue.hpp"

#include <limits>
#include <stdexcept>
#include <string>

namespace polydem::edmd {

void EventQueue::reset(Index count) {
  heap_.resize(static_cast<std::size_t>(count));
  position_.resize(static_cast<std::size_t>(count));
  for (Index i = 0; i < count; ++i) {
    heap_[static_cast<std::size_t>(i)] = {std::numeric_limits<double>::infinity(), i};
    position_[static_cast<std::size_t>(i)] = i;
  }
}

void EventQueue::assign(const std::vector<double>& keys) {
  reset(static_cast<Index>(keys.size()));
  for (std::size_t i = 0; i < keys.size(); ++i) heap_[i].key = keys[i];
  for (std::size_t k = heap_.size() / kArity + 1; k-- > 0;) siftDown(k);
}

void EventQueue::update(Index particle, double key) {
  const std::size_t k = static_cast<std::size_t>(position_[static_cast<std::size_t>(particle)]);
  const double old = heap_[k].key;
  heap_[k].key = key;
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
  const Node node = heap_[k];
  while (k > 0) {
    const std::size_t parent = (k - 1) / kArity;
    if (!(node.key < heap_[parent].key)) break;
    heap_[k] = heap_[parent];
    position_[static_cast<std::size_t>(heap_[k].particle)] = static_cast<Index>(k);
    k = parent;
  }
  heap_[k] = node;
  position_[static_cast<std::size_t>(node.particle)] = static_cast<Index>(k);
}

void EventQueue::siftDown(std::size_t k) {
  const Node node = heap_[k];
  const std::size_t n = heap_.size();
  for (;;) {
    const std::size_t first = kArity * k + 1;
    if (first >= n) break;
    std::size_t best = first;
    if (first + kArity <= n) {
      const std::size_t a = first + static_cast<std::size_t>(heap_[first + 1].key < heap_[first].key);
      const std::size_t b = first + 2 + static_cast<std::size_t>(heap_[first + 3].key < heap_[first + 2].key);
      best = heap_[b].key < heap_[a].key ? b : a;
    } else {
      for (std::size_t c = first + 1; c < n; ++c) best = heap_[c].key < heap_[best].key ? c : best;
    }
    if (!(heap_[best].key < node.key)) break;
    heap_[k] = heap_[best];
    position_[static_cast<std::size_t>(heap_[k].particle)] = static_cast<Index>(k);
    k = best;
  }
  heap_[k] = node;
  position_[static_cast<std::size_t>(node.particle)] = static_cast<Index>(k);
}

void EventQueue::validate() const {
  for (std::size_t k = 0; k < heap_.size(); ++k) {
    if (position_[static_cast<std::size_t>(heap_[k].particle)] != static_cast<Index>(k)) {
      throw std::logic_error("event queue: position index of particle " + std::to_string(heap_[k].particle) +
                             " is stale");
    }
    if (k > 0 && heap_[k].key < heap_[(k - 1) / kArity].key) {
      throw std::logic_error("event queue: heap order violated at node " + std::to_string(k));
    }
  }
}

}  // namespace polydem::edmd
