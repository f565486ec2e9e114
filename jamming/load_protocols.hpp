#pragma once
// Linear-programming test of collective (first-order) jamming of a sphere packing, with GLPK.
//
// Seed 001 ch. 4-5 (shared/seeds/001_3d36564c50aaa2ef.txt; digest §3.1-3.4): a packing is jammed iff no
// non-trivial velocities V satisfy (v_i - v_j) . u_ij >= 0 for every contact (eq. 4.1, :4174-4190), and
// for spheres first-order jamming is the same as jamming (:7291-7311). By Stiemke's lemma the motions
// split into two linear programs on the backbone (rattlers removed, one sphere pinned against the
// trivial translations, periodic box with the lattice fixed = collective jamming):
//   1. opening:  max sum_c s_c  over dR,  s_c = u_c . (dR_i - dR_j) in [0, 1]
//      > 0 <=> a motion opens some contact <=> no strict self-stress (A f = 0, f > 0) exists;
//   2. floppy:   max w . dR     over dR in [-1, 1]^3N', u_c . (dR_i - dR_j) = 0 for every contact, random w
//      > 0 <=> a motion keeps every contact <=> A is rank deficient beyond the translations.
// Jammed iff both optima vanish. Contacts are treated as exact (gaps h = 0): the non-randomised test
// for ideal packings, eq. 4.11 (:4573-4597), appropriate at p >= 1e10 where gaps are ~1e-10 D and below
// what the LP could resolve anyway (:11163-11166). Strict jamming (box deformation) is not tested.
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/box.hpp"
#include "jamming/contact_network.hpp"

