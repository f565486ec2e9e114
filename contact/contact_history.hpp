#pragma once
// Per-contact state (e.g. the Cundall-Strack spring displacement), stored parallel to a contact list
// and keyed by the stored ids of the particles, so it survives neighbour-list rebuilds and particle
// reordering (ParticleStore::reorder moves ids with the particles).
//
// After a rebuild, remap() carries the values of every contact that is in both the old and the new
// list: a linear merge of two sorted key lists when the new list is in key order (ids ascending with
// the slots, the usual case), a binary search of the few old active contacts otherwise (after a
// spatial reorder). Only "active" contacts (some value non-zero) are carried: the force loop zeroes a
// contact's values when the spheres separate, so a pair that left and came back starts afresh.
//
// A law with kHistorySize = 0 uses a ContactHistory of width 0, which stores nothing at all.
#include <cstdint>
#include <span>
#include <vector>

namespace polydem::contact {

class ContactHistory {
 public:
  explicit ContactHistory(int width = 0);

  int width() const { return width_; }
  /// Number of contacts (the length of the list this history is parallel to); 0 for width 0.
  std::size_t size() const { return keys_.size(); }
  double* values(std::size_t contact) { return values_.data() + contact * static_cast<std::size_t>(width_); }
  const double* values(std::size_t contact) const {
    return values_.data() + contact * static_cast<std::size_t>(width_);
  }
  std::span<const std::uint64_t> keys() const { return keys_; }
  /// All values, `width` per contact in list order (checkpoints).
  std::span<const double> allValues() const { return values_; }

  /// Replace keys and values wholesale (a resumed run: the same list, the saved values). Throws
  /// std::invalid_argument unless values.size() == width * keys.size().
  void assign(std::span<const std::uint64_t> keys, std::span<const double> values);

  /// Replace the contact list by one with `newKeys` (in list order, unique). Values of keys present in
  /// both lists carry over, the others start at zero. O(P) when newKeys ascend, O(P log A) otherwise
  /// (A = active contacts). Reuses its buffers: no allocation once sized. No-op for width 0.
  void remap(std::span<const std::uint64_t> newKeys);

  /// Number of contacts with some non-zero value. O(P).
  std::size_t activeCount() const;
  /// Value of the contact with `key`, or nullptr. O(P); for tests and reports.
  const double* find(std::uint64_t key) const;
  /// Zero every value.
  void clear();
  std::size_t memoryBytes() const;
  /// Invariants: values sized width * keys; keys unique. Throws std::logic_error.
  void validate() const;

 private:
  bool active(std::size_t contact) const;

  int width_ = 0;
  std::vector<std::uint64_t> keys_;
  std::vector<double> values_;
  bool keysAscending_ = true;
  // Scratch reused by remap().
  std::vector<std::uint64_t> activeKeys_;
  std::vector<double> activeValues_;
  std::vector<std::uint32_t> order_;
};

}  // namespace polydem::contact
