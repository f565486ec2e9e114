#include "structure/channel_size.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/errors.hpp"

namespace polydem::structure {

bool acuteTriangle(const Eigen::Vector3d& c1, const Eigen::Vector3d& c2, const Eigen::Vector3d& c3, double eps) {
  const double a2 = (c2 - c3).squaredNorm(), b2 = (c1 - c3).squaredNorm(), c2s = (c1 - c2).squaredNorm();
  return a2 + b2 > eps * c2s && c2s + b2 > eps * a2 && a2 + c2s > eps * b2;
}

std::optional<double> apolloniusGapRadius(const Eigen::Vector3d& c1, double r1, const Eigen::Vector3d& c2, double r2,
                                          const Eigen::Vector3d& c3, double r3) {
  // Plane frame: origin c1, e1 along c2 - c1, e2 in the plane.
  const Eigen::Vector3d u = c2 - c1, v = c3 - c1;
  const double lu = u.norm();
  if (!(lu > 0.0)) return std::nullopt;
  const Eigen::Vector3d e1 = u / lu;
  const Eigen::Vector3d w = v - v.dot(e1) * e1;
  const double lw = w.norm();
  const double scale = std::max(lu, v.norm());
  if (!(lw > 1e-14 * scale)) return std::nullopt;  // collinear: no bounded gap
  // Centres 2 and 3 in plane coordinates (centre 1 at the origin).
  const double p2x = lu, p2y = 0.0;
  const double p3x = v.dot(e1), p3y = lw;
  // 2 c_k . x + 2 (r_k - r_1) R = |c_k|^2 - r_k^2 + r_1^2; solve the 2x2 system for x = x0 + R x1.
  const double a11 = 2.0 * p2x, a12 = 2.0 * p2y, a21 = 2.0 * p3x, a22 = 2.0 * p3y;
  const double det = a11 * a22 - a12 * a21;
  const double f1 = p2x * p2x + p2y * p2y - r2 * r2 + r1 * r1, f2 = p3x * p3x + p3y * p3y - r3 * r3 + r1 * r1;
  const double g1 = -2.0 * (r2 - r1), g2 = -2.0 * (r3 - r1);
  const double x0 = (f1 * a22 - a12 * f2) / det, y0 = (a11 * f2 - f1 * a21) / det;
  const double x1 = (g1 * a22 - a12 * g2) / det, y1 = (a11 * g2 - g1 * a21) / det;
  // (|x1|^2 - 1) R^2 + 2 (x0.x1 - r1) R + |x0|^2 - r1^2 = 0
  const double qa = x1 * x1 + y1 * y1 - 1.0;
  const double qb = x0 * x1 + y0 * y1 - r1;  // half the linear coefficient
  const double qc = x0 * x0 + y0 * y0 - r1 * r1;
  double roots[2];
  int count = 0;
  const double disc = qb * qb - qa * qc;
  if (std::abs(qa) <= 1e-14 * (std::abs(qb) + std::abs(qc) / scale)) {
    if (qb != 0.0) roots[count++] = -qc / (2.0 * qb);  // linear: 2 qb R + qc = 0
  } else if (disc >= 0.0) {
    const double s = std::sqrt(disc);
    const double q = -(qb + std::copysign(s, qb));  // no cancellation
    roots[count++] = q / qa;
    if (q != 0.0) roots[count++] = qc / q;
  }
  std::optional<double> best;
  for (int k = 0; k < count; ++k) {
    const double R = roots[k];
    if (!(R > 0.0) || !std::isfinite(R)) continue;
    // Confirm the tangencies (round-off can produce a spurious root when the system is ill-conditioned).
    const double x = x0 + R * x1, y = y0 + R * y1;
    const double tol = 1e-7 * (scale + R);
    const double t1 = std::hypot(x, y) - (R + r1);
    const double t2 = std::hypot(x - p2x, y - p2y) - (R + r2);
    const double t3 = std::hypot(x - p3x, y - p3y) - (R + r3);
    if (std::abs(t1) > tol || std::abs(t2) > tol || std::abs(t3) > tol) continue;
    if (!best || R < *best) best = R;
  }
  return best;
}

ChannelHistogram channelSizes(const SphereView& spheres, const NeighbourList& neighbours,
                              const ChannelOptions& options) {
  if (!(options.binWidth > 0.0) || !std::isfinite(options.binWidth)) {
    throw ConfigError(fmt::format("channel sizes: bin width must be finite and > 0, got {}", options.binWidth));
  }
  if (!(options.eps > 0.0 && options.eps <= 1.0)) {
    throw ConfigError(fmt::format("channel sizes: acute-filter eps must lie in (0, 1], got {}", options.eps));
  }
  if (!(options.maxRatio > options.binWidth) || !std::isfinite(options.maxRatio)) {
    throw ConfigError(fmt::format("channel sizes: maxRatio {} must be finite and above the bin width {}",
                                  options.maxRatio, options.binWidth));
  }
  const Index n = spheres.count();
  if (neighbours.count() != n) {
    throw ConfigError(
        fmt::format("channel sizes: neighbour list has {} particles, the packing {}", neighbours.count(), n));
  }
  ChannelHistogram out;
  out.binWidth = options.binWidth;
  double sum = 0.0, sum2 = 0.0;
  for (Index i = 0; i < n; ++i) {
    const Index b = neighbours.start[i], e = neighbours.start[i + 1];
    const double ri = spheres.radius[i];
    for (Index p = b; p < e; ++p) {
      const Eigen::Vector3d cp = neighbours.displacement.col(p);
      const double rp = spheres.radius[neighbours.neighbour[p]];
      for (Index q = p + 1; q < e; ++q) {
        const Eigen::Vector3d cq = neighbours.displacement.col(q);
        const double rq = spheres.radius[neighbours.neighbour[q]];
        const double pq2 = (cp - cq).squaredNorm();
        for (Index s = q + 1; s < e; ++s) {
          ++out.triangles;
          const Eigen::Vector3d cs = neighbours.displacement.col(s);
          const double ps2 = (cp - cs).squaredNorm(), qs2 = (cq - cs).squaredNorm();
          const double eps = options.eps;
          if (!(pq2 + ps2 > eps * qs2 && pq2 + qs2 > eps * ps2 && ps2 + qs2 > eps * pq2)) continue;
          ++out.acute;
          const std::optional<double> R =
              apolloniusGapRadius(cp, rp, cq, rq, cs, spheres.radius[neighbours.neighbour[s]]);
          if (!R) continue;
          const double x = *R / ri;
          ++out.channels;
          sum += x;
          sum2 += x * x;
          if (x >= options.maxRatio) {
            ++out.overflow;
            continue;
          }
          const std::size_t bin = static_cast<std::size_t>(x / options.binWidth);
          if (bin >= out.counts.size()) out.counts.resize(std::max(bin + 1, 2 * out.counts.size()), 0);
          ++out.counts[bin];
        }
      }
    }
  }
  // Trim trailing empty bins left by geometric growth.
  while (!out.counts.empty() && out.counts.back() == 0) out.counts.pop_back();
  out.density.resize(out.counts.size());
  for (std::size_t k = 0; k < out.counts.size(); ++k) {
    // Normalised over all channels: with overflow the binned area is below 1.
    out.density[k] = out.channels ? double(out.counts[k]) / (double(out.channels) * options.binWidth) : 0.0;
  }
  if (out.channels) {
    out.mean = sum / out.channels;
    out.stddev = std::sqrt(std::max(0.0, sum2 / out.channels - out.mean * out.mean));
  }
  return out;
}

}  // namespace polydem::structure
