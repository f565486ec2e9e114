#pragma once
// Lattice packings for the jamming tests (Donev 2006, Table 4.1): m^3 unit cells of FCC (4 spheres each)
// or simple cubic (1), spheres of radius 1 - gap on the sites of a touching lattice, periodic cube.
#include <Eigen/Core>
#include <cmath>
#include <vector>

#include "core/box.hpp"

namespace polydem::edmd::testing {

inline Box latticePacking(bool fcc, int m, double gap, Eigen::Matrix3Xd& x, Eigen::VectorXd& r) {
  const double a = fcc ? 2.0 * std::sqrt(2.0) : 2.0;
  const std::vector<Eigen::Vector3d> basis =
      fcc ? std::vector<Eigen::Vector3d>{{0, 0, 0}, {0.5, 0.5, 0}, {0.5, 0, 0.5}, {0, 0.5, 0.5}}
          : std::vector<Eigen::Vector3d>{{0, 0, 0}};
  x.resize(3, m * m * m * static_cast<int>(basis.size()));
  int k = 0;
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j)
      for (int l = 0; l < m; ++l)
        for (const auto& b : basis) x.col(k++) = a * (Eigen::Vector3d(i, j, l) + b) + Eigen::Vector3d::Constant(0.1);
  r = Eigen::VectorXd::Constant(k, 1.0 - gap);
  return Box::cubic(m * a, Boundary::Periodic);
}

}  // namespace polydem::edmd::testing
