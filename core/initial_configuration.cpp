// Initial configurations by random sequential addition (RSA) and by independent uniform centres.
//
// RSA: spheres are inserted largest first at uniformly random trial centres; a trial is accepted when it
// overlaps no sphere already placed. Largest first because a big sphere finds no room once small ones
// are spread everywhere, while small ones still fit in the gaps between big ones. Saturation is near
// packing fraction 0.38 for monodisperse spheres; beyond that one needs compression (event-driven LS),
// which is what the stall error points to.
//
// Overlap queries use a private multi-level grid in the spirit of the hierarchical grid of Ogarko &
// Luding, Comput. Phys. Commun. 183 (2012) 931 (Ogarko's thesis §2.1.3, "Polydisperse systems"):
// radii are binned by factors of 2 below the largest, each level is a dense grid whose cells are at
// least that level's largest diameter, and a trial sphere of radius r is tested against level l over
// the cells within r + rmax_l of its centre.
// Cells per level are capped at 8 x (spheres in the level) by enlarging cells, so memory stays O(N)
// for any size distribution. A hash of occupied cells would also work; dense arrays are simpler and a
// level is only touched once its spheres start to be placed. Rejected design: one grid sized to the
// largest sphere (the small spheres of a wide distribution would all share a few cells).
#include "core/initial_configuration.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "core/errors.hpp"
#include "core/types.hpp"

