#pragma once
// K, the cost of one cell access in units of one pair test, measured on this machine.
//
// The HGrid cost model (hgrid_cost_model.hpp, seed 000 eq. 2.35 at shared/seeds/000_3b5cd2443ded9063.txt:2589)
// weighs cell look-ups against pair tests with K = t_cell / t_pair (digest §2.3; the seed measured
// 0.2-0.45 in ch. 2.1, :1192-1196, and uses 0.2 for spheres in ch. 2.2, :2567-2573). The micro-benchmark
// times the two kernels the HGrid actually runs:
//   t_pair  one spheresWithinReach() on packed x, y, z, r data in a periodic box (minimum image), data in
//           cache, as in the inner loop over a cell's slot range;
//   t_cell  one cell look-up that returns an empty or one-sphere slot range: cell coordinates of a
//           search-box cell -> 64-bit key -> open-addressing hash probe verifying the full key (the
//           HGrid's sparse levels), and the same through a dense cell-start array (its dense levels).
// K uses the hashed look-up, the common case on the fine levels where most work happens.
#include "broadphase/hgrid_cost_model.hpp"

namespace polydem::broadphase {

struct KCalibration {
  double K = kDefaultCellOverPairCost;  ///< t_cell / t_pair (hashed look-up)
  double pairTestSeconds = 0.0;         ///< t_pair (s)
  double cellAccessSeconds = 0.0;       ///< t_cell, hashed (s)
  double denseCellAccessSeconds = 0.0;  ///< t_cell through a dense cell-start array (s)
  bool calibrated = false;              ///< false: the default K, nothing measured
};

/// The seed's K = 0.2, not measured.
KCalibration defaultKCalibration();

/// Run the micro-benchmark now: about 0.1 s (each kernel timed several times, the fastest run kept).
KCalibration measureK();

/// measureK() once per process (thread-safe), then the cached result.
const KCalibration& calibratedK();

}  // namespace polydem::broadphase
