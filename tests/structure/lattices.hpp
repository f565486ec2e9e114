#pragma once
// Perfect lattices in periodic boxes for the structure tests (nearest-neighbour distance 1).
#include <Eigen/Core>
#include <cmath>
#include <random>
#include <vector>

#include "core/box.hpp"
#include "core/particle_store.hpp"

namespace polydem::test {

struct Lattice {
  Eigen::Matrix3Xd position;
  Eigen::VectorXd radius;
  Box box;
  SphereView spheres() const { return {position, radius}; }
};

/// `cells` unit cells per axis of a cell with edges `cell` and the given basis (fractions of the cell).
inline Lattice makeLattice(const Eigen::Vector3d& cell, const std::vector<Eigen::Vector3d>& basis, int cells,
                           double radius = 0.5, double jitter = 0.0, unsigned seed = 1) {
  Lattice out;
  const int n = cells * cells * cells * static_cast<int>(basis.size());
  out.position.resize(3, n);
  out.radius = Eigen::VectorXd::Constant(n, radius);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-jitter, jitter);
  int k = 0;
  for (int a = 0; a < cells; ++a) {
    for (int b = 0; b < cells; ++b) {
      for (int c = 0; c < cells; ++c) {
        for (const Eigen::Vector3d& f : basis) {
          out.position.col(k++) =
              (Eigen::Vector3d(a, b, c) + f).cwiseProduct(cell) + Eigen::Vector3d(u(rng), u(rng), u(rng));
        }
      }
    }
  }
  out.box = Box(cells * cell, {Boundary::Periodic, Boundary::Periodic, Boundary::Periodic});
  for (int i = 0; i < n; ++i) out.position.col(i) = out.box.wrap(out.position.col(i));
  return out;
}

inline Lattice fcc(int cells, double jitter = 0.0) {
  const double a = std::sqrt(2.0);
  return makeLattice({a, a, a}, {{0, 0, 0}, {0.5, 0.5, 0}, {0.5, 0, 0.5}, {0, 0.5, 0.5}}, cells, 0.5, jitter);
}
inline Lattice bcc(int cells, double jitter = 0.0) {
  const double a = 2.0 / std::sqrt(3.0);
  return makeLattice({a, a, a}, {{0, 0, 0}, {0.5, 0.5, 0.5}}, cells, 0.5, jitter);
}
inline Lattice sc(int cells, double jitter = 0.0) { return makeLattice({1, 1, 1}, {{0, 0, 0}}, cells, 0.5, jitter); }
/// HCP in its orthorhombic cell a x sqrt(3) a x c, c = sqrt(8/3) a (ABAB stacking along z).
inline Lattice hcp(int cells, double jitter = 0.0) {
  return makeLattice({1.0, std::sqrt(3.0), std::sqrt(8.0 / 3.0)},
                     {{0, 0, 0}, {0.5, 0.5, 0}, {0.5, 1.0 / 6.0, 0.5}, {0, 2.0 / 3.0, 0.5}}, cells, 0.5, jitter);
}

/// Uniform random centres (an ideal gas) of equal spheres in a periodic cube of edge `length`.
inline Lattice idealGas(int n, double length, double radius, unsigned seed) {
  Lattice out;
  out.position.resize(3, n);
  out.radius = Eigen::VectorXd::Constant(n, radius);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, length);
  for (int i = 0; i < n; ++i) out.position.col(i) = Eigen::Vector3d(u(rng), u(rng), u(rng));
  out.box = Box::cubic(length, Boundary::Periodic);
  return out;
}

}  // namespace polydem::test
