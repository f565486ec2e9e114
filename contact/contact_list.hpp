#pragma once
// Candidate contacts for the force loop: a half neighbour list in CSR form (row i holds the j > i
// within the skin, ascending) and a list of particle-wall candidates. Built by
// integrators/verlet_list.hpp from a broad phase; the force loop only reads it.
//
// The CSR order is canonical ((i, j) ascending) whatever backend produced the pairs, so forces are
// summed in the same order and every backend gives bit-identical trajectories.
//
// The threaded force loop also needs thread blocks, built by buildBlocks() after each rebuild: the rows
// split into contiguous blocks of about equal work (one per thread), and the "cross" pairs whose j lies
// in a later block than i. Each thread owns the forces of its block; a cross pair is computed once, in a
// pass shared by all threads, before the owner of j subtracts it and the owner of i reads it back
// (contact/force_loop.hpp).
#include <cstdint>
#include <vector>

#include "core/types.hpp"

namespace polydem::contact {

/// Wall faces: 2 * axis + side, side 0 = the face at coordinate 0, side 1 = the face at L.
inline constexpr int kFaceCount = 6;

struct ContactList {
  std::vector<Index> offset;          ///< N + 1 row starts into `neighbour`
  std::vector<Index> neighbour;       ///< j per candidate pair; row i lists j > i ascending
  std::vector<Index> wallParticle;    ///< particle per wall candidate, ascending
  std::vector<std::int8_t> wallFace;  ///< face per wall candidate (see kFaceCount)
  // Thread blocks (empty unless buildBlocks() ran).
  std::vector<Index> blockStart;    ///< B + 1 row boundaries
  std::vector<Index> crossStart;    ///< B + 1 starts into the cross arrays, by the block of i
  std::vector<Index> crossPair;     ///< slot c of each cross pair, ascending
  std::vector<Index> crossRow;      ///< i of each cross pair
  std::vector<Index> targetOffset;  ///< B + 1 starts into `byTarget`, by the block of j
  std::vector<Index> byTarget;      ///< cross-pair indices grouped by the block of j, ascending in each group

  /// Split the rows into `blocks` contiguous blocks of about equal work (candidates + 1 per row) and
  /// list the cross pairs. O(N + P); buffers only grow, so steady-state rebuilds do not allocate.
  void buildBlocks(int blocks);
  Index blockCount() const { return blockStart.empty() ? 0 : static_cast<Index>(blockStart.size() - 1); }
  std::size_t crossCount() const { return crossPair.size(); }

  Index particleCount() const { return offset.empty() ? 0 : static_cast<Index>(offset.size() - 1); }
  std::size_t pairCount() const { return neighbour.size(); }
  std::size_t wallCount() const { return wallParticle.size(); }
  std::size_t memoryBytes() const {
    return offset.capacity() * sizeof(Index) + neighbour.capacity() * sizeof(Index) +
           wallParticle.capacity() * sizeof(Index) + wallFace.capacity() +
           (blockStart.capacity() + crossStart.capacity() + crossPair.capacity() + crossRow.capacity() +
            targetOffset.capacity() + byTarget.capacity() + crossTarget_.capacity()) *
               sizeof(Index);
  }

 private:
  std::vector<Index> crossTarget_;  // scratch of buildBlocks(): the block of j per cross pair
};

/// History key of a particle pair from their stored ids: order-independent, unique per pair.
inline std::uint64_t pairKey(Index idA, Index idB) {
  const auto a = static_cast<std::uint32_t>(idA < idB ? idA : idB);
  const auto b = static_cast<std::uint32_t>(idA < idB ? idB : idA);
  return (static_cast<std::uint64_t>(a) << 32) | b;
}

/// History key of a particle-wall contact.
inline std::uint64_t wallKey(Index id, int face) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(id)) << 32) | static_cast<std::uint32_t>(face);
}

}  // namespace polydem::contact