namespace polydem::jamming {

struct JammingTestResult {
  JammingVerdict outcome = JammingVerdict::NotTested;
  bool jammed = false;  ///< outcome == Jammed
  std::string verdict;          ///< "jammed", "unjammed: opens contacts", "unjammed: floppy modes", ...
  double openingObjective = 0;  ///< optimum of LP 1 (sum of opened contact rates)
  double floppyObjective = 0;   ///< optimum of LP 2
  Index contactsOpened = 0;     ///< contacts with s_c > tolerance in the LP-1 motion
  Eigen::Matrix3Xd motion;      ///< unjamming motion (3 x N, zero for rattlers) if not jammed
  double seconds = 0.0;
  int lps = 0;  ///< LPs solved (0: decided by counting or the certificate; the optima above are then 0)
};

/// The randomised load test of seed 001 (eq. 4.10, :4522-4569; Algorithm 13 without its rattler LP):
/// every pair with gap h <= gapTolerance (r_i + r_j) is a linearised constraint
/// u_ij . (dR_i - dR_j) >= -h_ij (feasible for the true constraints too, :4319-4388); a random load B with
/// zero net force is applied to the backbone (rattlers are unloaded but keep their constraints, :5713-5725),
/// max B . dR over |dR_k| <= maxDisplacement, then -B. The packing is jammed if
/// no sphere moves by more than `displacementLimit` under `loads` loads and their opposites. Lengths in
/// units of the mean diameter.
enum class LpSolver {
  Automatic,      ///< GLPK's simplex up to kSimplexLimit movable spheres (if built with GLPK), else interior point
  Simplex,        ///< GLPK's simplex (exact vertex; minutes at N = 1000, does not finish at N = 10,000)
  InteriorPoint,  ///< edmd/interior_point.hpp on the force form (about a minute per load at N = 10,000)
};
inline constexpr int kSimplexLimit = 2000;

struct LoadTestOptions {
  double gapTolerance = 0.05;
  double displacementLimit = 1e-3;
  double maxDisplacement = 10.0;
  int loads = 2;  ///< >= 1 (ConfigError otherwise: a test without loads proves nothing)
  std::uint64_t seed = 1;
  std::vector<Index> removed;  ///< spheres taken out of the packing for the test (no variables, no constraints)
  LpSolver solver = LpSolver::Automatic;
  /// > 1: rounds of the seed's Algorithm 13 that set displaced spheres aside and load the rest again,
  /// until a round displaces nobody (a jammed subpacking). 1 = test the packing as a whole only.
  int subpackingRounds = 1;
  /// true: the seed's Algorithm 14 (sequential random loading) for packings with gaps: each load's LP
  /// motion is scaled to the first true collision, applied, and the LP solved again from there while a
  /// step moves some loaded sphere by more than beta D_i (D_i its own diameter), up to maxSteps LPs per
  /// load. Jammed if, over all loads, no loaded sphere moved more than maxLimit D_i in all and the mean is
  /// at most meanLimit D_i. subpackingRounds is not used. false: a single LP per load (the ideal test).
  bool sequential = false;
  /// Before the loads, unload spheres that a random load moves by more than displacementLimit with their
  /// neighbours held fixed (the seed's rattler LP, eq. 4.15): degenerate cages the contact count misses.
  bool localRattlers = true;
  /// Strict jamming (single-LP test, fully periodic box): the cell may deform with a symmetric strain
  /// that does not grow its volume (seed eq. 4.17-4.21); unjammed also if the boundary moves further than
  /// displacementLimit.
  bool strict = false;
  double beta = 0.01;        ///< seed :5753 (beta ~ 0.01-0.1): a step below this is not significant
  double maxLimit = 0.05;    ///< = the default gap tolerance: beyond it the constraint set is incomplete
  double meanLimit = 1e-3;
  int maxSteps = 10;
  /// Called after each LP with a one-line summary (round, load, sign, largest displacement, seconds);
  /// large packings take minutes per LP.
  std::function<void(const std::string&)> progress;
};
struct LoadTestResult {
  /// NotTested when no LP was solved (no spheres); Unjammed also for "no backbone" (every sphere rattles).
  JammingVerdict outcome = JammingVerdict::NotTested;
  bool jammed = false;  ///< outcome == Jammed
  std::string verdict;
  double largestDisplacement = 0.0;  ///< in mean diameters, over all loads
  Index displaced = 0;               ///< spheres moved beyond the limit by the worst load
  Index constraints = 0;
  Eigen::Matrix3Xd motion;  ///< the worst load's displacement (3 x N, length units)
  double seconds = 0.0;
  std::string solver;        ///< which LP solver ran, with its iteration counts
  int rounds = 0;            ///< rounds run (see LoadTestOptions::subpackingRounds)
  Index loose = 0;           ///< backbone spheres set aside as displaced, over all rounds
  std::vector<Index> setAsidePerRound;  ///< spheres displaced in each round (the last is 0 if it found a jammed subpacking)
  Index subpacking = 0;      ///< loaded spheres of the last round, if it displaced nobody
  bool subpackingJammed = false;  ///< a round displaced nobody (jammed == true implies it, with loose = 0)
  // Sequential loading (LoadTestOptions::sequential); largestDisplacement is then in own diameters D_i.
  double meanDisplacement = 0.0;  ///< mean accumulated displacement of the loaded spheres, D_i
  int steps = 0;                  ///< LPs solved
  std::vector<double> objectives;  ///< single-LP test: optimal B . dR of each LP, in order
  Eigen::Matrix3d strain = Eigen::Matrix3d::Zero();  ///< strict: the largest cell strain found
  double strainDisplacement = 0.0;  ///< strict: |strain| L_max in mean diameters
  Index localRattlers = 0;        ///< loaded spheres unloaded by the local LP (LoadTestOptions::localRattlers)
  double linearLargest = 0.0;     ///< largest first-step LP motion of a loaded sphere, mean diameters
  Index linearDisplaced = 0;      ///< loaded spheres beyond displacementLimit in that LP
};
LoadTestResult testJammingUnderLoad(const SphereView& spheres, const Box& box, const ContactNetwork& network,
                                    const LoadTestOptions& options = {});

/// True if this build has GLPK (the ideal-contact test and the simplex load test; the interior-point
/// load test is always built).
bool jammingTestAvailable();

/// Run the test on the backbone of `network` (spheres as analysed). `tolerance` is the relative size of
/// an optimum that counts as non-zero. Backbones larger than `simplexLimit` spheres skip the LPs: a
/// hypostatic one is unjammed by counting; otherwise the LP-free augmented-system certificate decides
/// (full-rank rigidity matrix and a strictly positive self-stress; sparse Cholesky, seconds at N = 10,000).
/// Throws ConfigError if GLPK is missing. No spheres: NotTested; every sphere a rattler: Unjammed.
JammingTestResult testCollectiveJamming(const SphereView& spheres, const Box& box, const ContactNetwork& network,
                                        double tolerance = 1e-9, std::uint64_t seed = 1,
                                        int simplexLimit = kSimplexLimit);

}  // namespace polydem::jamming
