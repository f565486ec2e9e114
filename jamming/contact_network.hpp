#pragma once
// Contact network of a (nearly) jammed hard-sphere packing: contacts from gaps, rattlers, isostaticity.
//
// Contacts are pairs with gap h_ij = |r_ij| - (r_i + r_j) <= tau (r_i + r_j) (A. Donev, "Jammed Packings of
// Hard Particles", PhD thesis, Princeton University (2006), §5.1 and §9.3.1.4, Fig. 9.8: the mean contact
// number is insensitive to tau across the plateau 1e-9..1e-5 once p is high, since contact gaps scale as
// D/p). Rattlers are removed iteratively: a particle with fewer than d + 1 = 4 contacts among non-rattlers
// cannot be locally jammed (§4.2.2; the d + 1 rule of §11.3.2) and is dropped, which can expose further
// rattlers (our choice: repeated until stable). Isostatic backbone in a periodic box (collective jamming,
// fixed lattice): M = N_f + 1 = 3 N' - 2 contacts among N' non-rattlers (§4.3.1.1, eq. 4.8).
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "broadphase/broad_phase.hpp"
#include "core/box.hpp"
#include "core/particle_store.hpp"

namespace polydem::jamming {

struct ContactOptions {
  double relativeGap = 1e-8;  ///< tau: contact when gap <= tau (r_i + r_j)
  int minContacts = 4;        ///< rattler: fewer contacts than this among non-rattlers (d + 1)
  std::string broadPhase = "hgrid-td";
};

/// A sphere touching a hard wall: wall = 2 axis + (upper ? 1 : 0).
struct WallContact {
  Index i;
  int wall;
};

struct ContactNetwork {
  std::vector<broadphase::Pair> contacts;  ///< sorted, i < j
  std::vector<WallContact> wallContacts;   ///< gap to a hard wall <= tau 2 r_i (walled axes only)
  std::vector<int> coordination;           ///< contacts per particle (pairs and walls)
  std::vector<char> rattler;               ///< 1 = rattler
  Index particles = 0;
  Index backbone = 0;                 ///< non-rattlers N'
  std::int64_t backboneContacts = 0;  ///< contacts between non-rattlers, and with walls, M'
  int periodicAxes = 3;
  double maxOverlap = 0.0;  ///< largest relative overlap (s - |r|) / s found
  double minGap = 0.0;      ///< smallest relative gap (negative = overlap)

