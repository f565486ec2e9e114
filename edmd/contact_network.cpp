#include "edmd/contact_network.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "broadphase/registry.hpp"
#include "core/errors.hpp"

namespace polydem::edmd {

double ContactNetwork::meanCoordination() const {
  return particles ? (2.0 * static_cast<double>(contacts.size()) + static_cast<double>(wallContacts.size())) / particles
                   : 0.0;
}

double ContactNetwork::backboneCoordination() const {
  if (!backbone) return std::numeric_limits<double>::quiet_NaN();
  std::int64_t walls = 0;
  for (const WallContact& w : wallContacts) walls += rattler[static_cast<std::size_t>(w.i)] ? 0 : 1;
  return (2.0 * static_cast<double>(backboneContacts - walls) + static_cast<double>(walls)) / backbone;
}

double ContactNetwork::rattlerFraction() const {
  return particles ? static_cast<double>(particles - backbone) / particles : 0.0;
}

double defaultContactGap(double pressure) {
  if (!(pressure > 0.0)) return 1e-3;
  return std::min(1e-3, std::max(100.0 / pressure, std::sqrt(1e-3 / pressure)));
}

ContactNetwork analyseContacts(const SphereView& spheres, const Box& box, const ContactOptions& options) {
  if (!(options.relativeGap >= 0.0)) {
    throw ConfigError(fmt::format("contact gap tolerance must be >= 0, got {}", options.relativeGap));
  }
  ContactNetwork net;
  const Index n = spheres.count();
  net.particles = n;
  net.coordination.assign(static_cast<std::size_t>(n), 0);
  net.rattler.assign(static_cast<std::size_t>(n), 0);
  if (n == 0) return net;
  const double rmax = spheres.radius.maxCoeff();
  auto broad = broadphase::makeBroadPhase(options.broadPhase);
  const double skin = options.relativeGap * 2.0 * rmax * (1.0 + 1e-9);
  broad->build(spheres, box, skin);
  std::vector<broadphase::Pair> candidates;
  broad->findPairs(spheres, candidates);
  net.minGap = std::numeric_limits<double>::infinity();
  for (const broadphase::Pair& p : candidates) {
    const double s = spheres.radius[p.i] + spheres.radius[p.j];
    const double dist = box.minimumImage(spheres.centre.col(p.i) - spheres.centre.col(p.j)).norm();
    const double gap = (dist - s) / s;
    net.minGap = std::min(net.minGap, gap);
    net.maxOverlap = std::max(net.maxOverlap, -gap);
    if (gap <= options.relativeGap) net.contacts.push_back(p);
  }
  broadphase::sortPairs(net.contacts);
  for (const auto& p : net.contacts) {
    ++net.coordination[static_cast<std::size_t>(p.i)];
    ++net.coordination[static_cast<std::size_t>(p.j)];
  }
  net.periodicAxes = 0;
  for (int k = 0; k < 3; ++k) {
    if (box.periodic(k)) {
      ++net.periodicAxes;
      continue;
    }
    for (Index i = 0; i < n; ++i) {
      const double r = spheres.radius[i], x = spheres.centre(k, i);
      for (int upper = 0; upper < 2; ++upper) {
        const double gap = upper ? box.length(k) - x - r : x - r;
        if (gap <= options.relativeGap * 2.0 * r) {
          net.wallContacts.push_back({i, 2 * k + upper});
          ++net.coordination[static_cast<std::size_t>(i)];
        }
      }
    }
  }
  // Iterative rattler removal with a work list.
  std::vector<std::vector<Index>> adjacency(static_cast<std::size_t>(n));
  for (const auto& p : net.contacts) {
    adjacency[static_cast<std::size_t>(p.i)].push_back(p.j);
    adjacency[static_cast<std::size_t>(p.j)].push_back(p.i);
  }
  std::vector<int> live = net.coordination;
  std::vector<Index> stack;
  for (Index i = 0; i < n; ++i) {
    if (live[static_cast<std::size_t>(i)] < options.minContacts) stack.push_back(i);
  }
  while (!stack.empty()) {
    const Index i = stack.back();
    stack.pop_back();
    const std::size_t ui = static_cast<std::size_t>(i);
    if (net.rattler[ui]) continue;
    net.rattler[ui] = 1;
    for (Index j : adjacency[ui]) {
      const std::size_t uj = static_cast<std::size_t>(j);
      if (net.rattler[uj]) continue;
      if (--live[uj] < options.minContacts) stack.push_back(j);
    }
  }
  net.backbone = 0;
  for (Index i = 0; i < n; ++i) net.backbone += net.rattler[static_cast<std::size_t>(i)] ? 0 : 1;
  net.backboneContacts = 0;
  for (const auto& p : net.contacts) {
    if (!net.rattler[static_cast<std::size_t>(p.i)] && !net.rattler[static_cast<std::size_t>(p.j)])
      ++net.backboneContacts;
  }
  for (const WallContact& w : net.wallContacts)
    net.backboneContacts += net.rattler[static_cast<std::size_t>(w.i)] ? 0 : 1;
  if (!std::isfinite(net.minGap)) net.minGap = 0.0;
  return net;
}

std::vector<double> cumulativeCoordination(const SphereView& spheres, const Box& box, const std::vector<double>& taus,
                                           const std::string& broadPhase) {
  std::vector<double> out(taus.size(), 0.0);
  const Index n = spheres.count();
  if (n == 0 || taus.empty()) return out;
  const double tauMax = *std::max_element(taus.begin(), taus.end());
  const double rmax = spheres.radius.maxCoeff();
  auto broad = broadphase::makeBroadPhase(broadPhase);
  broad->build(spheres, box, tauMax * 2.0 * rmax * (1.0 + 1e-9));
  std::vector<broadphase::Pair> pairs;
  broad->findPairs(spheres, pairs);
  std::vector<double> gaps;
  gaps.reserve(pairs.size());
  for (const auto& p : pairs) {
    const double s = spheres.radius[p.i] + spheres.radius[p.j];
    gaps.push_back((box.minimumImage(spheres.centre.col(p.i) - spheres.centre.col(p.j)).norm() - s) / s);
  }
  std::sort(gaps.begin(), gaps.end());
  for (std::size_t k = 0; k < taus.size(); ++k) {
    const auto count = std::upper_bound(gaps.begin(), gaps.end(), taus[k]) - gaps.begin();
    out[k] = 2.0 * static_cast<double>(count) / n;
  }
  return out;
}

PairCorrelation pairCorrelation(const SphereView& spheres, const Box& box, double xMax, int bins,
                                const std::string& broadPhase) {
  if (!(xMax > 1.0) || bins <= 0) {
    throw ConfigError(fmt::format("pair correlation: x max must be > 1 and bins > 0, got {} and {}", xMax, bins));
  }
  PairCorrelation out;
  const Index n = spheres.count();
  out.x.resize(static_cast<std::size_t>(bins));
  out.g.assign(static_cast<std::size_t>(bins), 0.0);
  const double dx = xMax / bins;
  for (int b = 0; b < bins; ++b) out.x[static_cast<std::size_t>(b)] = (b + 0.5) * dx;
  if (n < 2) return out;
  const double rmax = spheres.radius.maxCoeff();
  auto broad = broadphase::makeBroadPhase(broadPhase);
  broad->build(spheres, box, (xMax - 1.0) * 2.0 * rmax * (1.0 + 1e-9));
  std::vector<broadphase::Pair> pairs;
  broad->findPairs(spheres, pairs);
  std::vector<double> count(static_cast<std::size_t>(bins), 0.0);
  for (const auto& p : pairs) {
    const double s = spheres.radius[p.i] + spheres.radius[p.j];
    const double x = box.minimumImage(spheres.centre.col(p.i) - spheres.centre.col(p.j)).norm() / s;
    const int b = static_cast<int>(x / dx);
    if (b >= 0 && b < bins) count[static_cast<std::size_t>(b)] += 2.0;  // ordered pairs
  }
  // Ideal-gas expectation: sum over ordered pairs i != j of (r_i + r_j)^3, from the raw moments.
  double s1 = 0.0, s2 = 0.0, s3 = 0.0;
  for (Index i = 0; i < n; ++i) {
    const double r = spheres.radius[i];
    s1 += r;
    s2 += r * r;
    s3 += r * r * r;
  }
  const double sigma3 = 2.0 * n * s3 + 6.0 * s1 * s2 - 8.0 * s3;
  for (int b = 0; b < bins; ++b) {
    const double lo = b * dx, hi = (b + 1) * dx;
    const double ideal = 4.0 * kPi / 3.0 * (hi * hi * hi - lo * lo * lo) / box.volume() * sigma3;
    out.g[static_cast<std::size_t>(b)] = count[static_cast<std::size_t>(b)] / ideal;
  }
  return out;
}

}  // namespace polydem::edmd
