#pragma once
// Random-load tests of jamming for packings with gaps (A. Donev, "Jammed Packings of Hard Particles",
// PhD thesis, Princeton University (2006), §4.3.2 and §4.6).
//
// Every pair with gap h <= gapTolerance (r_i + r_j) is a linearised constraint u_ij . (dR_i - dR_j) >= -h_ij
// (eq. 4.10; feasible for the true constraints too, §4.3.1); a random load B with zero net force is applied
// to the backbone (rattlers are unloaded but keep their constraints, §4.6.2.2), max B . dR over
// |dR_k| <= maxDisplacement, then -B. Two protocols (LoadProtocol):
//  - SingleLp (ideal packings, §4.6.1, Algorithm 13): one LP per load; jammed if no loaded sphere moves by
//    more than `displacementLimit` under `loads` loads and their opposites. Lengths in mean diameters.
//  - Sequential (sequential random loading, §4.6.2, Algorithm 14): each load's LP motion is scaled to the
//    first true collision, applied, and the LP solved again from there while a step moves some loaded
//    sphere by more than beta D_i (D_i its own diameter), up to maxSteps LPs per load. Jammed if, over all
//    loads, no loaded sphere moved more than maxLimit D_i in all and the mean is at most meanLimit D_i.
// Either can search for a jammed subpacking (subpackingRounds > 1, Algorithm 13; jammed subpackings §4.2.4.1).
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>
#include <variant>
#include <vector>

#include "core/box.hpp"
#include "jamming/contact_network.hpp"
#include "jamming/ideal_contacts.hpp"
#include "jamming/lp_solver.hpp"
#include "jamming/verdict.hpp"

namespace polydem::jamming {

enum class LoadProtocol {
  SingleLp,    ///< one LP per load (Donev 2006, Algorithm 13): the ideal test
  Sequential,  ///< sequential random loading (Donev 2006, Algorithm 14) for packings with gaps
};

struct LoadTestOptions {
  LoadProtocol protocol = LoadProtocol::SingleLp;  ///< read by testJammingUnderLoad only
  double gapTolerance = 0.05;
  double displacementLimit = 1e-3;
  double maxDisplacement = 10.0;
  int loads = 2;  ///< >= 1 (ConfigError otherwise: a test without loads proves nothing)
  std::uint64_t seed = 1;
  std::vector<Index> removed;  ///< spheres taken out of the packing for the test (no variables, no constraints)
  LpSolver solver = LpSolver::Automatic;
  /// > 1: rounds of Algorithm 13 that set displaced spheres aside (SingleLp: unload them; Sequential:
  /// remove them and start again from the packing) and load the rest again, until a round displaces
  /// nobody (a jammed subpacking). 1 = test the packing as a whole only.
  int subpackingRounds = 1;
  /// Before the loads, unload spheres that a random load moves by more than displacementLimit with their
  /// neighbours held fixed (the rattler LP, Donev 2006 eq. 4.15): degenerate cages the contact count misses.
  bool localRattlers = true;
  /// SingleLp, fully periodic box: strict jamming, the cell may deform with a symmetric strain that does
  /// not grow its volume (Donev 2006, eq. 4.17-4.21); unjammed also if the boundary moves further than
  /// displacementLimit.
  bool strict = false;
  // Sequential (checked by both protocols):
  double beta = 0.01;      ///< Donev 2006 §4.6.2.4 (beta ~ 0.01-0.1): a step below this is not significant
  double maxLimit = 0.05;  ///< = the default gap tolerance: beyond it the constraint set is incomplete
  double meanLimit = 1e-3;
  int maxSteps = 10;
  /// Called after each LP with a one-line summary (round, load, sign, largest displacement, seconds);
  /// large packings take minutes per LP.
  std::function<void(const std::string&)> progress;
};

/// What every load protocol reports.
struct LoadTestSummary {
  /// NotTested when no LP was solved (no spheres); Unjammed also for "no backbone" (every sphere rattles).
  JammingVerdict outcome = JammingVerdict::NotTested;
  bool jammed = false;  ///< outcome == Jammed
  std::string verdict;
  /// SingleLp: over all loads, in mean diameters; Sequential: the largest accumulated one, own diameters D_i.
  double largestDisplacement = 0.0;
  Index displaced = 0;      ///< loaded spheres beyond the limit (SingleLp: of the worst load)
  Index constraints = 0;    ///< rows of the first load LP
  Eigen::Matrix3Xd motion;  ///< SingleLp: the worst load's displacement; Sequential: the accumulated one (3 x N)
  double seconds = 0.0;
  std::string solver;       ///< which LP solver ran, with its iteration counts (empty: no LP solved)
  Index localRattlers = 0;  ///< loaded spheres unloaded by the local LP (LoadTestOptions::localRattlers)
};

/// The subpacking search of LoadTestOptions::subpackingRounds (Donev 2006, Algorithm 13).
struct SubpackingSearch {
  int rounds = 0;                       ///< rounds run
  Index loose = 0;                      ///< backbone spheres set aside as displaced, over all rounds
  std::vector<Index> setAsidePerRound;  ///< the last is 0 if it found a jammed subpacking
  Index subpacking = 0;                 ///< loaded spheres of the last round, if it displaced nobody
  bool subpackingJammed = false;        ///< a round displaced nobody (jammed == true implies it, with loose = 0)
};

struct SingleLoadResult : LoadTestSummary {
  SubpackingSearch search;
  std::vector<double> objectives;                    ///< optimal B . dR of each LP, in order
  Eigen::Matrix3d strain = Eigen::Matrix3d::Zero();  ///< strict: the largest cell strain found
  double strainDisplacement = 0.0;                   ///< strict: |strain| L_max in mean diameters
};

struct SequentialLoadingResult : LoadTestSummary {
  SubpackingSearch search;        ///< rounds = 0 when subpackingRounds = 1
  double meanDisplacement = 0.0;  ///< largest mean accumulated displacement of the loaded spheres, D_i
  int steps = 0;                  ///< LPs solved
  double linearLargest = 0.0;     ///< largest first-step LP motion of a loaded sphere, mean diameters
  Index linearDisplaced = 0;      ///< loaded spheres beyond displacementLimit in that LP
};

/// One LP per load (Algorithm 13); options.protocol is not read. Throws ConfigError for bad options.
SingleLoadResult testSingleLoads(const SphereView& spheres, const Box& box, const ContactNetwork& network,
                                 const LoadTestOptions& options = {});

/// Sequential random loading (Algorithm 14); options.protocol is not read. Throws ConfigError for bad options.
SequentialLoadingResult testSequentialLoading(const SphereView& spheres, const Box& box, const ContactNetwork& network,
                                              const LoadTestOptions& options = {});

using LoadTestResult = std::variant<SingleLoadResult, SequentialLoadingResult>;

/// The protocol options.protocol names.
LoadTestResult testJammingUnderLoad(const SphereView& spheres, const Box& box, const ContactNetwork& network,
                                    const LoadTestOptions& options = {});

/// The part of a result every protocol has.
const LoadTestSummary& summaryOf(const LoadTestResult& result);

}  // namespace polydem::jamming
