// The linked multi-level grid (broadphase/hgrid_dynamic.hpp), the event-driven engine's exit index: every
// query equals brute force with the one pair predicate, on periodic and walled boxes, for a wide size
// distribution, before and after moves far across cells through update() (the property suite covers the
// rest, as for every registered backend).
#include "broadphase/hgrid_dynamic.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "broadphase/registry.hpp"

namespace polydem::broadphase {
namespace {

std::vector<Index> bruteForce(const Box& box, const Eigen::Matrix3Xd& x, const Eigen::VectorXd& r, Index i,
                              double reach) {
  std::vector<Index> out;
  for (Index j = 0; j < static_cast<Index>(r.size()); ++j) {
    if (j != i && spheresWithinReach(box, x.col(i).data(), r[i], x.col(j).data(), r[j], reach)) {
      out.push_back(j);
    }
  }
  return out;
}

TEST(HGridDynamic, QueriesMatchBruteForceAfterMovesThroughUpdate) {
  for (const Boundary boundary : {Boundary::Periodic, Boundary::Wall}) {
    SCOPED_TRACE(boundary == Boundary::Periodic ? "periodic" : "walls");
    const Box box(Eigen::Vector3d(25.0, 20.0, 30.0), {boundary, boundary, boundary});
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    const Index n = 600;
    Eigen::Matrix3Xd x(3, n);
    Eigen::VectorXd r(n);
    for (Index i = 0; i < n; ++i) {
      r[i] = 0.5 / std::sqrt(1.0 - 0.99 * uniform(rng));  // 0.5 .. 5, many small, a few large
      for (int k = 0; k < 3; ++k) x(k, i) = box.length(k) * uniform(rng);
    }
    x(0, 0) = 0.0;                                 // on the lower face
    x(1, 1) = std::nextafter(box.length(1), 0.0);  // just below the upper face
    const double skin = 0.3;
    HGridDynamic grid;
    grid.build(SphereView{x, r}, box, skin);
    std::vector<Index> got;
    std::vector<Index> moved;
    std::int64_t pairs = 0;
    for (int round = 0; round < 3; ++round) {
      for (const double reach : {0.0, 0.1, skin}) {
        for (Index i = 0; i < n; ++i) {
          grid.findNeighbours(SphereView{x, r}, i, reach, got);
          ASSERT_EQ(got, bruteForce(box, x, r, i, reach)) << "sphere " << i << " round " << round << " reach " << reach;
          if (reach == 0.0) pairs += static_cast<std::int64_t>(got.size());
        }
      }
      moved.clear();
      // Move a third of the spheres by up to 3 units (across cells), wrapped or clamped into the box.
      for (Index i = round; i < n; i += 3) {
        for (int k = 0; k < 3; ++k) {
          double c = x(k, i) + 6.0 * (uniform(rng) - 0.5);
          const double length = box.length(k);
          c = boundary == Boundary::Periodic ? c - length * std::floor(c / length) : std::clamp(c, 0.0, length);
          if (c >= length) c = boundary == Boundary::Periodic ? 0.0 : length;
          x(k, i) = c;
        }
        moved.push_back(i);
      }
      grid.update(SphereView{x, r}, moved);
    }
    EXPECT_GT(pairs, 3 * n);  // the scene has real overlaps to find
  }
}

TEST(HGridDynamic, ManyMovesRelocateAndCompactTheCells) {
  // Every sphere moved 40 times to anywhere in the box (an event-driven run moves each neighbourhood a few
  // times per epoch): cells fill past their room and move to the end of their level's array, the array is
  // compacted when those moves have doubled it, and the queries still equal brute force. The index's memory
  // stays within a small multiple of its size after the build (without the compaction it grows past it).
  const Box box = Box::cubic(30.0, Boundary::Periodic);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const Index n = 2000;
  Eigen::Matrix3Xd x(3, n);
  Eigen::VectorXd r(n);
  for (Index i = 0; i < n; ++i) {
    r[i] = i % 50 == 0 ? 2.5 : 0.5;  // two levels
    for (int k = 0; k < 3; ++k) x(k, i) = 30.0 * uniform(rng);
  }
  HGridDynamic grid;
  grid.build(SphereView{x, r}, box, 0.2);
  const std::size_t built = grid.memoryBytes();
  std::size_t largest = built;
  std::vector<Index> got;
  for (int round = 0; round < 40; ++round) {
    for (Index i = 0; i < n; ++i) {
      // Half the moves crowd into one corner, so that cells there overflow their room.
      const double span = i % 2 ? 30.0 : 4.0;
      for (int k = 0; k < 3; ++k) x(k, i) = std::min(span * uniform(rng), std::nextafter(30.0, 0.0));
      const Index moved[1] = {i};
      grid.update(SphereView{x, r}, moved);
    }
    largest = std::max(largest, grid.memoryBytes());
    if (round % 13 == 0 || round == 39) {
      for (Index i = 0; i < n; i += 7) {
        grid.findNeighbours(SphereView{x, r}, i, 0.1, got);
        ASSERT_EQ(got, bruteForce(box, x, r, i, 0.1)) << "sphere " << i << " round " << round;
      }
    }
  }
  std::printf("index memory: %zu B after the build, at most %zu B while moving\n", built, largest);
  // Measured when written: 418,248 B built, at most 1,043,640 B (2.5x); 1,871,928 B (4.5x) without compaction.
  EXPECT_LT(static_cast<double>(largest), 3.5 * static_cast<double>(built));
}

TEST(HGridDynamic, IsRegisteredAsACompleteIncrementalBackend) {
  const auto bp = makeBroadPhase("hgrid-dynamic");
  EXPECT_EQ(bp->name(), "hgrid-dynamic");
  EXPECT_TRUE(bp->capabilities().complete);
  EXPECT_TRUE(bp->capabilities().incremental);
}

}  // namespace
}  // namespace polydem::broadphase
