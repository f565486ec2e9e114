#include "core/huge_pages.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <numeric>
#include <vector>

namespace polydem {
namespace {

constexpr std::size_t kHuge = std::size_t{2} << 20;

TEST(HugePages, NothingOutsideWholeAlignedHugePagesInsideTheArray) {
  EXPECT_EQ(adviseHugePages(nullptr, 0), 0u);
  std::vector<double> small(1000, 1.0);
  EXPECT_EQ(adviseHugePages(small.data(), small.size() * sizeof(double)), 0u);
  // 3 MiB from an unaligned start holds at most one whole aligned 2 MiB page, never more than the array.
  std::vector<char> block(3 * (kHuge / 2) + 4096, 'x');
  const std::size_t advised = adviseHugePages(block.data() + 1, block.size() - 1);
  EXPECT_TRUE(advised == 0 || advised == kHuge) << advised;
}

TEST(HugePages, AdvisedArraysKeepTheirContents) {
  // 16 MiB: at least 6 whole huge pages whatever the alignment; collapsing them copies the pages.
  std::vector<double> data(kHuge, 0.0);
  std::iota(data.begin(), data.end(), 0.5);
  const std::size_t advised = adviseHugePages(data.data(), data.size() * sizeof(double));
  // A kernel without transparent huge pages says no (0); one with them takes every whole page inside.
  const auto begin = reinterpret_cast<std::uintptr_t>(data.data());
  const std::uintptr_t whole =
      ((begin + data.size() * sizeof(double)) & ~(kHuge - 1)) - ((begin + kHuge - 1) & ~(kHuge - 1));
  EXPECT_TRUE(advised == 0 || advised == whole) << advised << " of " << whole;
  for (std::size_t k = 0; k < data.size(); ++k) ASSERT_EQ(data[k], static_cast<double>(k) + 0.5) << k;
}

TEST(HugePages, AdviceRecordsOneArrayPerSlotAndAdvisesOnlyChanges) {
  HugePageAdvice advice;
  std::vector<double> a(kHuge, 1.0), b(kHuge / 2, 2.0);
  advice.apply(0, a.data(), a.size() * sizeof(double));
  advice.apply(1, b.data(), b.size() * sizeof(double));
  const std::size_t both = advice.advisedBytes();
  EXPECT_EQ(both, adviseHugePages(a.data(), a.size() * sizeof(double)) +
                      adviseHugePages(b.data(), b.size() * sizeof(double)));
  advice.apply(0, a.data(), a.size() * sizeof(double));  // unchanged: same record
  EXPECT_EQ(advice.advisedBytes(), both);
  b.assign(8, 3.0);
  b.shrink_to_fit();
  advice.apply(1, b.data(), b.size() * sizeof(double));  // moved and small: nothing left advised in slot 1
  EXPECT_EQ(advice.advisedBytes(), adviseHugePages(a.data(), a.size() * sizeof(double)));
  advice.apply(0, nullptr, 0);
  EXPECT_EQ(advice.advisedBytes(), 0u);
}

TEST(HugePages, LargeVectorsAreAlignedToHugePagesAndBehaveAsVectors) {
  LargeVector<std::int64_t> small(100, 7);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(small.data()) % alignof(std::int64_t), 0u);
  LargeVector<std::int64_t> large(kHugePageThreshold / sizeof(std::int64_t) + 3);
#if defined(__linux__)
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(large.data()) % kHuge, 0u);
#endif
  std::iota(large.begin(), large.end(), std::int64_t{-5});
  large.resize(3 * large.size());  // grows into a new mapping: contents move with it
  for (std::size_t k = 0; k < kHugePageThreshold / sizeof(std::int64_t) + 3; ++k) {
    ASSERT_EQ(large[k], static_cast<std::int64_t>(k) - 5) << k;
  }
  EXPECT_EQ(large.back(), 0);
  large.clear();
  large.shrink_to_fit();
  EXPECT_EQ(small[99], 7);
}

}  // namespace
}  // namespace polydem