  /// 2 M / N over all particles (a wall contact counts once, for its sphere).
  double meanCoordination() const;
  /// 2 M' / N' over the backbone (NaN if empty).
  double backboneCoordination() const;
  double rattlerFraction() const;
  /// M' - (N_f + 1), N_f = 3 N' - (periodic axes): 0 for an isostatic, collectively jammed backbone
  /// (3N' - 2 in a periodic box, 3N' + 1 between walls; Donev 2006, §4.3.1.1, eq. 4.8).
  std::int64_t isostaticExcess() const {
    return backboneContacts - (3 * static_cast<std::int64_t>(backbone) - periodicAxes + 1);
  }
};

/// Contacts and rattlers of the spheres (centres inside the box). O(N) with a grid broad phase.
/// Throws ConfigError for a negative gap tolerance.
ContactNetwork analyseContacts(const SphereView& spheres, const Box& box, const ContactOptions& options = {});

/// Cumulative coordination Z(tau) = 2 #{pairs with gap <= tau (r_i + r_j)} / N for each tau (ascending),
/// all particles counted (Donev 2006, §9.3.1, Fig. 9.4; the plateau at 6 over many decades marks true contacts).
std::vector<double> cumulativeCoordination(const SphereView& spheres, const Box& box, const std::vector<double>& taus,
                                           const std::string& broadPhase = "hgrid-td");

/// Pair correlation of the centre distance scaled by the pair's contact distance, x = |r_ij| / (r_i + r_j),
/// on [0, xMax) in `bins` bins, normalised by the ideal-gas count sum_{i != j} (r_i + r_j)^3 (4 pi / 3V)
/// (x_hi^3 - x_lo^3): 1 at large x, a delta-like peak at x = 1 for a jammed packing; works for any size
/// distribution (Donev 2006, §9.3.1, defines g2 and Z(l) for equal spheres). Periodic boxes; O(N x neighbours
/// within xMax).
struct PairCorrelation {
  std::vector<double> x;  ///< bin centres
  std::vector<double> g;
};
PairCorrelation pairCorrelation(const SphereView& spheres, const Box& box, double xMax, int bins,
                                const std::string& broadPhase = "hgrid-td");

/// Default relative gap for a packing at reduced pressure p. Contact gaps scale as delta = 1/p, and the
/// contact number is flat for 100 delta < tau < 1e-5 (Donev 2006, §9.3.1.4); take the geometric middle of
/// that plateau, sqrt(100/p x 1e-5) = sqrt(1e-3/p) (3e-8 at p = 1e12, where the near-contact background
/// Z_b ~ 11 (l/D)^0.6 of Donev 2006, §9.3.1.2, Fig. 9.6, adds 3e-4 per particle), and 100/p when there is no plateau;
/// at most 1e-3.
double defaultContactGap(double pressure);

/// The pair of spheres with the smallest relative gap (|r_ij| - s) / s, s = r_i + r_j, minimum image.
struct PairGap {
  Index i = -1, j = -1;
  double gap = 0.0;  ///< relative; negative = overlap
};

/// The true smallest relative gap over all pairs (not limited by a contact cutoff), or nullopt for fewer
/// than two spheres. Brute force up to a few thousand spheres, else a broad-phase search whose skin grows
/// until the closest pair is certain: O(N) for packings and gases alike.
std::optional<PairGap> smallestGap(const SphereView& spheres, const Box& box,
                                   const std::string& broadPhase = "hgrid-td");

// Validity of a hard-sphere packing, checked before any contact statistics or jamming verdict: a
// configuration with real overlaps or a density no packing can have is not a hard-sphere packing, and
// every verdict on it (the LP tests treat near-contacts as exact contacts) would be meaningless.
//
// Overlaps: h_ij = r_i + r_j - |r_ij| measured against the smaller radius of the pair, h_ij / min(r_i, r_j),
// so that a small sphere sunk into a large one counts as much as two equal spheres overlapping; a sphere
// crossing a hard wall by h counts h / r_i; a sphere larger than half a periodic length overlaps its own
// image. Refused beyond the tolerance (the contact tolerance: round-off of a packing jammed to gaps
// below it stays far inside).
//
// Density bound: phi = sum (4/3) pi r_i^3 / V must not exceed
//   phi_max = min(1, pi / sqrt(18) <r^3> / r_min^3)   (x (1 + 1e-9) for round-off in the sums).
// Disjoint bodies never fill more than the box (1). Shrinking every sphere about its centre to r_min keeps
// a packing a packing, now of equal spheres; repeated periodically (and mirrored at hard walls, which
// tiles space with copies of the box) it is a packing of R^3, whose density is at most the FCC density
// pi / sqrt(18) (Kepler's conjecture, Hales, Ann. Math. 162 (2005) 1065). So phi r_min^3 / <r^3> <=
// pi / sqrt(18). For equal spheres this is the FCC density itself; it is the better bound for narrow
// distributions and exceeds 1 once <r^3> > 1.35 r_min^3. It is a rigorous upper bound, not the (generally
// unknown) densest packing of the mixture, so it refuses only states no hard-sphere packing can reach.
// Overlaps within the tolerance could in principle add a factor (1 - tau)^-3; that slack is not
// granted: a packing denser than the bound has overlaps that add up to an impossible state.
struct PackingCheckOptions {
  double overlapTolerance = 1e-8;  ///< largest h / min(r_i, r_j) accepted (the contact tolerance tau)
  std::string broadPhase = "hgrid-td";
};

struct PackingValidity {
  Index spheres = 0;
  double packingFraction = 0.0;
  double densityBound = 1.0;  ///< phi_max above (without the round-off allowance)
  bool equalSpheres = false;  ///< r_max = r_min to round-off: the bound is the FCC density
  /// Largest overlap relative to the smaller radius (<= 0 when nothing overlaps; then worstI = -1).
  double worstOverlap = 0.0;
  Index worstI = -1, worstJ = -1;  ///< worstJ == worstI: its own periodic image; worstJ = -1: a wall
  int worstWall = -1;              ///< 2 axis + (upper ? 1 : 0) when worstJ = -1
  Index overlaps = 0;              ///< pairs and wall contacts overlapping beyond the tolerance
  double tolerance = 0.0;

  bool overlapTooLarge() const { return overlaps > 0; }
  bool densityTooHigh() const { return packingFraction > densityBound * (1.0 + 1e-9); }
  bool valid() const { return !overlapTooLarge() && !densityTooHigh(); }
};

/// Overlaps and density of the spheres (centres inside the box) as described above. O(N) with the broad
/// phase; brute force O(N^2) when a periodic length is too short for it.
PackingValidity checkHardSpherePacking(const SphereView& spheres, const Box& box, const PackingCheckOptions& options);

/// One-line description of the problems of an invalid packing, naming the worst pair by `ids` (indices
/// if empty) and its overlap, and the density against its bound; empty if valid.
std::string describeInvalidPacking(const PackingValidity& validity, std::span<const Index> ids = {});

/// checkHardSpherePacking(), then throw InputError "WHAT: not a valid hard-sphere packing: ..." unless valid.
PackingValidity requireHardSpherePacking(const SphereView& spheres, const Box& box, const PackingCheckOptions& options,
                                         const std::string& what, std::span<const Index> ids = {});

}  // namespace polydem::jamming
