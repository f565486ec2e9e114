#include "core/huge_pages.hpp"

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <new>
#include <sstream>
#include <string>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace polydem {

namespace {
constexpr std::uintptr_t kHugePage = std::uintptr_t{2} << 20;
constexpr std::uintptr_t pageBelow(std::uintptr_t at) { return at & ~(kHugePage - 1); }
constexpr std::uintptr_t pageAbove(std::uintptr_t at) { return pageBelow(at + kHugePage - 1); }
#if defined(__linux__) && !defined(MADV_COLLAPSE)
constexpr int MADV_COLLAPSE = 25;  // Linux 6.1; older headers lack the name
#endif
}  // namespace

std::size_t adviseHugePages(const void* data, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  const auto begin = reinterpret_cast<std::uintptr_t>(data);
  const std::uintptr_t first = pageAbove(begin);
  const std::uintptr_t last = pageBelow(begin + bytes);
  if (data == nullptr || last <= first) return 0;
  void* const at = reinterpret_cast<void*>(first);
  const std::size_t length = last - first;
  if (madvise(at, length, MADV_HUGEPAGE) != 0) return 0;
  // Pages already written stay small until khugepaged gets to them (minutes for a large array): collapse
  // them now. Fails harmlessly (EINVAL, EAGAIN, ENOMEM) where the kernel cannot.
  (void)madvise(at, length, MADV_COLLAPSE);
  return length;
#else
  (void)data;
  (void)bytes;
  return 0;
#endif
}

void* allocateLarge(std::size_t bytes, std::size_t alignment) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  if (bytes >= kHugePageThreshold) {
    const std::size_t length = pageAbove(bytes);
    // One huge page more than needed, then the unaligned head and the tail given back.
    void* const raw = mmap(nullptr, length + kHugePage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (raw == MAP_FAILED) throw std::bad_alloc();
    const auto begin = reinterpret_cast<std::uintptr_t>(raw);
    const std::uintptr_t aligned = pageAbove(begin);
    if (aligned > begin) munmap(raw, aligned - begin);
    const std::uintptr_t end = begin + length + kHugePage;
    if (end > aligned + length) munmap(reinterpret_cast<void*>(aligned + length), end - (aligned + length));
    (void)madvise(reinterpret_cast<void*>(aligned), length, MADV_HUGEPAGE);  // a hint: failure is harmless
    return reinterpret_cast<void*>(aligned);
  }
#endif
  return ::operator new (bytes, std::align_val_t{std::max(alignment, alignof(std::max_align_t))});
}

void deallocateLarge(void* data, std::size_t bytes, std::size_t alignment) noexcept {
  if (data == nullptr) return;
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  if (bytes >= kHugePageThreshold) {
    munmap(data, pageAbove(bytes));
    return;
  }
#endif
  ::operator delete (data, std::align_val_t{std::max(alignment, alignof(std::max_align_t))});
}

std::optional<std::size_t> residentHugePageBytes() {
  std::ifstream in("/proc/self/smaps_rollup");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("AnonHugePages:", 0) != 0) continue;
    std::istringstream fields(line.substr(14));
    std::size_t kib = 0;
    std::string unit;
    if (fields >> kib >> unit && unit == "kB") return kib * 1024;
    return std::nullopt;
  }
  return std::nullopt;
}

void HugePageAdvice::apply(std::size_t slot, const void* data, std::size_t bytes) {
  if (slot >= slots_.size()) slots_.resize(slot + 1);
  Range& r = slots_[slot];
  if (r.data == data && r.bytes == bytes) return;
  r = {data, bytes, adviseHugePages(data, bytes)};
}

std::size_t HugePageAdvice::advisedBytes() const {
  std::size_t total = 0;
  for (const Range& r : slots_) total += r.advised;
  return total;
}

}  // namespace polydem
