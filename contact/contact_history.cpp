#include "contact/contact_history.hpp"

#include <algorithm>
#include <stdexcept>

namespace polydem::contact {

namespace {
/// vector::assign allocates exactly the new size when it outgrows the capacity; lists that creep up by a
/// few entries per rebuild would then allocate at every rebuild. Grow geometrically instead.
template <class T>
void reserveGeometric(std::vector<T>& v, std::size_t n) {
  if (n > v.capacity()) v.reserve(std::max(n, 2 * v.capacity()));
}
}  // namespace

ContactHistory::ContactHistory(int width) : width_(width) {
  if (width < 0) throw std::logic_error("ContactHistory: negative width");
}

bool ContactHistory::active(std::size_t contact) const {
  const double* v = values(contact);
  for (int k = 0; k < width_; ++k) {
    if (v[k] != 0.0) return true;
  }
  return false;
}

void ContactHistory::remap(std::span<const std::uint64_t> newKeys) {
  if (width_ == 0) return;
  const auto w = static_cast<std::size_t>(width_);

  // 1. The active old contacts, sorted by key.
  order_.clear();
  for (std::size_t c = 0; c < keys_.size(); ++c) {
    if (active(c)) order_.push_back(static_cast<std::uint32_t>(c));
  }
  if (!keysAscending_) {
    std::sort(order_.begin(), order_.end(), [&](std::uint32_t a, std::uint32_t b) { return keys_[a] < keys_[b]; });
  }
  activeKeys_.resize(order_.size());
  activeValues_.resize(order_.size() * w);
  for (std::size_t a = 0; a < order_.size(); ++a) {
    activeKeys_[a] = keys_[order_[a]];
    std::copy_n(values(order_[a]), w, activeValues_.data() + a * w);
  }

  // 2. The new list, zeroed, then filled from the active old contacts.
  reserveGeometric(keys_, newKeys.size());
  reserveGeometric(values_, newKeys.size() * w);
  keys_.assign(newKeys.begin(), newKeys.end());
  values_.assign(keys_.size() * w, 0.0);
  keysAscending_ = std::is_sorted(keys_.begin(), keys_.end());
  if (activeKeys_.empty()) return;
  if (keysAscending_) {
    std::size_t a = 0;
    for (std::size_t c = 0; c < keys_.size() && a < activeKeys_.size(); ++c) {
      while (a < activeKeys_.size() && activeKeys_[a] < keys_[c]) ++a;  // contacts that left the list
      if (a < activeKeys_.size() && activeKeys_[a] == keys_[c]) {
        std::copy_n(activeValues_.data() + a * w, w, values(c));
        ++a;
      }
    }
  } else {
    for (std::size_t c = 0; c < keys_.size(); ++c) {
      const auto it = std::lower_bound(activeKeys_.begin(), activeKeys_.end(), keys_[c]);
      if (it != activeKeys_.end() && *it == keys_[c]) {
        std::copy_n(activeValues_.data() + static_cast<std::size_t>(it - activeKeys_.begin()) * w, w, values(c));
      }
    }
  }
}

void ContactHistory::assign(std::span<const std::uint64_t> keys, std::span<const double> values) {
  if (values.size() != keys.size() * static_cast<std::size_t>(width_)) {
    throw std::invalid_argument("ContactHistory::assign: values must hold width values per key");
  }
  keys_.assign(keys.begin(), keys.end());
  values_.assign(values.begin(), values.end());
  keysAscending_ = std::is_sorted(keys_.begin(), keys_.end());
}

std::size_t ContactHistory::activeCount() const {
  std::size_t n = 0;
  for (std::size_t c = 0; c < keys_.size(); ++c) n += active(c) ? 1 : 0;
  return n;
}

const double* ContactHistory::find(std::uint64_t key) const {
  for (std::size_t c = 0; c < keys_.size(); ++c) {
    if (keys_[c] == key) return values(c);
  }
  return nullptr;
}

void ContactHistory::clear() { std::fill(values_.begin(), values_.end(), 0.0); }

std::size_t ContactHistory::memoryBytes() const {
  return keys_.capacity() * sizeof(std::uint64_t) + values_.capacity() * sizeof(double) +
         activeKeys_.capacity() * sizeof(std::uint64_t) + activeValues_.capacity() * sizeof(double) +
         order_.capacity() * sizeof(std::uint32_t);
}

void ContactHistory::validate() const {
  if (values_.size() != keys_.size() * static_cast<std::size_t>(width_)) {
    throw std::logic_error("ContactHistory: values and keys disagree in size");
  }
  std::vector<std::uint64_t> sorted = keys_;
  std::sort(sorted.begin(), sorted.end());
  if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) {
    throw std::logic_error("ContactHistory: duplicate key");
  }
  if (keysAscending_ && !std::is_sorted(keys_.begin(), keys_.end())) {
    throw std::logic_error("ContactHistory: keys flagged ascending but are not");
  }
}

}  // namespace polydem::contact
