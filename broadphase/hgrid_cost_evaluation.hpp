#pragma once
// Expected work T/N of the hierarchical grid (HGrid) per particle, in units of one pair test
// (thesis §2.2.3, eqs. 2.14-2.35). Centres uniformly random (excluded volume ignored), radii i.i.d. from
// f(r); d = 3, n_c = 13 half-neighbour cells:
//   T/N = sum_h P_h [ (1/2 + n_c) m_h + K (1 + n_c) + sum_{j in J(h)} (m_j + K) b(j, h) ]      (2.31-2.35)
// P_h = fraction of particles inserted at level h, m_h = particles per cell there (2.19), b(j, h) = mean
// number of level-j cells a level-h particle scans (2.24), J(h) = {1..h-1} top-down, {h+1..L} bottom-up.
// Empty levels are dropped before evaluating: the grid skips them.
//
// K, the cost ratio: the time of one cell access over the time of one pair test, so that T is in units
// of pair tests (eq. 2.35; the thesis's sentence introducing K, just before eq. 2.35, states the inverse
// ratio, but eq. 2.35 and the time unit of §2.2.6 need this reading). Its calibrated value on this
// machine is calibratedK().K (calibrate_k.hpp: a cell access is a look-up through a dense cell-start
// array); the functions below take K as an argument and default to kDefaultCellOverPairCost, the
// thesis's uncalibrated value for spheres.
//
// Skin: every radius here is the interaction radius r + skin / 2. A particle goes to the first level with
// 2 r + skin <= s_h (the HGrid insertion rule), and searches level j with half-width r + skin/2 + s_j/2,
// which is complete because every level-j particle has 2 r + skin <= s_j. b(j, h) is a cubic polynomial
// in r (binomial expansion of (2 r / s_j + 2)^3, or the per-axis product for snapped cells), so every
// per-level quantity needs only the partial moments of hgrid_cost_psd.hpp.
//
// References (thesis numbering): V. Ogarko, PhD thesis on polydisperse smooth hard spheres (University of
// Twente), ch. 2; its ch. 2.1 is Ogarko & Luding, Comput. Phys. Commun. 183 (2012) 931 and its ch. 2.2 is
// Krijgsman, Ogarko & Luding, Comp. Part. Mech. 1 (2014) 357.
#include <Eigen/Core>
#include <array>
#include <span>
#include <vector>

#include "broadphase/hgrid_config.hpp"
#include "broadphase/hgrid_cost_psd.hpp"

namespace polydem::broadphase {

/// n_c: cells of the forward half neighbourhood in 3-D, (3^3 - 1) / 2.
inline constexpr int kHalfNeighbourCells = 13;
/// K when none is given: the thesis's value for spheres (§2.2.3, with eq. 2.35), not measured. The HGrid
/// configurator of the registry and `auto` use the calibrated calibratedK().K instead.
inline constexpr double kDefaultCellOverPairCost = 0.2;

/// One level as the grid realises it. For the plain model all lengths equal s_h; a periodic box snaps
/// the cell edge up to L_k / floor(L_k / s_h) per axis while insertion may keep the nominal s_h.
/// A level-h particle then scans (2 r + skin + searchSize_k) / cellEdge_k + 1 cells along axis k on
/// average (thesis, appendix of ch. 2.2, eqs. 2.55-2.64: the mean of the per-axis count over
/// a uniform centre is the box width over the cell edge plus one), i.e. 2 r / s + 2 + skin / s for plain
/// cells.
struct LevelGeometry {
  double insertionSize = 0.0;          ///< s_h (m): holds particles with s_{h-1} < 2 r + skin <= s_h
  std::array<double, 3> cellEdge{};    ///< actual cell edge per axis (m); cell volume = product
  std::array<double, 3> searchSize{};  ///< the s_j in the search half-width r + skin/2 + s_j/2 (m)
};

/// Plain cubic cells: edge = insertion size = search size (the thesis's model).
std::vector<LevelGeometry> cubicGeometry(std::span<const double> cellSizes);

/// Cells of a rectangular box with edges `boxLengths` (m): n_hk = floor(L_k / (s_h (1 + snapMargin))),
/// clamped to [1, 2^20], cells per axis of edge s'_hk = L_k / n_hk, so N^c_h = prod_k n_hk. The default
/// margin is the HGrid's (hgrid::kSnapMargin: a size dividing the box exactly is rounded down by one
/// cell), so model and counters see the same cells. Insertion uses the nominal s_h. The search
/// half-width uses the nominal s_h (complete, since level-h particles have 2 r + skin <= s_h, and
/// tighter), or s'_hk per axis when `searchWithCellEdge` (a grid that computes beta from its cell edge).
/// A grid that also inserts by the snapped edge of a cubic box is cubicGeometry(snapped sizes).
/// Not modelled: clamping of a search box that wraps a whole periodic axis, the aliasing of neighbour
/// cells when n_hk < 3, and walls (cells behind a wall do not exist, so walled boxes need less work,
/// thesis §2.2.5, numerical results). With periodic boxes and n_hk >= 3 the model matches the HGrid's counters to 0.1%
/// (hgrid_cost_model_test.cpp).
std::vector<LevelGeometry> snappedGeometry(std::span<const double> cellSizes, const Eigen::Vector3d& boxLengths,
                                           bool searchWithCellEdge = false, double snapMargin = 1e-9);

/// One occupied level of a cost evaluation; work is per particle of the whole system.
struct LevelCost {
  double insertionSize = 0.0;        ///< s_h (m)
  std::array<double, 3> cellEdge{};  ///< s'_hk (m)
  double fraction = 0.0;             ///< P_h = N_h / N
  double perCell = 0.0;              ///< m_h = N_h / N^c_h
  double pairTests = 0.0;            ///< T^cd_h / N (eqs. 2.31/2.33)
  double cellAccesses = 0.0;         ///< T^ca_h / N (eqs. 2.32/2.34)
};

struct CostBreakdown {
  std::vector<LevelCost> levels;  ///< occupied levels only (empty ones are dropped), ascending s_h
  double pairTests = 0.0;         ///< T^cd / N
  double cellAccesses = 0.0;      ///< T^ca / N
  double total = 0.0;             ///< T / N = T^cd / N + K T^ca / N (eq. 2.35)
};

/// T/N of eq. 2.35 for nominal cubic cells s_1 <= ... <= s_L (m; s_L >= maxDiameter()), cross-level
/// mode and K. O(L^2) arithmetic plus one levelBands() call; no allocation after the first call on a
/// thread.
/// Particles larger than s_L are not modelled (precondition).
double costPerParticle(const CostModelPsd& psd, std::span<const double> cellSizes, CrossLevel mode,
                       double K = kDefaultCellOverPairCost);

/// The same with the per-level breakdown, for any geometry (cubicGeometry, snappedGeometry).
/// `exactOwnCell` uses 1/2 m_h (N_h - 1) / N_h own-cell pairs (eq. 2.20 before the N_h >> 1 step;
/// samples only): the right choice when comparing with counted work on small samples.
CostBreakdown costBreakdown(const CostModelPsd& psd, std::span<const LevelGeometry> levels, CrossLevel mode,
                            double K = kDefaultCellOverPairCost, bool exactOwnCell = false);
CostBreakdown costBreakdown(const CostModelPsd& psd, std::span<const double> cellSizes, CrossLevel mode,
                            double K = kDefaultCellOverPairCost);

}  // namespace polydem::broadphase
