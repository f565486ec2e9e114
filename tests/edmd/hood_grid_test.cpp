// EDMD's own index of neighbourhoods (edmd/hood_grid.hpp): every query equals brute force with the one
// pair predicate, on periodic and walled boxes, for a wide size distribution, before and after moves.
#include "edmd/hood_grid.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "broadphase/broad_phase.hpp"

namespace polydem::edmd {
namespace {

std::vector<Index> bruteForce(const Box& box, const Eigen::Matrix3Xd& x, const Eigen::VectorXd& r, Index i) {
  std::vector<Index> out;
  for (Index j = 0; j < static_cast<Index>(r.size()); ++j) {
    if (j != i && broadphase::spheresWithinReach(box, x.col(i).data(), r[i], x.col(j).data(), r[j], 0.0)) {
      out.push_back(j);
    }
  }
  return out;
}

TEST(HoodGrid, QueriesMatchBruteForceAfterMoves) {
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
    HoodGrid grid;
    grid.build(box, x, r);
    std::vector<Index> got;
    std::int64_t pairs = 0;
    for (int round = 0; round < 3; ++round) {
      for (Index i = 0; i < n; ++i) {
        grid.overlapping(i, got);
        ASSERT_EQ(got, bruteForce(box, x, r, i)) << "sphere " << i << " round " << round;
        pairs += static_cast<std::int64_t>(got.size());
      }
      // Move a third of the spheres by up to 3 units (across cells), wrapped or clamped into the box.
      for (Index i = round; i < n; i += 3) {
        for (int k = 0; k < 3; ++k) {
          double c = x(k, i) + 6.0 * (uniform(rng) - 0.5);
          const double length = box.length(k);
          c = boundary == Boundary::Periodic ? c - length * std::floor(c / length) : std::clamp(c, 0.0, length);
          if (c >= length) c = boundary == Boundary::Periodic ? 0.0 : length;
          x(k, i) = c;
        }
        grid.move(i, x.col(i).data());
      }
    }
    EXPECT_GT(pairs, 3 * n);  // the scene has real overlaps to find
  }
}

}  // namespace
}  // namespace polydem::edmd
