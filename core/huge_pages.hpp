#pragma once
// Transparent huge pages for the large per-particle arrays. A DEM step at 10^6 particles reads the
// neighbours' positions, velocities and forces from arrays of tens of megabytes in an order that jumps
// between 4 KiB pages, and the page walks of the resulting TLB misses cost time in the force loop; 2 MiB
// pages cover the same arrays with 512x fewer entries. Where the kernel leaves huge pages to madvise()
// (Debian's default), nothing asks for them, so the arrays are advised here: MADV_HUGEPAGE for the pages
// still to come and MADV_COLLAPSE (Linux >= 6.1) for the ones already written. Only whole, aligned 2 MiB
// ranges inside an array are advised, so arrays under 4 MiB are never touched and no memory outside an
// array changes backing. Advice is a hint: a kernel without it, or without free huge pages, runs the same
// code on 4 KiB pages with the same results.
#include <cstddef>
#include <optional>
#include <vector>

namespace polydem {

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
