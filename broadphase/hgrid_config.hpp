#pragma once
// Parameters of the hierarchical grid, shared by the HGrid backend and its cost-model optimiser.
// V. Ogarko, PhD thesis (University of Twente), §2.1-§2.2 = Ogarko & Luding, Comput. Phys. Commun. 183
// (2012) 931 and Krijgsman, Ogarko & Luding, Comp. Part. Mech. 1 (2014) 357.
#include <string>
#include <vector>

namespace polydem::broadphase {

/// Which levels a particle searches besides its own (thesis §2.2.2).
enum class CrossLevel {
  TopDown,  ///< a particle searches the finer levels j < h (pairs found from the larger member)
  BottomUp  ///< a particle searches the coarser levels j > h (pairs found from the smaller member)
};

struct HGridConfig {
  /// Nominal cell edges s_1 < ... < s_L (m). A particle of interaction diameter 2 r + skin goes to the
  /// first level with s_h >= 2 r + skin; the last edge must hold the largest particle.
  std::vector<double> cellSizes;
  CrossLevel mode = CrossLevel::TopDown;
  /// Where the configuration came from (e.g. "optimiser: predicted T/N = 11.6, runner-up ...").
  std::string origin;
};

}  // namespace polydem::broadphase
