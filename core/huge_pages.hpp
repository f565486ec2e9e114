#pragma once
// Transparent huge pages for the large per-particle arrays. A DEM step at 10^6 particles reads the
// neighbours' positions, velocities and forces from arrays of tens of megabytes in an order that jumps
// between 4 KiB pages, and the event-driven engine at 10^5 spheres jumps between the states, events and
// lists of a few-MiB working set; the page walks of the resulting TLB misses cost time. 2 MiB pages cover
// the same arrays with 512x fewer entries. Where the kernel leaves huge pages to madvise() (Debian's
// default) nothing asks for them, so two ways are offered here:
// - LargeVector (HugePageAllocator): arrays from 1 MiB on are mapped 2 MiB-aligned and advised before
//   anything is written, so the whole array can be on huge pages (the event-driven engine's arrays);
// - adviseHugePages / HugePageAdvice for arrays allocated elsewhere (Eigen's): MADV_HUGEPAGE for the pages
//   still to come and MADV_COLLAPSE (Linux >= 6.1) for the ones already written, only for the whole aligned
//   2 MiB pages inside the array, so arrays under 4 MiB are never touched and no memory outside an array
//   changes backing (the DEM arrays, tens of MiB at 10^6).
// Advice is a hint: a kernel without it, or without free huge pages, runs the same code on 4 KiB pages
// with the same results.
#include <cstddef>
#include <optional>
#include <vector>

namespace polydem {

/// Memory for a large array, 2 MiB-aligned from mmap with MADV_HUGEPAGE before anything is written (so
/// the whole array can be on huge pages, which advice after the fact gives only to the aligned pages inside)
/// from kHugePageThreshold bytes on, from operator new below. Throws std::bad_alloc.
void* allocateLarge(std::size_t bytes, std::size_t alignment);
/// Frees what allocateLarge(bytes, alignment) returned, given the same bytes and alignment.
void deallocateLarge(void* data, std::size_t bytes, std::size_t alignment) noexcept;
inline constexpr std::size_t kHugePageThreshold = std::size_t{1} << 20;

/// std::vector's allocator through allocateLarge(): for the hot arrays of the event-driven engine, which
/// at 10^5 spheres are a few MiB each (advice after the fact would cover only their aligned interior).
template <class T>
struct HugePageAllocator {
  using value_type = T;
  HugePageAllocator() = default;
  template <class U>
  HugePageAllocator(const HugePageAllocator<U>&) noexcept {}
  T* allocate(std::size_t n) { return static_cast<T*>(allocateLarge(n * sizeof(T), alignof(T))); }
  void deallocate(T* data, std::size_t n) noexcept { deallocateLarge(data, n * sizeof(T), alignof(T)); }
  template <class U>
  bool operator==(const HugePageAllocator<U>&) const noexcept {
    return true;
  }
};
template <class T>
using LargeVector = std::vector<T, HugePageAllocator<T>>;

/// Advise the whole 2 MiB pages inside [data, data + bytes); returns the bytes advised (0 where no whole
/// huge page fits, or on a system without transparent huge pages).
std::size_t adviseHugePages(const void* data, std::size_t bytes);

/// Bytes of this process's memory on transparent huge pages now (AnonHugePages of /proc/self/smaps_rollup);
/// nothing where that file is missing or unreadable.
std::optional<std::size_t> residentHugePageBytes();

/// One record per array (its slot, numbered by the caller), so that calling it after every neighbour-list
/// rebuild advises only the arrays that are new, have moved or have grown.
class HugePageAdvice {
 public:
  void apply(std::size_t slot, const void* data, std::size_t bytes);
  /// Bytes advised for the arrays as the slots last saw them.
  std::size_t advisedBytes() const;

 private:
  struct Range {
    const void* data = nullptr;
    std::size_t bytes = 0;
    std::size_t advised = 0;
  };
  std::vector<Range> slots_;
};

}  // namespace polydem
