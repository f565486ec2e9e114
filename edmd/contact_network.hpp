#pragma once
// Contact network of a (nearly) jammed hard-sphere packing: contacts from gaps, rattlers, isostaticity.
//
// Contacts are pairs with gap h_ij = |r_ij| - (r_i + r_j) <= tau (r_i + r_j) (seed 001 :6540-6542,
// :11488-11493: the mean contact number is insensitive to tau across the plateau 1e-9..1e-5 once p is
// high, since contact gaps scale as D/p). Rattlers are removed iteratively: a particle with fewer than
// d + 1 = 4 contacts among non-rattlers cannot be locally jammed (:4116-4119) and is dropped, which can
// expose further rattlers (digest §3.8 [rec]). Isostatic backbone in a periodic box (collective
// jamming, fixed lattice): M = N_f + 1 = 3 N' - 2 contacts among N' non-rattlers (eq. 4.8, :4482-4502).
#include <cstdint>
#include <string>
#include <vector>

#include "broadphase/broad_phase.hpp"
#include "core/box.hpp"
#include "core/particle_store.hpp"

namespace polydem::edmd {

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
  /// (3N' - 2 in a periodic box, 3N' + 1 between walls; eq. 4.8, :4476-4502).
  std::int64_t isostaticExcess() const {
    return backboneContacts - (3 * static_cast<std::int64_t>(backbone) - periodicAxes + 1);
  }
};

/// Contacts and rattlers of the spheres (centres inside the box). O(N) with a grid broad phase.
/// Throws ConfigError for a negative gap tolerance.
ContactNetwork analyseContacts(const SphereView& spheres, const Box& box, const ContactOptions& options = {});

/// Cumulative coordination Z(tau) = 2 #{pairs with gap <= tau (r_i + r_j)} / N for each tau (ascending),
/// all particles counted (seed 001 :11245-11262; the plateau at 6 over many decades marks true contacts).
std::vector<double> cumulativeCoordination(const SphereView& spheres, const Box& box, const std::vector<double>& taus,
                                           const std::string& broadPhase = "hgrid-td");

/// Pair correlation of the centre distance scaled by the pair's contact distance, x = |r_ij| / (r_i + r_j),
/// on [0, xMax) in `bins` bins, normalised by the ideal-gas count sum_{i != j} (r_i + r_j)^3 (4 pi / 3V)
/// (x_hi^3 - x_lo^3): 1 at large x, a delta-like peak at x = 1 for a jammed packing; works for any size
/// distribution (digest §4.10). Periodic boxes; O(N x neighbours within xMax).
struct PairCorrelation {
  std::vector<double> x;  ///< bin centres
  std::vector<double> g;
};
PairCorrelation pairCorrelation(const SphereView& spheres, const Box& box, double xMax, int bins,
                                const std::string& broadPhase = "hgrid-td");

/// Default relative gap for a packing at reduced pressure p. Contact gaps scale as delta = 1/p, and the
/// contact number is flat for 100 delta < tau < 1e-5 (seed :11488-11493); take the geometric middle of
/// that plateau, sqrt(100/p x 1e-5) = sqrt(1e-3/p) (3e-8 at p = 1e12, where the near-contact background
/// Z_b ~ 11 (l/D)^0.6 of seed :11402-11404 adds 3e-4 per particle), and 100/p when there is no plateau;
/// at most 1e-3.
double defaultContactGap(double pressure);

}  // namespace polydem::edmd
