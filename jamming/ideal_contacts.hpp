#pragma once
// Linear-programming test of collective (first-order) jamming of a packing whose contacts are exact.
//
// A. Donev, "Jammed Packings of Hard Particles", PhD thesis, Princeton University (2006), ch. 4-5: a
// packing is jammed iff no non-trivial velocities V satisfy (v_i - v_j) . u_ij >= 0 for every contact
// (§4.2.3, eq. 4.1), and for spheres first-order jamming is the same as jamming (§5.5.2.2). By Stiemke's
// lemma the motions split into two linear programs on the backbone (rattlers removed, one sphere pinned
// against the trivial translations, periodic box with the lattice fixed = collective jamming):
//   1. opening:  max sum_c s_c  over dR,  s_c = u_c . (dR_i - dR_j) in [0, 1]
//      > 0 <=> a motion opens some contact <=> no strict self-stress (A f = 0, f > 0) exists;
//   2. floppy:   max w . dR     over dR in [-1, 1]^3N', u_c . (dR_i - dR_j) = 0 for every contact, random w
//      > 0 <=> a motion keeps every contact <=> A is rank deficient beyond the translations.
// Jammed iff both optima vanish. Contacts are treated as exact (gaps h = 0): the non-randomised test
// for ideal packings (Donev 2006, §4.3.2.1, eq. 4.11), appropriate at p >= 1e10 where gaps are ~1e-10 D
// and below what the LP could resolve anyway (§9.3.1). Strict jamming (box deformation) is not tested.
#include <Eigen/Core>
#include <cstdint>
#include <string>

#include "core/box.hpp"
#include "jamming/contact_network.hpp"
#include "jamming/lp_solver.hpp"
#include "jamming/verdict.hpp"

namespace polydem::jamming {

struct JammingTestResult {
  JammingVerdict outcome = JammingVerdict::NotTested;
  bool jammed = false;          ///< outcome == Jammed
  std::string verdict;          ///< "jammed", "unjammed: opens contacts", "unjammed: floppy modes", ...
  double openingObjective = 0;  ///< optimum of LP 1 (sum of opened contact rates)
  double floppyObjective = 0;   ///< optimum of LP 2
  Index contactsOpened = 0;     ///< contacts with s_c > tolerance in the LP-1 motion
  Eigen::Matrix3Xd motion;      ///< unjamming motion (3 x N, zero for rattlers) if not jammed
  double seconds = 0.0;
  int lps = 0;  ///< LPs solved (0: decided by counting or the certificate; the optima above are then 0)
};

/// Run the test on the backbone of `network` (spheres as analysed). `tolerance` is the relative size of
/// an optimum that counts as non-zero. Backbones larger than `simplexLimit` spheres skip the LPs: a
/// hypostatic one is unjammed by counting; otherwise the LP-free augmented-system certificate decides
/// (full-rank rigidity matrix and a strictly positive self-stress; sparse Cholesky, seconds at N = 10,000).
/// Throws ConfigError if GLPK is missing. No spheres: NotTested; every sphere a rattler: Unjammed.
JammingTestResult testCollectiveJamming(const SphereView& spheres, const Box& box, const ContactNetwork& network,
                                        double tolerance = 1e-9, std::uint64_t seed = 1,
                                        int simplexLimit = kSimplexLimit);

}  // namespace polydem::jamming
