#pragma once
// Cell-size rules for the HGrid (thesis §2.2.5): each returns L non-decreasing sizes s_1..s_L with
// s_L = maxDiameter() (some may coincide: collapsed levels are empty and cost nothing). Linear (eq. 2.42),
// exponential (2.43-2.44), constant ratio q of particles per cell (2.45-2.47; q = 1 is the hypothesis of
// ch. 2.1, eq. 2.6), and the appendix procedure of ch. 2.1 on a sample. The "optimal" rule, a direct
// minimisation of eq. 2.35, is in hgrid_optimiser.hpp. Sizes are interaction diameters: s_0 = 2 r_min +
// skin and s_L = 2 r_max + skin.
//
// References (thesis numbering): V. Ogarko, PhD thesis on polydisperse smooth hard spheres (University of
// Twente), ch. 2; its ch. 2.1 is Ogarko & Luding, Comput. Phys. Commun. 183 (2012) 931 and its ch. 2.2 is
// Krijgsman, Ogarko & Luding, Comp. Part. Mech. 1 (2014) 357.
#include <span>
#include <vector>

#include "broadphase/hgrid_cost_psd.hpp"

namespace polydem::broadphase {

/// Linear rule, eq. 2.42: s_h = s_0 + h (s_L - s_0) / L.
std::vector<double> linearCellSizes(const CostModelPsd& psd, int levels);
/// Exponential rule, eqs. 2.43-2.44: s_h = s_0 (s_L / s_0)^(h / L).
std::vector<double> exponentialCellSizes(const CostModelPsd& psd, int levels);
/// Constant ratio q of particles per cell, m_{h+1} = q m_h (eqs. 2.45-2.47): bisection on m_1, each
/// trial sweeping the levels upward and solving m_h(s_h) = q^(h-1) m_1 for s_h; the smallest admissible
/// m_1 is kept (the top level holds at most its share). q = 1 is the thesis's ch. 2.1 hypothesis (eq. 2.6).
/// A PSD that cannot fill L levels (e.g. monodisperse) gets trailing sizes equal to s_L (empty levels).
std::vector<double> constantRatioCellSizes(const CostModelPsd& psd, int levels, double q = 1.0);

/// Result of the appendix procedure of thesis ch. 2.1 ("Calculation of m(L, PSD)") for one number of levels.
struct AppendixLevels {
  int levels = 0;                 ///< L
  double perCell = 0.0;           ///< m(L, PSD): the smallest m with L(m) = L
  double cost = 0.0;              ///< L (m + K), eq. 2.7 up to the factor N
  std::vector<double> cellSizes;  ///< s_h = 2 (largest radius on level h) + skin
};
struct AppendixResult {
  std::vector<AppendixLevels> table;  ///< every attainable L in 1..maxLevels, ascending
  int optimalLevels = 1;              ///< ONL = argmin L (m(L) + K) (thesis §2.1.3, eq. 2.7)
  const AppendixLevels& optimal() const;
};
/// Number of levels L(m) of the appendix procedure for particles-per-cell limit m, on a sample sorted
/// ascending, with N^c = V_box / (2 r_i + skin)^3 (the thesis's [S / (2 r_i)]^d taken as a real number,
/// thesis ch. 2.1 appendix). O(L log N).
int appendixLevelCount(std::span<const double> sortedRadii, double boxVolume, double skin, double m);
/// m(L) for L = 1..maxLevels by bisection on m (L(m) is non-increasing), and the ONL for this K.
/// The thesis found K in [0.2, 0.45] for its ch. 2.1 grid (§2.1.3, from §2.1.4); 0.3 by default. O(maxLevels * 60 * L
/// log N).
AppendixResult appendixProcedure(std::span<const double> radii, double boxVolume, double skin, double K = 0.3,
                                 int maxLevels = 30);

}  // namespace polydem::broadphase
