#include "structure/bond_order.hpp"

#include <fmt/format.h>

#include <array>
#include <cmath>

#include "core/errors.hpp"
#include "core/types.hpp"
#include "structure/spherical_harmonics.hpp"

namespace polydem::structure {

BondOrder bondOrder(const NeighbourList& neighbours, const BondOrderOptions& options) {
  const int l = options.degree;
  if (l < 0 || l > kMaxDegree) {
    throw ConfigError(fmt::format("bond order: degree l = {} outside 0..{}", l, kMaxDegree));
  }
  if (!(options.connectionThreshold >= -1.0 && options.connectionThreshold <= 1.0)) {
    throw ConfigError(fmt::format("bond order: connection threshold {} outside [-1, 1]", options.connectionThreshold));
  }
  if (options.minConnections < 0) {
    throw ConfigError(fmt::format("bond order: minConnections {} must be >= 0", options.minConnections));
  }
  const Index n = neighbours.count();
  const int width = 2 * l + 1;
  BondOrder out;
  out.degree = l;
  out.normalised = Eigen::MatrixXcd::Zero(width, n);
  out.q.assign(static_cast<std::size_t>(n), 0.0);
  out.connections.assign(static_cast<std::size_t>(n), 0);
  out.solid.assign(static_cast<std::size_t>(n), 0);
  std::array<std::complex<double>, 2 * kMaxDegree + 1> y{}, sum{};
  Eigen::VectorXcd global = Eigen::VectorXcd::Zero(width);
  std::int64_t bonds = 0;
  double qSum = 0.0;
  Index withNeighbours = 0;
  for (Index i = 0; i < n; ++i) {
    const Index b = neighbours.start[i], e = neighbours.start[i + 1];
    if (e == b) continue;
    sum.fill({0.0, 0.0});
    for (Index k = b; k < e; ++k) {
      const Eigen::Vector3d d = neighbours.displacement.col(k);
      const double len = d.norm();
      if (!(len > 0.0)) continue;  // coincident centres have no direction
      sphericalHarmonics(l, d / len, y);
      for (int m = 0; m < width; ++m) sum[m] += y[m];
    }
    double norm2 = 0.0;
    for (int m = 0; m < width; ++m) {
      global[m] += sum[m];
      norm2 += std::norm(sum[m]);
    }
    bonds += e - b;
    const double count = double(e - b);
    out.q[i] = std::sqrt(4.0 * kPi / width * norm2) / count;
    qSum += out.q[i];
    ++withNeighbours;
    if (norm2 > 0.0) {
      const double inv = 1.0 / std::sqrt(norm2);
      for (int m = 0; m < width; ++m) out.normalised(m, i) = sum[m] * inv;
    }
  }
  for (Index i = 0; i < n; ++i) {
    int c = 0;
    for (Index k = neighbours.start[i]; k < neighbours.start[i + 1]; ++k) {
      if (bondCorrelation(out, i, neighbours.neighbour[k]) > options.connectionThreshold) ++c;
    }
    out.connections[i] = c;
    out.solid[i] = c >= options.minConnections && neighbours.degree(i) > 0;
    out.solidCount += out.solid[i];
  }
  out.crystallineFraction = n ? double(out.solidCount) / n : 0.0;
  out.meanQ = withNeighbours ? qSum / withNeighbours : 0.0;
  out.globalQ = bonds ? std::sqrt(4.0 * kPi / width * global.squaredNorm()) / double(bonds) : 0.0;
  return out;
}

double bondCorrelation(const BondOrder& order, Index i, Index j) {
  // Re sum_m a_m conj(b_m); the sum is real for real-valued bond sets (q_l(-m) = (-1)^m conj(q_lm)).
  double s = 0.0;
  for (Eigen::Index m = 0; m < order.normalised.rows(); ++m) {
    const std::complex<double> a = order.normalised(m, i), b = order.normalised(m, j);
    s += a.real() * b.real() + a.imag() * b.imag();
  }
  return s;
}

}  // namespace polydem::structure
