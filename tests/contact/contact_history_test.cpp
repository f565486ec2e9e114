#include "contact/contact_history.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "contact/contact_list.hpp"

namespace polydem::contact {
namespace {

void set(ContactHistory& h, std::uint64_t key, double value) {
  for (std::size_t c = 0; c < h.size(); ++c) {
    if (h.keys()[c] == key) {
      for (int k = 0; k < h.width(); ++k) h.values(c)[k] = value + k;
      return;
    }
  }
  FAIL() << "no key " << key;
}

TEST(ContactHistory, KeysAreSymmetricAndDistinguishWalls) {
  EXPECT_EQ(pairKey(3, 7), pairKey(7, 3));
  EXPECT_NE(pairKey(3, 7), pairKey(3, 8));
  EXPECT_NE(wallKey(3, 0), wallKey(3, 1));
}

TEST(ContactHistory, SortedRemapCarriesSurvivorsAndZeroesNewcomers) {
  ContactHistory h(3);
  h.remap(std::vector<std::uint64_t>{pairKey(0, 1), pairKey(0, 2), pairKey(1, 2), pairKey(2, 5)});
  set(h, pairKey(0, 2), 10.0);
  set(h, pairKey(2, 5), 20.0);
  set(h, pairKey(0, 1), 30.0);
  // (0, 1) left the list, (1, 5) and (3, 4) are new.
  h.remap(std::vector<std::uint64_t>{pairKey(0, 2), pairKey(1, 2), pairKey(1, 5), pairKey(2, 5), pairKey(3, 4)});
  h.validate();
  EXPECT_EQ(h.size(), 5u);
  EXPECT_EQ(h.find(pairKey(0, 2))[0], 10.0);
  EXPECT_EQ(h.find(pairKey(0, 2))[2], 12.0);
  EXPECT_EQ(h.find(pairKey(2, 5))[1], 21.0);
  EXPECT_EQ(h.find(pairKey(1, 5))[0], 0.0);
  EXPECT_EQ(h.find(pairKey(0, 1)), nullptr);
  EXPECT_EQ(h.activeCount(), 2u);
}

TEST(ContactHistory, UnsortedRemapAfterReorderingFindsTheSameValues) {
  ContactHistory h(3);
  h.remap(std::vector<std::uint64_t>{pairKey(0, 1), pairKey(0, 2), pairKey(4, 9)});
  set(h, pairKey(0, 1), 1.0);
  set(h, pairKey(4, 9), 4.0);
  // After a spatial reorder the list order no longer follows the ids.
  h.remap(std::vector<std::uint64_t>{pairKey(9, 4), pairKey(7, 8), pairKey(1, 0)});
  h.validate();
  EXPECT_EQ(h.find(pairKey(4, 9))[0], 4.0);
  EXPECT_EQ(h.find(pairKey(0, 1))[0], 1.0);
  EXPECT_EQ(h.find(pairKey(7, 8))[0], 0.0);
  // And back to sorted order from an unsorted one.
  h.remap(std::vector<std::uint64_t>{pairKey(0, 1), pairKey(4, 9)});
  EXPECT_EQ(h.find(pairKey(0, 1))[2], 3.0);
  EXPECT_EQ(h.find(pairKey(4, 9))[1], 5.0);
}

TEST(ContactHistory, InactiveContactsAreNotCarried) {
  ContactHistory h(3);
  h.remap(std::vector<std::uint64_t>{pairKey(0, 1)});
  EXPECT_EQ(h.activeCount(), 0u);
  h.remap(std::vector<std::uint64_t>{pairKey(0, 1)});
  EXPECT_EQ(h.find(pairKey(0, 1))[0], 0.0);
}

TEST(ContactHistory, WidthZeroStoresNothing) {
  ContactHistory h(0);
  h.remap(std::vector<std::uint64_t>{pairKey(0, 1), pairKey(1, 2)});
  EXPECT_EQ(h.size(), 0u);
  EXPECT_EQ(h.memoryBytes(), 0u);
}

}  // namespace
}  // namespace polydem::contact
