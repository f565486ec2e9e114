// HGrid cost model: geometry of the levels and evaluation of T/N (thesis §2.2.3, eqs. 2.14-2.35); see
// hgrid_cost_evaluation.hpp. Equations: V_p 2.14, N_h 2.17, N^c_h 2.18, m_h 2.19, own cell 2.20-2.21,
// half neighbourhood 2.22-2.23, b(j,h) 2.24, cross-level top-down 2.27-2.28, bottom-up 2.29-2.30, totals
// 2.31-2.34, T 2.35 (Krijgsman, Ogarko & Luding, Comp. Part. Mech. 1 (2014) 357).
//
// Every per-level quantity is a linear combination of the partial moments int_band r^k f dr, k = 0..3,
// because b(j, h) P_h = int_band prod_k ((2 r + skin + S_j) / e_jk + 1) f dr is a cubic in r. So one
// evaluation is L band() calls plus O(L^2) dot products of length 4, for both PSD sources (a sample
// uses prefix sums over sorted radii: O(log N) per level instead of O(N)).
#include "broadphase/hgrid_cost_evaluation.hpp"

#include <algorithm>
#include <cmath>

namespace polydem::broadphase {

namespace {
constexpr double kNc = kHalfNeighbourCells;
}  // namespace

// ---- geometry -----------------------------------------------------------------------------------------

std::vector<LevelGeometry> cubicGeometry(std::span<const double> cellSizes) {
  std::vector<LevelGeometry> out(cellSizes.size());
  for (std::size_t h = 0; h < cellSizes.size(); ++h) {
    const double s = cellSizes[h];
    out[h] = {s, {s, s, s}, {s, s, s}};
  }
  return out;
}

std::vector<LevelGeometry> snappedGeometry(std::span<const double> cellSizes, const Eigen::Vector3d& boxLengths,
                                           bool searchWithCellEdge, double snapMargin) {
  std::vector<LevelGeometry> out(cellSizes.size());
  for (std::size_t h = 0; h < cellSizes.size(); ++h) {
    const double s = cellSizes[h];
    out[h].insertionSize = s;
    for (int k = 0; k < 3; ++k) {
      const double n = std::clamp(std::floor(boxLengths[k] / (s * (1.0 + snapMargin))), 1.0, 1048576.0);
      out[h].cellEdge[k] = boxLengths[k] / n;
      out[h].searchSize[k] = searchWithCellEdge ? out[h].cellEdge[k] : s;
    }
  }
  return out;
}

// ---- evaluation ---------------------------------------------------------------------------------------

namespace {

struct Scratch {
  std::vector<double> sizes;
  std::vector<std::array<double, 4>> bands;
  std::vector<int> kept;
  std::vector<std::array<double, 4>> poly;
  std::vector<double> perCell;
  std::vector<LevelGeometry> geometry;
};

Scratch& scratch() {
  thread_local Scratch s;
  return s;
}

/// Coefficients (r^0..r^3) of the expected number of cells a particle of radius r scans on level g:
/// prod_k ((2 r + skin + S_k) / e_k + 1), the per-axis mean of the thesis's appendix to ch. 2.2 (eqs. 2.55-2.64).
std::array<double, 4> scanPolynomial(const LevelGeometry& g, double skin) {
  std::array<double, 4> p{1.0, 0.0, 0.0, 0.0};
  for (int k = 0; k < 3; ++k) {
    const double a = 2.0 / g.cellEdge[k];
    const double c = (skin + g.searchSize[k]) / g.cellEdge[k] + 1.0;
    for (int i = 3; i >= 1; --i) p[i] = p[i] * c + p[i - 1] * a;
    p[0] *= c;
  }
  return p;
}

/// Eqs. 2.31-2.35 per particle. `out` (optional) receives the per-level breakdown.
double evaluate(const CostModelPsd& psd, std::span<const LevelGeometry> geometry, CrossLevel mode, double K,
                bool exactOwnCell, CostBreakdown* out) {
  Scratch& sc = scratch();
  const int L = static_cast<int>(geometry.size());
  sc.sizes.resize(geometry.size());
  for (int h = 0; h < L; ++h) sc.sizes[h] = geometry[h].insertionSize;
  psd.levelBands(sc.sizes, sc.bands);
  sc.kept.clear();
  for (int h = 0; h < L; ++h) {
    if (sc.bands[h][0] > 0.0) sc.kept.push_back(h);  // empty levels are skipped by the grid
  }
  const int kept = static_cast<int>(sc.kept.size());
  sc.poly.resize(sc.kept.size());
  sc.perCell.resize(sc.kept.size());
  for (int a = 0; a < kept; ++a) {
    const LevelGeometry& g = geometry[sc.kept[a]];
    // eq. 2.19: m_h = N_h / N^c_h = n P_h (cell volume).
    sc.perCell[a] = psd.numberDensity() * sc.bands[sc.kept[a]][0] * (g.cellEdge[0] * g.cellEdge[1] * g.cellEdge[2]);
    sc.poly[a] = scanPolynomial(g, psd.skin());
  }
  const double ownCellDeficit = exactOwnCell && psd.isSample() ? 1.0 / psd.sampleSize() : 0.0;
  if (out) out->levels.clear();
  double sumCd = 0.0, sumCa = 0.0;
  for (int a = 0; a < kept; ++a) {
    const auto& moments = sc.bands[sc.kept[a]];
    const double P = moments[0], m = sc.perCell[a];
    // eqs. 2.20-2.23: own cell (1/2 m_h per particle) and n_c forward neighbour cells.
    double cd = 0.5 * m * (P - ownCellDeficit) + kNc * m * P;
    double ca = (1.0 + kNc) * P;
    // eqs. 2.27-2.30: P_h b(j, h) = int_band poly_j(r) f(r) dr.
    const int b0 = mode == CrossLevel::TopDown ? 0 : a + 1;
    const int b1 = mode == CrossLevel::TopDown ? a : kept;
    for (int b = b0; b < b1; ++b) {
      const auto& p = sc.poly[b];
      const double B = p[0] * moments[0] + p[1] * moments[1] + p[2] * moments[2] + p[3] * moments[3];
      cd += sc.perCell[b] * B;
      ca += B;
    }
    sumCd += cd;
    sumCa += ca;
    if (out) {
      const LevelGeometry& g = geometry[sc.kept[a]];
      out->levels.push_back({g.insertionSize, g.cellEdge, P, m, cd, ca});
    }
  }
  const double total = sumCd + K * sumCa;  // eq. 2.35
  if (out) {
    out->pairTests = sumCd;
    out->cellAccesses = sumCa;
    out->total = total;
  }
  return total;
}

std::span<const LevelGeometry> cubicScratchGeometry(std::span<const double> cellSizes) {
  auto& g = scratch().geometry;
  g.resize(cellSizes.size());
  for (std::size_t h = 0; h < cellSizes.size(); ++h) {
    const double s = cellSizes[h];
    g[h] = {s, {s, s, s}, {s, s, s}};
  }
  return g;
}

}  // namespace

double costPerParticle(const CostModelPsd& psd, std::span<const double> cellSizes, CrossLevel mode, double K) {
  // The cubic geometry lives in per-thread scratch: the optimiser's inner loop does not allocate.
  return evaluate(psd, cubicScratchGeometry(cellSizes), mode, K, false, nullptr);
}

CostBreakdown costBreakdown(const CostModelPsd& psd, std::span<const LevelGeometry> levels, CrossLevel mode, double K,
                            bool exactOwnCell) {
  CostBreakdown out;
  evaluate(psd, levels, mode, K, exactOwnCell, &out);
  return out;
}

CostBreakdown costBreakdown(const CostModelPsd& psd, std::span<const double> cellSizes, CrossLevel mode, double K) {
  const auto geometry = cubicGeometry(cellSizes);
  return costBreakdown(psd, geometry, mode, K, false);
}

}  // namespace polydem::broadphase
