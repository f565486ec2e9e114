#include "structure/delaunay_neighbours.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <tuple>
#include <vector>

#include "core/errors.hpp"
#include "core/initial_configuration.hpp"
#include "core/types.hpp"
#include "polydem/config.hpp"
#include "tests/structure/lattices.hpp"

namespace polydem::structure {
namespace {

using Row = std::vector<std::tuple<Index, long, long, long>>;  // neighbour, displacement in 1e-9 units

Row rowOf(const NeighbourList& nb, Index i, Index modulo) {
  Row row;
  for (Index k = nb.start[i]; k < nb.start[i + 1]; ++k) {
    const Eigen::Vector3d d = nb.displacement.col(k) * 1e9;
    row.emplace_back(nb.neighbour[k] % modulo, std::lround(d[0]), std::lround(d[1]), std::lround(d[2]));
  }
  std::sort(row.begin(), row.end());
  return row;
}

TEST(DelaunayNeighbours, PeriodicImagesMatchAnExplicitlyReplicatedBox) {
  ASSERT_TRUE(POLYDEM_WITH_CGAL) << "built without CGAL (POLYDEM_WITH_CGAL=OFF): no Delaunay neighbours";
  // A polydisperse RSA packing, once periodic, once as 27 copies in a walled box: the middle copy's
  // neighbours must be the periodic ones (same partners, same vectors).
  std::vector<double> radii;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.5, 1.5);
  for (int i = 0; i < 400; ++i) radii.push_back(u(rng));
  const Configuration conf = randomSequentialAddition({.radii = radii, .packingFraction = 0.3, .seed = 9});
  const Index n = static_cast<Index>(radii.size());
  const Box& box = conf.box;
  const NeighbourList periodic = delaunayNeighbours({conf.position, conf.radius}, box);
  EXPECT_EQ(periodic.unverifiedCells, 0);
  EXPECT_EQ(periodic.hidden, 0);

  Eigen::Matrix3Xd big(3, 27 * n);
  Eigen::VectorXd bigR(27 * n);
  int copy = 0;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) {
      for (int c = 0; c < 3; ++c, ++copy) {
        for (Index i = 0; i < n; ++i) {
          big.col(copy * n + i) = conf.position.col(i) + Eigen::Vector3d(a, b, c).cwiseProduct(box.lengths());
          bigR[copy * n + i] = conf.radius[i];
        }
      }
    }
  }
  const Box walled(3.0 * box.lengths(), {Boundary::Wall, Boundary::Wall, Boundary::Wall});
  const NeighbourList explicitList = delaunayNeighbours({big, bigR}, walled);
  EXPECT_EQ(explicitList.imageShell, 0.0);
  const Index middle = 13;  // copy (1, 1, 1)
  for (Index i = 0; i < n; ++i) {
    ASSERT_EQ(rowOf(periodic, i, n), rowOf(explicitList, middle * n + i, n)) << "particle " << i;
  }
}

TEST(DelaunayNeighbours, ListsAreSymmetric) {
  ASSERT_TRUE(POLYDEM_WITH_CGAL) << "built without CGAL (POLYDEM_WITH_CGAL=OFF): no Delaunay neighbours";
  const test::Lattice gas = test::idealGas(500, 8.0, 0.2, 3);
  const NeighbourList nb = delaunayNeighbours(gas.spheres(), gas.box);
  for (Index i = 0; i < nb.count(); ++i) {
    for (Index k = nb.start[i]; k < nb.start[i + 1]; ++k) {
      const Index j = nb.neighbour[k];
      bool found = false;
      for (Index q = nb.start[j]; q < nb.start[j + 1] && !found; ++q) {
        found = nb.neighbour[q] == i && (nb.displacement.col(q) + nb.displacement.col(k)).norm() < 1e-9;
      }
      ASSERT_TRUE(found) << i << " -> " << j;
    }
  }
}

TEST(DelaunayNeighbours, PoissonPointsHaveFifteenPointFiveNeighbours) {
  ASSERT_TRUE(POLYDEM_WITH_CGAL) << "built without CGAL (POLYDEM_WITH_CGAL=OFF): no Delaunay neighbours";
  // Mean face count of the Poisson-Voronoi cell: 48 pi^2 / 35 + 2 = 15.535 (Meijering 1953). A dilute
  // gas needs a shell of several spacings: the verification must have grown it.
  const test::Lattice gas = test::idealGas(4000, 100.0, 0.01, 17);
  const NeighbourList nb = delaunayNeighbours(gas.spheres(), gas.box, {.imageShell = 1.0});
  EXPECT_EQ(nb.unverifiedCells, 0);
  EXPECT_GT(nb.attempts, 1);
  EXPECT_NEAR(nb.meanDegree(), 48 * kPi * kPi / 35 + 2, 0.2);
}

TEST(DelaunayNeighbours, WalledBoxHasNoImages) {
  ASSERT_TRUE(POLYDEM_WITH_CGAL) << "built without CGAL (POLYDEM_WITH_CGAL=OFF): no Delaunay neighbours";
  const test::Lattice gas = test::idealGas(300, 6.0, 0.2, 4);
  const Box walled(gas.box.lengths(), {Boundary::Wall, Boundary::Periodic, Boundary::Wall});
  const NeighbourList nb = delaunayNeighbours(gas.spheres(), walled);
  for (Index i = 0; i < nb.count(); ++i) {
    for (Index k = nb.start[i]; k < nb.start[i + 1]; ++k) {
      const Eigen::Vector3d xj = gas.position.col(i) + nb.displacement.col(k);
      EXPECT_NEAR((xj - gas.position.col(nb.neighbour[k]))[0], 0.0, 1e-12);  // x, z: no image
      EXPECT_NEAR((xj - gas.position.col(nb.neighbour[k]))[2], 0.0, 1e-12);
    }
  }
  EXPECT_GT(nb.meanDegree(), 10.0);
}

TEST(DelaunayNeighbours, BadInputIsAConfigError) {
  Eigen::Matrix3Xd x = Eigen::Matrix3Xd::Zero(3, 2);
  x(0, 1) = 1.0;
  Eigen::VectorXd r(2);
  r << 0.1, 0.0;
  const Box box = Box::cubic(4.0, Boundary::Periodic);
  EXPECT_THROW(delaunayNeighbours({x, r}, box), ConfigError);
  r[1] = 0.1;
  x(2, 0) = std::nan("");
  EXPECT_THROW(delaunayNeighbours({x, r}, box), ConfigError);
  x(2, 0) = 0.0;
  EXPECT_THROW(cutoffNeighbours({x, r}, box, 3.0), ConfigError);  // beyond half the box
  if (POLYDEM_WITH_CGAL) {  // without CGAL every call is a ConfigError naming the build option
    EXPECT_NO_THROW(delaunayNeighbours({x, r}, box));
    EXPECT_EQ(delaunayNeighbours({x.leftCols(0), r.head(0)}, box).count(), 0);
  }
}

}  // namespace
}  // namespace polydem::structure
