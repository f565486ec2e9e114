#include "contact/contact_list.hpp"

#include <cstddef>

namespace polydem::contact {

void ContactList::buildBlocks(int blocks) {
  const Index n = particleCount();
  const auto b = static_cast<std::size_t>(blocks < 1 ? 1 : blocks);
  // Contiguous blocks of about equal work: block k starts at the first row whose preceding work
  // (candidates + 1 per row) reaches k / B of the total. Rows are Morton-ordered, so each block is a
  // compact region and few pairs cross between blocks.
  blockStart.assign(b + 1, n);
  blockStart[0] = 0;
  const double total = static_cast<double>(neighbour.size()) + static_cast<double>(n);
  std::size_t next = 1;
  for (Index i = 0; i < n && next < b; ++i) {
    const double before = static_cast<double>(offset[i]) + static_cast<double>(i);
    while (next < b && before >= total * static_cast<double>(next) / static_cast<double>(b)) blockStart[next++] = i;
  }

  // Cross pairs in slot order (ascending c, hence ascending (i, j)), with the block of j.
  crossStart.assign(b + 1, 0);
  crossPair.clear();
  crossRow.clear();
  crossTarget_.clear();
  for (std::size_t s = 0; s < b; ++s) {
    crossStart[s] = static_cast<Index>(crossPair.size());
    const Index blockEnd = blockStart[s + 1];
    for (Index i = blockStart[s]; i < blockEnd; ++i) {
      std::size_t t = s;
      for (Index c = offset[i]; c < offset[i + 1]; ++c) {
        const Index j = neighbour[c];
        if (j < blockEnd) continue;
        while (j >= blockStart[t + 1]) ++t;  // j ascends along the row: t only moves forward
        crossPair.push_back(c);
        crossRow.push_back(i);
        crossTarget_.push_back(static_cast<Index>(t));
      }
    }
  }
  crossStart[b] = static_cast<Index>(crossPair.size());

  // Group by the block of j (stable counting sort: ascending within each group).
  targetOffset.assign(b + 1, 0);
  for (const Index t : crossTarget_) ++targetOffset[static_cast<std::size_t>(t) + 1];
  for (std::size_t t = 0; t < b; ++t) targetOffset[t + 1] += targetOffset[t];
  byTarget.resize(crossPair.size());
  for (std::size_t k = 0; k < crossTarget_.size(); ++k) {
    byTarget[static_cast<std::size_t>(targetOffset[static_cast<std::size_t>(crossTarget_[k])]++)] =
        static_cast<Index>(k);
  }
  for (std::size_t t = b; t > 0; --t) targetOffset[t] = targetOffset[t - 1];
  targetOffset[0] = 0;
}

}  // namespace polydem::contact