namespace polydem {

namespace {

double uniform01(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

/// Validates the request and returns the box holding the spheres at the requested packing fraction.
Box makeBox(const PackingRequest& request) {
  if (!(request.packingFraction > 0.0 && request.packingFraction < 1.0)) {
    throw ConfigError(fmt::format("packingFraction must be in (0, 1), got {}", request.packingFraction));
  }
  for (int k = 0; k < 3; ++k) {
    if (!(request.aspect[k] > 0.0 && std::isfinite(request.aspect[k]))) {
      throw ConfigError(fmt::format("aspect along {} must be > 0 and finite, got {}", "xyz"[k], request.aspect[k]));
    }
  }
  if (request.radii.empty()) throw ConfigError("radii must not be empty: need at least one sphere to size the box");
  double volume = 0.0;
  for (std::size_t i = 0; i < request.radii.size(); ++i) {
    const double r = request.radii[i];
    if (!(r > 0.0 && std::isfinite(r))) {
      throw ConfigError(fmt::format("radius {} must be > 0 and finite, got {}", i, r));
    }
    volume += 4.0 / 3.0 * kPi * r * r * r;
  }
  const double boxVolume = volume / request.packingFraction;
  const double scale = std::cbrt(boxVolume / request.aspect.prod());
  const Box box(scale * request.aspect, request.boundaries);
  const double rmax = *std::max_element(request.radii.begin(), request.radii.end());
  for (int k = 0; k < 3; ++k) {
    if (box.length(k) < 2.0 * rmax) {
      throw ConfigError(fmt::format(
          "box length {:g} along {} is below the largest diameter {:g}: add spheres, lower packingFraction or "
          "change aspect",
          box.length(k), "xyz"[k], 2.0 * rmax));
    }
  }
  return box;
}

/// A uniformly random centre for a sphere of radius r: [0, L) on periodic axes, [r, L - r] on walled ones.
Eigen::Vector3d randomCentre(const Box& box, double r, std::mt19937_64& rng) {
  Eigen::Vector3d x;
  for (int k = 0; k < 3; ++k) {
    const double length = box.length(k);
    if (box.periodic(k)) {
      x[k] = uniform01(rng) * length;
      if (x[k] >= length) x[k] = 0.0;  // u * L can round up to L
    } else {
      x[k] = std::clamp(r + uniform01(rng) * (length - 2.0 * r), r, length - r);
    }
  }
  return x;
}

// Levels of cells: level l holds radii in (rmax / 2^(l+1), rmax / 2^l].
class MultiLevelGrid {
 public:
  MultiLevelGrid(const Box& box, const std::vector<double>& radii) : box_(box), next_(radii.size(), -1) {
    const double rmax = *std::max_element(radii.begin(), radii.end());
    levelOf_.resize(radii.size());
    for (std::size_t i = 0; i < radii.size(); ++i) {
      const int l = std::clamp(static_cast<int>(std::floor(std::log2(rmax / radii[i]))), 0, kMaxLevels - 1);
      levelOf_[i] = l;
      if (l >= static_cast<int>(levels_.size())) levels_.resize(static_cast<std::size_t>(l) + 1);
      Level& level = levels_[static_cast<std::size_t>(l)];
      level.rmax = std::max(level.rmax, radii[i]);
      ++level.count;
    }
    for (Level& level : levels_) {
      if (level.count == 0) continue;
      const double cap = 8.0 * static_cast<double>(level.count) + 64.0;
      const double size = std::max(2.0 * level.rmax, std::cbrt(box.volume() / cap));
      std::int64_t cells = 1;
      for (int k = 0; k < 3; ++k) {
        level.n[k] = std::max<std::int64_t>(1, static_cast<std::int64_t>(std::floor(box.length(k) / size)));
        level.inverseCell[k] = static_cast<double>(level.n[k]) / box.length(k);
        cells *= level.n[k];
      }
      level.head.assign(static_cast<std::size_t>(cells), -1);
    }
  }

  /// True when a sphere (x, r) would overlap a sphere already inserted (touching is not overlap).
  bool overlaps(const Eigen::Vector3d& x, double r, const Eigen::Matrix3Xd& position,
                const std::vector<double>& radii) const {
    for (const Level& level : levels_) {
      if (level.inserted == 0) continue;
      const double reach = r + level.rmax;
      std::array<std::int64_t, 3> lo, hi;
      for (int k = 0; k < 3; ++k) {
        lo[k] = static_cast<std::int64_t>(std::floor((x[k] - reach) * level.inverseCell[k]));
        hi[k] = static_cast<std::int64_t>(std::floor((x[k] + reach) * level.inverseCell[k]));
        if (!box_.periodic(k)) {
          lo[k] = std::max<std::int64_t>(lo[k], 0);
          hi[k] = std::min<std::int64_t>(hi[k], level.n[k] - 1);
        } else if (hi[k] - lo[k] + 1 >= level.n[k]) {
          lo[k] = 0;  // the range wraps onto itself: visit each cell once
          hi[k] = level.n[k] - 1;
        }
      }
      for (std::int64_t iz = lo[2]; iz <= hi[2]; ++iz) {
        const std::int64_t cz = wrap(iz, level.n[2]);
        for (std::int64_t iy = lo[1]; iy <= hi[1]; ++iy) {
          const std::int64_t cy = wrap(iy, level.n[1]);
          for (std::int64_t ix = lo[0]; ix <= hi[0]; ++ix) {
            const std::int64_t cx = wrap(ix, level.n[0]);
            for (Index j = level.head[static_cast<std::size_t>((cz * level.n[1] + cy) * level.n[0] + cx)]; j >= 0;
                 j = next_[static_cast<std::size_t>(j)]) {
              const Eigen::Vector3d d = box_.minimumImage(x - position.col(j));
              const double contact = r + radii[static_cast<std::size_t>(j)];
              if (d.squaredNorm() < contact * contact) return true;
            }
          }
        }
      }
    }
    return false;
  }

  void insert(Index i, const Eigen::Vector3d& x) {
    Level& level = levels_[static_cast<std::size_t>(levelOf_[static_cast<std::size_t>(i)])];
    std::int64_t cell = 0;
    for (int k = 2; k >= 0; --k) {
      const auto c = std::clamp(static_cast<std::int64_t>(std::floor(x[k] * level.inverseCell[k])), std::int64_t{0},
                                level.n[k] - 1);
      cell = cell * level.n[k] + c;
    }
    next_[static_cast<std::size_t>(i)] = level.head[static_cast<std::size_t>(cell)];
    level.head[static_cast<std::size_t>(cell)] = i;
    ++level.inserted;
  }

 private:
  static constexpr int kMaxLevels = 64;
  struct Level {
    double rmax = 0.0;
    Index count = 0, inserted = 0;
    std::array<std::int64_t, 3> n{1, 1, 1};
    Eigen::Vector3d inverseCell = Eigen::Vector3d::Ones();
    std::vector<Index> head;  // first sphere per cell, -1 when empty; cells x fastest
  };
  // Only periodic ranges leave [0, n); walled ranges were clamped.
  static std::int64_t wrap(std::int64_t i, std::int64_t n) {
    if (i < 0) return i + n;
    if (i >= n) return i - n;
    return i;
  }

  const Box& box_;
  std::vector<Level> levels_;
  std::vector<int> levelOf_;
  std::vector<Index> next_;  // next sphere in the same cell
};

Configuration emptyConfiguration(const Box& box, const std::vector<double>& radii) {
  Configuration config;
  config.box = box;
  const auto count = static_cast<Eigen::Index>(radii.size());
  config.position.setZero(3, count);
  config.radius = Eigen::Map<const Eigen::VectorXd>(radii.data(), count);
  return config;
}

}  // namespace

Configuration randomSequentialAddition(const PackingRequest& request) {
  if (request.maxAttemptsPerParticle < 1) {
    throw ConfigError(fmt::format("maxAttemptsPerParticle must be >= 1, got {}", request.maxAttemptsPerParticle));
  }
  const Box box = makeBox(request);
  const std::vector<double>& radii = request.radii;
  Configuration config = emptyConfiguration(box, radii);
  const auto count = static_cast<Index>(radii.size());

  std::vector<Index> order(radii.size());
  std::iota(order.begin(), order.end(), Index{0});
  // Index tie-break = the stable order (no std::stable_sort buffer; see integrators::mortonOrder).
  std::sort(order.begin(), order.end(), [&](Index a, Index b) {
    const double ra = radii[static_cast<std::size_t>(a)];
    const double rb = radii[static_cast<std::size_t>(b)];
    return ra > rb || (ra == rb && a < b);
  });

  MultiLevelGrid grid(box, radii);
  std::mt19937_64 rng(request.seed);
  double placedVolume = 0.0;
  for (Index placed = 0; placed < count; ++placed) {
    const Index i = order[static_cast<std::size_t>(placed)];
    const double r = radii[static_cast<std::size_t>(i)];
    bool done = false;
    for (std::int64_t attempt = 0; attempt < request.maxAttemptsPerParticle && !done; ++attempt) {
      const Eigen::Vector3d x = randomCentre(box, r, rng);
      if (grid.overlaps(x, r, config.position, radii)) continue;
      config.position.col(i) = x;
      grid.insert(i, x);
      done = true;
    }
    if (!done) {
      throw ConfigError(fmt::format(
          "random sequential addition stalled at packing fraction {:.4f} after placing {} of {} spheres (no free "
          "spot for radius {:g} in {} attempts); request a lower packingFraction than {:g}, or use `polydem jam` "
          "(event-driven compression) for denser states",
          placedVolume / box.volume(), placed, count, r, request.maxAttemptsPerParticle, request.packingFraction));
    }
    placedVolume += 4.0 / 3.0 * kPi * r * r * r;
  }
  return config;
}

Configuration randomOverlapping(const PackingRequest& request) {
  const Box box = makeBox(request);
  Configuration config = emptyConfiguration(box, request.radii);
  std::mt19937_64 rng(request.seed);
  for (Eigen::Index i = 0; i < config.radius.size(); ++i) {
    config.position.col(i) = randomCentre(box, config.radius[i], rng);
  }
  return config;
}

StartPacking makeStartPacking(const SizeDistribution& distribution, const StartPackingRequest& request) {
  PackingRequest packing;
  packing.radii =
      request.radii.empty() ? distribution.sample(request.count, request.sampling, request.seed) : request.radii;
  std::mt19937_64 rng(request.seed ^ kStartShuffleSalt);
  std::shuffle(packing.radii.begin(), packing.radii.end(), rng);
  packing.packingFraction = request.packingFraction;
  packing.aspect = request.aspect;
  packing.boundaries = request.boundaries;
  packing.seed = request.seed;
  StartPacking out;
  out.configuration = request.placement == Placement::RandomSequentialAddition ? randomSequentialAddition(packing)
                                                                               : randomOverlapping(packing);
  const Index n = static_cast<Index>(out.configuration.radius.size());
  out.id.resize(static_cast<std::size_t>(n));
  std::iota(out.id.begin(), out.id.end(), Index(0));
  out.distribution = distribution.describe();
  return out;
}

}  // namespace polydem
