#pragma once
// The broad-phase interface every contact-detection backend implements.
//
// A pair (i, j) counts when the gap between the spheres is at most `skin`:
//   |minimumImage(x_i - x_j)| <= r_i + r_j + skin.
// Every complete backend filters candidates with the one predicate withinReach() below, so all of
// them report bit-identical pair sets (the property suite compares them with EXPECT_EQ).
//
// One virtual call per build or query, never one per pair. Buffers are owned by the caller and only
// grow, so steady-state calls do not allocate (exception: an HGrid with a configurator, whose
// configuration is returned by value at every build, see hgrid.hpp).
#include <compare>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "core/box.hpp"
#include "core/particle_store.hpp"
#include "core/types.hpp"

namespace polydem::broadphase {

class PairChunks;

/// A candidate pair, i < j.
struct Pair {
  Index i, j;
  auto operator<=>(const Pair&) const = default;
};

struct Capabilities {
  bool complete = true;      ///< reports every pair within the skin (false: must report its recall)
  bool incremental = false;  ///< update() is cheaper than a rebuild
};

/// Work counters (enabled with setCounting(true)); the cost model's T_cd and T_ca.
struct Counters {
  std::uint64_t pairTests = 0;     ///< candidate pairs given the exact (narrow-phase) test
  std::uint64_t cellAccesses = 0;  ///< cell look-ups
};

/// The one pair predicate on raw coordinates: centres a, b with radii ra, rb. Written out term by term
/// (and compiled without FMA contraction) so every caller rounds identically. Symmetric in (a, b).
inline bool spheresWithinReach(const Box& box, const double* a, double ra, const double* b, double rb, double reach) {
  const Eigen::Vector3d d = box.minimumImage(Eigen::Vector3d(a[0] - b[0], a[1] - b[1], a[2] - b[2]));
  const double limit = (ra + rb) + reach;
  return d[0] * d[0] + d[1] * d[1] + d[2] * d[2] <= limit * limit;
}

/// The one pair predicate. Precondition: both centres inside the box (see Box::minimumImage).
inline bool withinReach(const SphereView& s, const Box& box, Index i, Index j, double reach) {
  return spheresWithinReach(box, s.centre.col(i).data(), s.radius[i], s.centre.col(j).data(), s.radius[j], reach);
}

class BroadPhase {
 public:
  virtual ~BroadPhase() = default;
  virtual std::string_view name() const = 0;
  virtual Capabilities capabilities() const { return {}; }

  /// Index all spheres for pairs with gap <= skin (m). Validates the input first and throws
  /// ConfigError naming the particle: non-finite or non-positive radius, non-finite centre, centre
  /// outside the box, periodic axis shorter than 2 (2 r_max + skin). O(N) for grid backends.
  void build(const SphereView& spheres, const Box& box, double skin);

  /// Spheres in `moved` changed position since build()/update() (event-driven use, by less than a
  /// cell). Default: full rebuild. Radii must not change.
  void update(const SphereView& spheres, std::span<const Index> moved) { doUpdate(spheres, moved); }

  /// Every pair with gap <= skin, each exactly once, i < j, in backend order (sortPairs() gives the
  /// canonical order). Clears `out` first; reuses its capacity.
  virtual void findPairs(const SphereView& spheres, std::vector<Pair>& out) const = 0;

  /// The pairs of findPairs() in chunks: concatenated in order they are exactly findPairs()' output.
  /// Threaded backends (linked-cell, hgrid-td/bu, auto) fill one chunk per piece of work in parallel;
  /// the default is one chunk filled by findPairs(). Reuses the chunks' capacity.
  virtual void findPairChunks(const SphereView& spheres, PairChunks& out) const;

  /// Every j != i with gap(i, j) <= reach (0 <= reach <= skin), ascending. Clears `out` first.
  virtual void findNeighbours(const SphereView& spheres, Index i, double reach, std::vector<Index>& out) const = 0;

  /// Heap bytes held by the index structure (not the caller's particle arrays or pair buffer).
  virtual std::size_t memoryBytes() const { return 0; }

  /// Human-readable configuration, e.g. "linked-cell 12x12x12 cells of 0.25".
  virtual std::string describe() const { return std::string(name()); }

  /// OpenMP threads for build() and findPairs()/findPairChunks() (>= 1, ConfigError otherwise; a build
  /// without POLYDEM_WITH_OPENMP runs serially). The pairs, their order and the index are identical for
  /// every thread count. Counting (setCounting) runs serially. Takes effect at the next call.
  void setThreads(int threads);
  int threads() const { return threads_; }

  /// Count pair tests and cell accesses in findPairs (slower; for cost-model checks).
  void setCounting(bool on) { counting_ = on; }
  const Counters& counters() const { return counters_; }
  void resetCounters() const { counters_ = {}; }

  const Box& box() const { return box_; }
  double skin() const { return skin_; }

 protected:
  virtual void doBuild(const SphereView& spheres) = 0;
  virtual void doUpdate(const SphereView& spheres, std::span<const Index> /*moved*/) { doBuild(spheres); }

  Box box_;
  double skin_ = 0.0;
  double maxRadius_ = 0.0;
  double minRadius_ = 0.0;
  bool counting_ = false;
  int threads_ = 1;
  mutable Counters counters_;
};

/// Sort pairs into (i, j) order. O(P log P).
void sortPairs(std::vector<Pair>& pairs);

/// Check a sphere set and box for build(): throws ConfigError naming the first bad particle.
/// Returns {min radius, max radius} (0, 0 for an empty set). With threads > 1 the scan runs in parallel
/// (the same result and the same error).
std::pair<double, double> validateSpheres(const SphereView& spheres, const Box& box, double skin, int threads = 1);

}  // namespace polydem::broadphase
