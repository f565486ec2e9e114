#pragma once
// Timed broad-phase runs shared by `polydem pairs` and `polydem example`.
#include <string>
#include <vector>

#include "broadphase/broad_phase.hpp"

namespace polydem::app {

struct PairReport {
  std::string backend;
  std::string description;  ///< backend configuration after the build
  std::size_t candidatePairs = 0;
  std::size_t overlappingPairs = 0;  ///< distance < r_i + r_j
  double buildSeconds = 0.0;         ///< median
  double findSeconds = 0.0;          ///< median
  std::size_t memoryBytes = 0;
  std::uint64_t checksum = 0;
  std::vector<broadphase::Pair> pairs;  ///< sorted
};

/// Build + findPairs `repeat` times (one untimed warm-up first), medians of the times.
PairReport measurePairs(const std::string& backend, const SphereView& spheres, const Box& box, double skin, int repeat);
PairReport measurePairs(broadphase::BroadPhase& backend, const SphereView& spheres, const Box& box, double skin,
                        int repeat);
void printPairReport(const PairReport& r, Index count);

}  // namespace polydem::app
