#pragma once
// K, the cost of one cell access in units of one pair test, measured on this machine: the one K the
// library's HGrid configurator (CachedGridOptimiser, hgrid_optimiser.hpp) and `auto` (auto_select.hpp) use.
//
// The HGrid cost model (hgrid_cost_evaluation.hpp, thesis eq. 2.35) weighs cell look-ups against pair
// tests with K = t_cell / t_pair. The thesis measured 0.2-0.45 for its ch. 2.1 grid (§2.1.3, from the
// experiments of §2.1.4) and uses 0.2 for spheres in ch. 2.2 (§2.2.3); kDefaultCellOverPairCost = 0.2 is
// that uncalibrated value. The micro-benchmark times the two kernels the HGrid actually runs:
//   t_pair  one spheresWithinReach() on packed x, y, z, r data in a periodic box (minimum image), data in
//           cache, as in the inner loop over a cell's slot range;
//   t_cell  one cell look-up that returns an empty or one-sphere slot range: cell coordinates of a
//           search-box cell -> index -> a dense cell-start array. Dense and ranked storage serve most
//           levels (hgrid_storage.hpp), so this is the representative look-up.
// The open-addressing hash look-up of the sparsest levels is timed alongside (hashedCellAccessSeconds, 3-5x
// slower) for comparison only: K does not use it.
//
// References (thesis numbering): V. Ogarko, PhD thesis (University of Twente), ch. 2; ch. 2.1 = Ogarko &
// Luding, Comput. Phys. Commun. 183 (2012) 931, ch. 2.2 = Krijgsman, Ogarko & Luding, Comp. Part. Mech. 1
// (2014) 357.
#include "broadphase/hgrid_cost_evaluation.hpp"

namespace polydem::broadphase {

struct KCalibration {
  double K = kDefaultCellOverPairCost;   ///< t_cell / t_pair, t_cell through a dense cell-start array
  double pairTestSeconds = 0.0;          ///< t_pair (s)
  double cellAccessSeconds = 0.0;        ///< t_cell, dense cell-start array (s)
  double hashedCellAccessSeconds = 0.0;  ///< a look-up through the hash table, for comparison (s; not in K)
  bool calibrated = false;               ///< false: the default K, nothing measured
};

/// The thesis's K = 0.2, not measured.
KCalibration defaultKCalibration();

/// Run the micro-benchmark now: about 0.1 s (each kernel timed several times, the fastest run kept).
KCalibration measureK();

/// measureK() once per process (thread-safe), then the cached result.
const KCalibration& calibratedK();

/// calibratedK().K: the K for the cost model on this machine.
double modelCostRatio();

}  // namespace polydem::broadphase
