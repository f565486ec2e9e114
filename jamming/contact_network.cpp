#include "jamming/contact_network.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "broadphase/registry.hpp"
#include "core/errors.hpp"

namespace polydem::jamming {

namespace {

// Brute force below this many spheres: N^2 / 2 = 2e6 distance evaluations take milliseconds, and it has
// no box-size condition.
constexpr Index kBruteForceSpheres = 2000;

// True if a broad phase accepts `skin` in this box (periodic lengths >= 2 (2 r_max + skin)).
bool broadPhaseFits(const Box& box, double rmax, double skin) {
  for (int k = 0; k < 3; ++k) {
    if (box.periodic(k) && box.length(k) < 2.0 * (2.0 * rmax + skin)) return false;
  }
  return true;
}

// Calls f(i, j, distance) for every pair i < j with |r_ij| - (r_i + r_j) <= skin (minimum image): through
// the broad phase when the box allows, else by brute force.
template <class F>
void forPairsWithin(const SphereView& spheres, const Box& box, double skin, const std::string& broadPhase, F&& f) {
  const Index n = spheres.count();
  if (n < 2) return;
  const double rmax = spheres.radius.maxCoeff();
  if (n > kBruteForceSpheres && broadPhaseFits(box, rmax, skin)) {
    auto broad = broadphase::makeBroadPhase(broadPhase);
    broad->build(spheres, box, skin);
    std::vector<broadphase::Pair> pairs;
    broad->findPairs(spheres, pairs);
    for (const broadphase::Pair& p : pairs) {
      f(p.i, p.j, box.minimumImage(spheres.centre.col(p.i) - spheres.centre.col(p.j)).norm());
    }
    return;
  }
  for (Index i = 0; i < n; ++i) {
    for (Index j = i + 1; j < n; ++j) {
      const double d = box.minimumImage(spheres.centre.col(i) - spheres.centre.col(j)).norm();
      if (d - (spheres.radius[i] + spheres.radius[j]) <= skin) f(i, j, d);
    }
  }
}

}  // namespace

std::optional<PairGap> smallestGap(const SphereView& spheres, const Box& box, const std::string& broadPhase) {
  const Index n = spheres.count();
  if (n < 2) return std::nullopt;
  const double rmax = spheres.radius.maxCoeff();
  PairGap best;
  best.gap = std::numeric_limits<double>::infinity();
  auto consider = [&](Index i, Index j, double d) {
    const double s = spheres.radius[i] + spheres.radius[j];
    const double g = (d - s) / s;
    if (g < best.gap) best = {i, j, g};
  };
  if (n <= kBruteForceSpheres) {
    forPairsWithin(spheres, box, std::numeric_limits<double>::infinity(), broadPhase, consider);
    return best;
  }
  // A pair left out has absolute gap > skin, so relative gap > skin / (2 r_max): the best pair found is
  // the true smallest once its relative gap is below that. Start from the mean spacing.
  double skin = std::cbrt(box.volume() / static_cast<double>(n));
  for (;;) {
    if (!broadPhaseFits(box, rmax, skin)) {
      best = {};
      best.gap = std::numeric_limits<double>::infinity();
      for (Index i = 0; i < n; ++i) {
        for (Index j = i + 1; j < n; ++j) {
          consider(i, j, box.minimumImage(spheres.centre.col(i) - spheres.centre.col(j)).norm());
        }
      }
      return best;
    }
    best.gap = std::numeric_limits<double>::infinity();
    forPairsWithin(spheres, box, skin, broadPhase, consider);
    if (best.gap <= skin / (2.0 * rmax)) return best;
    skin = std::isfinite(best.gap) ? best.gap * 2.0 * rmax * (1.0 + 1e-12) : 4.0 * skin;
  }
}

PackingValidity checkHardSpherePacking(const SphereView& spheres, const Box& box, const PackingCheckOptions& options) {
  if (!(options.overlapTolerance >= 0.0) || !std::isfinite(options.overlapTolerance)) {
    throw ConfigError(
        fmt::format("packing check: overlap tolerance must be finite and >= 0, got {}", options.overlapTolerance));
  }
  PackingValidity out;
  const Index n = spheres.count();
  out.spheres = n;
  out.tolerance = options.overlapTolerance;
  if (n == 0) {
    out.equalSpheres = true;
    out.densityBound = kPi / std::sqrt(18.0);
    return out;
  }
  double volume = 0.0, cubes = 0.0;
  const double rmin = spheres.radius.minCoeff(), rmax = spheres.radius.maxCoeff();
  for (Index i = 0; i < n; ++i) {
    const double r = spheres.radius[i];
    cubes += r * r * r;
  }
  volume = 4.0 / 3.0 * kPi * cubes;
  out.packingFraction = volume / box.volume();
  out.equalSpheres = rmax <= rmin * (1.0 + 1e-12);
  const double mean3 = cubes / static_cast<double>(n);
  out.densityBound = std::min(1.0, kPi / std::sqrt(18.0) * mean3 / (rmin * rmin * rmin));

  auto overlap = [&](double h, double scale, Index i, Index j, int wall) {
    if (!(h > 0.0)) return;
    const double relative = h / scale;
    if (relative > out.tolerance) ++out.overlaps;
    if (relative > out.worstOverlap) {
      out.worstOverlap = relative;
      out.worstI = i;
      out.worstJ = j;
      out.worstWall = wall;
    }
  };
  forPairsWithin(spheres, box, 0.0, options.broadPhase, [&](Index i, Index j, double d) {
    overlap(spheres.radius[i] + spheres.radius[j] - d, std::min(spheres.radius[i], spheres.radius[j]), i, j, -1);
  });
  for (Index i = 0; i < n; ++i) {
    const double r = spheres.radius[i];
    for (int k = 0; k < 3; ++k) {
      if (box.periodic(k)) {
        overlap(2.0 * r - box.length(k), r, i, i, -1);  // its own image, one period away
        continue;
      }
      overlap(r - spheres.centre(k, i), r, i, -1, 2 * k);
      overlap(spheres.centre(k, i) + r - box.length(k), r, i, -1, 2 * k + 1);
    }
  }
  return out;
}

std::string describeInvalidPacking(const PackingValidity& v, std::span<const Index> ids) {
  if (v.valid()) return {};
  auto name = [&](Index i) { return ids.empty() ? i : ids[static_cast<std::size_t>(i)]; };
  std::string worst;
  if (v.worstI >= 0) {
    const std::string what =
        v.worstJ == v.worstI ? fmt::format("sphere {} overlaps its own periodic image", name(v.worstI))
        : v.worstJ < 0
            ? fmt::format("sphere {} crosses the {} wall at {} = {}", name(v.worstI),
                          v.worstWall % 2 ? "upper" : "lower", "xyz"[v.worstWall / 2], v.worstWall % 2 ? "L" : "0")
            : fmt::format("spheres {} and {} overlap", name(v.worstI), name(v.worstJ));
    worst = fmt::format("{} by {:.3g} of the {} radius", what, v.worstOverlap,
                        v.worstJ >= 0 && v.worstJ != v.worstI ? "smaller" : "sphere's");
  }
  std::vector<std::string> parts;
  if (v.overlapTooLarge()) {
    parts.push_back(
        fmt::format("{} (worst of {} overlaps beyond the contact tolerance {:.1e})", worst, v.overlaps, v.tolerance));
  }
  if (v.densityTooHigh()) {
    parts.push_back(
        fmt::format("packing fraction {:.8f} exceeds {:.8f}, the largest any packing of these radii can have ({}){}",
                    v.packingFraction, v.densityBound,
                    v.equalSpheres         ? "FCC density pi/sqrt(18) for equal spheres"
                    : v.densityBound < 1.0 ? "pi/sqrt(18) <r^3>/r_min^3"
                                           : "the box volume",
                    v.overlapTooLarge() || worst.empty() ? "" : fmt::format("; worst overlap: {}", worst)));
  }
  std::string text;
  for (const std::string& p : parts) text += (text.empty() ? "" : "; ") + p;
  return text;
}

PackingValidity requireHardSpherePacking(const SphereView& spheres, const Box& box, const PackingCheckOptions& options,
                                         const std::string& what, std::span<const Index> ids) {
  const PackingValidity v = checkHardSpherePacking(spheres, box, options);
  if (!v.valid()) {
    throw InputError(
        fmt::format("{}: not a valid hard-sphere packing: {}; no contact statistics or jamming verdict "
                    "for it",
                    what, describeInvalidPacking(v, ids)));
  }
  return v;
}

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

}  // namespace polydem::jamming
