// HGrid cost model, cell-size rules, optimiser and K calibration against reference values recomputed
// from the model (d = 3, nu = 0.7, K = 0.2 unless noted), which reproduce the numbers printed in Ogarko's
// thesis (Univ. Twente) ch. 2.1-2.2 (Krijgsman, Ogarko & Luding, Comp. Part. Mech. 1 (2014) 357).
#include "broadphase/hgrid_cost_model.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <numeric>
#include <vector>

#include "broadphase/auto_select.hpp"
#include "broadphase/brute_force.hpp"
#include "broadphase/calibrate_k.hpp"
#include "broadphase/hgrid.hpp"
#include "core/errors.hpp"
#include "core/size_distribution.hpp"
#include "tests/support/scene.hpp"

namespace polydem::broadphase {
namespace {

constexpr CrossLevel kTD = CrossLevel::TopDown;
constexpr CrossLevel kBU = CrossLevel::BottomUp;

std::unique_ptr<SizeDistribution> powerLaw(double alpha, double omega) {
  DistributionSpec spec;
  spec.kind = "power-law";
  spec.rmin = 1.0;
  spec.omega = omega;
  spec.alpha = alpha;
  return makeDistribution(spec);
}

std::unique_ptr<SizeDistribution> mono() {
  DistributionSpec spec;
  spec.kind = "mono";
  spec.rmin = 1.0;
  return makeDistribution(spec);
}

/// Systematic sample with u = 1/2 (thesis §2.1.3): r_i = F^-1((i + 1/2) / N), ascending.
std::vector<double> systematicSample(const SizeDistribution& d, int count) {
  std::vector<double> r(static_cast<std::size_t>(count));
  for (int i = 0; i < count; ++i) r[i] = d.quantile((i + 0.5) / count);
  return r;
}

/// Box volume that gives packing fraction nu to these radii.
double boxVolumeFor(const std::vector<double>& radii, double nu) {
  double v = 0.0;
  for (double r : radii) v += 4.0 / 3.0 * kPi * r * r * r;
  return v / nu;
}

struct Best {
  int levels = 0;
  double value = 1e300;
};

/// Plain argmin over L of a rule (the spec's L*, without the optimiser's 1% preference).
Best scan(const CostModelPsd& psd, const std::function<std::vector<double>(int)>& rule, CrossLevel mode, int maxLevels,
          double K = 0.2) {
  Best best;
  for (int L = 1; L <= maxLevels; ++L) {
    const double v = costPerParticle(psd, rule(L), mode, K);
    if (v < best.value) best = {L, v};
  }
  return best;
}

// ---- model -------------------------------------------------------------------------------------------

TEST(HGridCostModel, MonodisperseLinkedCell) {
  const auto d = mono();
  for (auto [nu, expected] : {std::pair{0.7, 20.85}, std::pair{0.62, 18.79}}) {
    const CostModelPsd psd = CostModelPsd::analytic(*d, nu);
    const std::vector<double> sizes{2.0};
    const double t = costPerParticle(psd, sizes, kTD, 0.2);
    EXPECT_NEAR(t, expected, 0.005) << "nu " << nu;
    // T/N = 13.5 m_1 + 14 K with m_1 = 8 nu / V_3 (eqs. 2.35, 2.40).
    EXPECT_NEAR(t, 13.5 * 8.0 * nu / (4.0 / 3.0 * kPi) + 14 * 0.2, 1e-12);
  }
}

TEST(HGridCostModel, LinkedCellPowerLaws) {
  struct Case {
    double alpha, omega, expected, tolerance;
  };
  // Our recomputed 995.5 for omega = 10 is 995.449 rounded up; the others agree to all printed digits.
  for (const Case& c :
       {Case{-3, 100, 91146, 1.0}, Case{0, 100, 74.27, 0.005}, Case{-3, 10, 995.45, 0.01}, Case{-3, 2, 56.9, 0.05}}) {
    const auto d = powerLaw(c.alpha, c.omega);
    const CostModelPsd psd = CostModelPsd::analytic(*d, 0.7);
    const std::vector<double> sizes{2.0 * c.omega};
    EXPECT_NEAR(costPerParticle(psd, sizes, kTD, 0.2), c.expected, c.tolerance) << c.alpha << " " << c.omega;
    // m_1 against the closed form eq. 2.40 (thesis §2.2.5, Fig. 2.9).
    const double a = c.alpha, w = c.omega;
    const double m1 = 8 * w * w * w * (0.7 / (4.0 / 3.0 * kPi)) * (4 + a) / (1 + a) * (std::pow(w, 1 + a) - 1) /
                      (std::pow(w, 4 + a) - 1);
    EXPECT_NEAR(costBreakdown(psd, sizes, kTD).levels.at(0).perCell, m1, 1e-9 * m1);
  }
}

TEST(HGridCostModel, BreakdownAddsUp) {
  const auto d = powerLaw(-3, 100);
  const CostModelPsd psd = CostModelPsd::analytic(*d, 0.7);
  const auto sizes = constantRatioCellSizes(psd, 12);
  for (CrossLevel mode : {kTD, kBU}) {
    const CostBreakdown b = costBreakdown(psd, sizes, mode, 0.2);
    ASSERT_EQ(b.levels.size(), 12u);
    double P = 0, cd = 0, ca = 0;
    for (const LevelCost& l : b.levels) {
      P += l.fraction;
      cd += l.pairTests;
      ca += l.cellAccesses;
    }
    EXPECT_NEAR(P, 1.0, 1e-12);
    EXPECT_NEAR(cd, b.pairTests, 1e-12 * cd);
    EXPECT_NEAR(ca, b.cellAccesses, 1e-12 * ca);
    EXPECT_NEAR(b.total, b.pairTests + 0.2 * b.cellAccesses, 1e-12 * b.total);
    EXPECT_DOUBLE_EQ(b.total, costPerParticle(psd, sizes, mode, 0.2));
  }
}

TEST(HGridCostModel, EmptyLevelsAreDropped) {
  const auto d = powerLaw(-3, 10);
  const CostModelPsd psd = CostModelPsd::analytic(*d, 0.7);
  const std::vector<double> sizes{5.0, 11.0, 20.0};
  // Sizes below s_0 = 2 and repeated sizes hold nobody.
  const std::vector<double> padded{1.0, 1.5, 5.0, 5.0, 11.0, 20.0, 20.0};
  for (CrossLevel mode : {kTD, kBU}) {
    EXPECT_DOUBLE_EQ(costPerParticle(psd, padded, mode), costPerParticle(psd, sizes, mode));
    EXPECT_EQ(costBreakdown(psd, padded, mode).levels.size(), 3u);
  }
}

// ---- the four rules of ch. 2.2.5, alpha = -3, omega = 100 (Figs. 2.15-2.16) ----------------------------------

TEST(HGridCostModel, ConstantMReference) {
  const auto d = powerLaw(-3, 100);
  const CostModelPsd psd = CostModelPsd::analytic(*d, 0.7);
  const Best best = scan(
      psd, [&](int L) { return constantRatioCellSizes(psd, L); }, kTD, 40);
  EXPECT_EQ(best.levels, 12);
  EXPECT_NEAR(best.value, 11.595, 0.002);  // seed: 11.60

  const auto sizes = constantRatioCellSizes(psd, 12);
  const std::vector<double> expected{6.252,  13.904,  24.887, 38.695,  54.748,  72.55,
                                     91.714, 111.949, 133.04, 154.823, 177.175, 200.0};
  ASSERT_EQ(sizes.size(), expected.size());
  for (std::size_t h = 0; h < sizes.size(); ++h) EXPECT_NEAR(sizes[h], expected[h], 6e-4 * expected[h]) << h;
  for (const LevelCost& l : costBreakdown(psd, sizes, kTD).levels) EXPECT_NEAR(l.perCell, 0.185, 5e-4);

  // Insensitivity: L = 8 or 19 cost about 10% more (thesis §2.2.5, constant-m results).
  EXPECT_NEAR(costPerParticle(psd, constantRatioCellSizes(psd, 8), kTD), 12.759, 0.002);
  EXPECT_NEAR(costPerParticle(psd, constantRatioCellSizes(psd, 19), kTD), 12.771, 0.002);
}

TEST(HGridCostModel, ConstantRatioQ) {
  // Fig. 2.12: minima for q = 1.5 and 2.
  const auto d = powerLaw(-3, 100);
  const CostModelPsd psd = CostModelPsd::analytic(*d, 0.7);
  const Best q15 = scan(
      psd, [&](int L) { return constantRatioCellSizes(psd, L, 1.5); }, kTD, 20);
  EXPECT_EQ(q15.levels, 6);
  EXPECT_NEAR(q15.value, 11.603, 0.002);
  const Best q2 = scan(
      psd, [&](int L) { return constantRatioCellSizes(psd, L, 2.0); }, kTD, 20);
  EXPECT_EQ(q2.levels, 5);
  EXPECT_NEAR(q2.value, 11.718, 0.002);
  const auto sizes = constantRatioCellSizes(psd, 6, 1.5);
  const auto levels = costBreakdown(psd, sizes, kTD).levels;
  for (std::size_t h = 1; h < levels.size(); ++h) EXPECT_NEAR(levels[h].perCell / levels[h - 1].perCell, 1.5, 1e-6);
}

TEST(HGridCostModel, LinearReference) {
  const auto d = powerLaw(-3, 100);
  const CostModelPsd psd = CostModelPsd::analytic(*d, 0.7);
  const Best best = scan(
      psd, [&](int L) { return linearCellSizes(psd, L); }, kTD, 80);
  EXPECT_EQ(best.levels, 43);
  EXPECT_NEAR(best.value, 12.398, 0.002);  // seed: 12.40
}

TEST(HGridCostModel, ExponentialReference) {
  const auto d = powerLaw(-3, 100);
  const CostModelPsd psd = CostModelPsd::analytic(*d, 0.7);
  const Best best = scan(
      psd, [&](int L) { return exponentialCellSizes(psd, L); }, kTD, 30);
  EXPECT_EQ(best.levels, 4);
  EXPECT_NEAR(best.value, 12.13, 0.005);  // the seed's 11.57 is not reproducible by the model
  EXPECT_NEAR(costPerParticle(psd, exponentialCellSizes(psd, 3), kTD), 17.88, 0.01);
  EXPECT_NEAR(costPerParticle(psd, exponentialCellSizes(psd, 6), kTD), 15.04, 0.01);
}

TEST(HGridCostModel, OptimalReference) {
  const auto d = powerLaw(-3, 100);
  const CostModelPsd psd = CostModelPsd::analytic(*d, 0.7);
  OptimiserOptions options;
  options.mode = kTD;
  const OptimiserResult result = optimiseHGrid(psd, options);
  double best = 1e300;
  for (const LevelsRow& row : result.table) best = std::min(best, row.topDown.predicted);
  EXPECT_NEAR(best, 11.5736, 0.1e-2 * 11.5736);
  EXPECT_LE(best, 11.595);  // at least as good as constant m
  // The chosen configuration is within 1% of the minimum, with fewer levels.
  EXPECT_FALSE(result.chosen.linkedCell);
  EXPECT_EQ(result.chosen.config.mode, kTD);
  EXPECT_LE(result.chosen.predicted, 1.01 * best + 1e-12);
  EXPECT_LE(result.chosen.levels, 12);
  // L = 8 optimum (recomputed from the model): 6.22, 14.50, 28.08, 47.82, 74.29, 107.87, 149.11, 200.0, T/N flat.
  const LevelsRow& row8 = result.table.at(7);
  EXPECT_NEAR(row8.topDown.predicted, 11.5736, 0.003 * 11.5736);
  const std::vector<double> expected{6.22, 14.50, 28.08, 47.82, 74.29, 107.87, 149.11, 200.0};
  for (std::size_t h = 0; h < expected.size(); ++h) {
    EXPECT_NEAR(row8.topDown.cellSizes.at(h), expected[h], 0.005 * expected[h]) << h;
  }
  // Never worse than constant m, never increasing with L (warm starts).
  for (std::size_t i = 0; i < result.table.size(); ++i) {
    EXPECT_LE(result.table[i].topDown.predicted, result.table[i].constantMTopDown.predicted * (1 + 1e-12)) << i;
    if (i > 0) {
      EXPECT_LE(result.table[i].topDown.predicted, result.table[i - 1].topDown.predicted * (1 + 1e-12)) << i;
    }
  }
  EXPECT_EQ(result.table.size(), 30u);
  EXPECT_TRUE(std::isinf(result.table[5].bottomUp.predicted));  // BU not evaluated
}

// ---- other PSDs -------------------------------------------------------------------------------------

TEST(HGridCostModel, UniformSizeOmega100) {
  const auto d = powerLaw(0, 100);
  const CostModelPsd psd = CostModelPsd::analytic(*d, 0.7);
  const auto linear = [&](int L) { return linearCellSizes(psd, L); };
  const auto constantM = [&](int L) { return constantRatioCellSizes(psd, L); };
  const Best linearBU = scan(psd, linear, kBU, 40);
  EXPECT_EQ(linearBU.levels, 5);
  EXPECT_NEAR(linearBU.value, 31.51, 0.005);
  const Best linearTD = scan(psd, linear, kTD, 40);
  EXPECT_EQ(linearTD.levels, 3);
  EXPECT_NEAR(linearTD.value, 33.74, 0.005);
  const Best cmTD = scan(psd, constantM, kTD, 30);
  EXPECT_EQ(cmTD.levels, 5);
  EXPECT_NEAR(cmTD.value, 29.47, 0.005);
  const Best cmBU = scan(psd, constantM, kBU, 30);
  EXPECT_EQ(cmBU.levels, 4);
  EXPECT_NEAR(cmBU.value, 33.35, 0.005);
}

TEST(HGridCostModel, ConstantMOtherPowerLaws) {
  struct Case {
    double alpha, omega;
    int levels;
    double expected;
  };
  for (const Case& c : {Case{-3, 10, 7, 20.48}, Case{-3, 1000, 15, 8.87}, Case{-3, 2, 3, 27.48},
                        Case{-1, 100, 7, 22.71}, Case{-2, 100, 10, 13.60}}) {
    const auto d = powerLaw(c.alpha, c.omega);
    const CostModelPsd psd = CostModelPsd::analytic(*d, 0.7);
    const Best best = scan(
        psd, [&](int L) { return constantRatioCellSizes(psd, L); }, kTD, 30);
    EXPECT_EQ(best.levels, c.levels) << c.alpha << " " << c.omega;
    EXPECT_NEAR(best.value, c.expected, 0.006) << c.alpha << " " << c.omega;
  }
}

// ---- ch. 2.1 appendix procedure -------------------------------------------------------------------

TEST(HGridCostModel, AppendixProcedureUniformVolume) {
  const auto d = powerLaw(-3, 50);
  const auto radii = systematicSample(*d, 125001);
  const double volume = boxVolumeFor(radii, 0.62);
  const AppendixResult result = appendixProcedure(radii, volume, 0.0, 0.3);
  EXPECT_EQ(result.optimalLevels, 7);
  EXPECT_NEAR(result.optimal().perCell, 0.368, 1e-3);
  EXPECT_NEAR(result.optimal().cost, 4.67, 0.01);
  ASSERT_EQ(result.table.front().levels, 1);
  EXPECT_NEAR(result.table.front().cost, 1487.7, 0.5);
  // L(m) at the reported m, and one level more just below it.
  const CostModelPsd psd = CostModelPsd::sample(radii, volume);  // owns the radii the span views
  const auto sorted = psd.sortedRadii();
  EXPECT_EQ(appendixLevelCount(sorted, volume, 0.0, result.optimal().perCell), 7);
  EXPECT_GT(appendixLevelCount(sorted, volume, 0.0, result.optimal().perCell * (1 - 1e-6)), 7);
  const auto& s = result.optimal().cellSizes;
  ASSERT_EQ(s.size(), 7u);
  EXPECT_DOUBLE_EQ(s.back(), 2.0 * radii.back());
  EXPECT_TRUE(std::is_sorted(s.begin(), s.end()));
}

TEST(HGridCostModel, AppendixProcedureUniformSize) {
  const auto d = powerLaw(0, 50);
  const auto radii = systematicSample(*d, 125001);
  const AppendixResult result = appendixProcedure(radii, boxVolumeFor(radii, 0.62), 0.0, 0.3);
  EXPECT_EQ(result.optimalLevels, 3);
  EXPECT_NEAR(result.optimal().perCell, 0.688, 1e-3);
  // Predicted gain over one level: 1.67x.
  EXPECT_NEAR(result.table.front().cost / result.optimal().cost, 1.67, 0.01);
}

// ---- sample-based model, skin, snapped cells ----------------------------------------------------------

TEST(HGridCostModel, SampleAgreesWithAnalytic) {
  // A systematic sample of UV omega = 100 lacks the extreme tail: its largest radius is 99.38 (the
  // quantile at 1 - 1/(2N)) and its mean volume is 0.6% low. Levels near the top hold a handful of
  // particles. So model values agree to 0.2%, sizes to about 1%.
  const auto d = powerLaw(-3, 100);
  const auto radii = systematicSample(*d, 400001);
  for (double skin : {0.0, 0.3}) {
    SCOPED_TRACE(::testing::Message() << "skin " << skin);
    const CostModelPsd analytic = CostModelPsd::analytic(*d, 0.7, skin);
    const CostModelPsd sample = CostModelPsd::sample(radii, boxVolumeFor(radii, 0.7), skin);
    EXPECT_NEAR(sample.maxDiameter() / analytic.maxDiameter(), 1.0, 0.01);
    EXPECT_NEAR(sample.numberDensity() / analytic.numberDensity(), 1.0, 0.01);
    for (int L : {1, 4, 12}) {
      SCOPED_TRACE(::testing::Message() << "L " << L);
      const auto sizes = constantRatioCellSizes(analytic, L);
      for (CrossLevel mode : {kTD, kBU}) {
        const double a = costPerParticle(analytic, sizes, mode), s = costPerParticle(sample, sizes, mode);
        EXPECT_NEAR(s / a, 1.0, 2e-3);
        const auto la = costBreakdown(analytic, sizes, mode).levels, ls = costBreakdown(sample, sizes, mode).levels;
        ASSERT_EQ(la.size(), ls.size());
        for (std::size_t h = 0; h < la.size(); ++h) {
          EXPECT_NEAR(ls[h].fraction / la[h].fraction, 1.0, la[h].fraction * 400001 > 1000 ? 0.01 : 0.2) << h;
        }
      }
      // The sample's own constant-m sizes and their cost (its smaller s_L = 2 r_max + skin alone
      // lowers the linked-cell m by 1.8%).
      const auto sampled = constantRatioCellSizes(sample, L);
      for (int h = 0; h + 1 < L; ++h) EXPECT_NEAR(sampled[h] / sizes[h], 1.0, L <= 4 ? 0.005 : 0.015) << h;
      EXPECT_NEAR(costPerParticle(sample, sampled, kTD) / costPerParticle(analytic, sizes, kTD), 1.0, 0.025);
    }
  }
}

TEST(HGridCostModel, SkinIsAnInteractionRadius) {
  const auto d = powerLaw(-2, 20);
  const auto radii = systematicSample(*d, 20000);
  const double volume = boxVolumeFor(radii, 0.5), skin = 0.4;
  std::vector<double> grown(radii);
  for (double& r : grown) r += 0.5 * skin;
  const CostModelPsd withSkin = CostModelPsd::sample(radii, volume, skin);
  const CostModelPsd interaction = CostModelPsd::sample(grown, volume, 0.0);
  EXPECT_DOUBLE_EQ(withSkin.maxDiameter(), interaction.maxDiameter());
  const std::vector<double> sizes{3.0, 7.0, 15.0, withSkin.maxDiameter()};
  for (CrossLevel mode : {kTD, kBU}) {
    EXPECT_NEAR(costPerParticle(withSkin, sizes, mode), costPerParticle(interaction, sizes, mode),
                1e-9 * costPerParticle(interaction, sizes, mode));
  }
  // The skin makes everything costlier: larger cells hold more particles.
  const CostModelPsd noSkin = CostModelPsd::sample(radii, volume, 0.0);
  EXPECT_GT(costPerParticle(withSkin, sizes, kTD), costPerParticle(noSkin, sizes, kTD));
}

TEST(HGridCostModel, SnappedCellsOfARectangularBox) {
  // Monodisperse r = 1, N = 1000 in a 10 x 20 x 7 box, one level of nominal size 3:
  // 3 x 6 x 2 cells of 3.333 x 3.333 x 3.5.
  const std::vector<double> radii(1000, 1.0);
  const Eigen::Vector3d lengths(10, 20, 7);
  const CostModelPsd psd = CostModelPsd::sample(radii, lengths.prod());
  const std::vector<double> one{3.0};
  const auto g = snappedGeometry(one, lengths);
  EXPECT_NEAR(g[0].cellEdge[0], 10.0 / 3, 1e-12);
  EXPECT_NEAR(g[0].cellEdge[1], 20.0 / 6, 1e-12);
  EXPECT_NEAR(g[0].cellEdge[2], 3.5, 1e-12);
  const CostBreakdown b = costBreakdown(psd, g, kTD, 0.2);
  const double m = 1000.0 / 36;
  EXPECT_NEAR(b.levels.at(0).perCell, m, 1e-9);
  EXPECT_NEAR(b.total, 13.5 * m + 14 * 0.2, 1e-9);
  // exactOwnCell: 1/2 m (N - 1) / N own-cell pairs.
  EXPECT_NEAR(costBreakdown(psd, g, kTD, 0.2, true).total, 0.5 * m * 999 / 1000 + 13 * m + 14 * 0.2, 1e-9);
  // A size dividing the box exactly loses one cell (the HGrid's snap margin).
  const std::vector<double> five{5.0};
  EXPECT_NEAR(snappedGeometry(five, lengths)[0].cellEdge[1], 20.0 / 3, 1e-12);
  EXPECT_NEAR(snappedGeometry(five, lengths, false, 0.0)[0].cellEdge[1], 5.0, 1e-12);
}

TEST(HGridCostModel, SnappedCrossLevelScan) {
  // Bidisperse r = 1 and r = 4 (half each) in a cube of 30; nominal sizes 2.5 and 8.5.
  std::vector<double> radii(2000, 1.0);
  std::fill(radii.begin() + 1000, radii.end(), 4.0);
  const Eigen::Vector3d lengths(30, 30, 30);
  const double skin = 0.25;
  const CostModelPsd psd = CostModelPsd::sample(radii, lengths.prod(), skin);
  const std::vector<double> sizes{2.5, 8.5};
  // floor(30 / 2.5) = 12 cells, but the snap margin rounds an exact divisor down: 11 cells.
  const double f1 = 30.0 / 11, e2 = 30.0 / 3;
  const auto g = snappedGeometry(sizes, lengths);
  EXPECT_NEAR(g[0].cellEdge[0], f1, 1e-12);
  EXPECT_NEAR(g[1].cellEdge[0], e2, 1e-12);
  const double n = 2000 / lengths.prod();
  const double m1 = n * 0.5 * f1 * f1 * f1, m2 = n * 0.5 * e2 * e2 * e2;
  // TD: large spheres scan ((2 * 4 + skin + s_1) / s'_1 + 1)^3 level-1 cells.
  const double bTD = std::pow((8 + skin + 2.5) / f1 + 1, 3);
  const double own = 0.5 * (13.5 * m1 + 14 * 0.2) + 0.5 * (13.5 * m2 + 14 * 0.2);
  EXPECT_NEAR(costBreakdown(psd, g, kTD, 0.2).total, own + 0.5 * (m1 + 0.2) * bTD, 1e-9);
  // BU: small spheres scan ((2 + skin + s_2) / s'_2 + 1)^3 level-2 cells.
  const double bBU = std::pow((2 + skin + 8.5) / e2 + 1, 3);
  EXPECT_NEAR(costBreakdown(psd, g, kBU, 0.2).total, own + 0.5 * (m2 + 0.2) * bBU, 1e-9);
  // Unsnapped cubic cells give the seed's (2r/s + 2 + skin/s)^3.
  const double cubicTD = std::pow((8 + skin) / 2.5 + 2, 3);
  const double n1 = n * 0.5 * 2.5 * 2.5 * 2.5, n2 = n * 0.5 * 8.5 * 8.5 * 8.5;
  const double cubicOwn = 0.5 * (13.5 * n1 + 14 * 0.2) + 0.5 * (13.5 * n2 + 14 * 0.2);
  EXPECT_NEAR(costPerParticle(psd, sizes, kTD, 0.2), cubicOwn + 0.5 * (n1 + 0.2) * cubicTD, 1e-9);
}

TEST(HGridCostModel, SnappedModelMatchesHGridCounters) {
  // The model's ensemble (random overlapping centres, periodic box) counted by the real grid: UV
  // omega = 10, nu = 0.3, constant-m sizes for L = 5 and a skin. The grid inserts by the nominal sizes
  // and maps with snapped cells, as snappedGeometry() models; the remaining difference is the
  // randomness of the centres (we measured within 0.4% for N = 20000).
  const test::Scene scene =
      test::makeScene({.count = 20000, .distribution = "uniform-volume", .sizeRatio = 10.0, .packing = 0.3, .seed = 5});
  const double skin = 0.1 * scene.minRadius();
  const std::vector<double> radii(scene.radius.data(), scene.radius.data() + scene.radius.size());
  const CostModelPsd psd = CostModelPsd::sample(radii, scene.box.volume(), skin);
  std::vector<double> sizes = constantRatioCellSizes(psd, 5);
  sizes.back() *= 1.0 + 1e-12;
  const auto geometry = snappedGeometry(sizes, scene.box.lengths());
  for (CrossLevel mode : {kTD, kBU}) {
    SCOPED_TRACE(mode == kTD ? "top-down" : "bottom-up");
    std::vector<Pair> pairs;
    Counters counted;
    auto run = [&](auto& grid) {
      grid.setConfig(HGridConfig{sizes, mode, "test"});
      grid.build(scene.spheres(), scene.box, skin);
      grid.setCounting(true);
      grid.findPairs(scene.spheres(), pairs);
      counted = grid.counters();
    };
    if (mode == kTD) {
      HGridTopDown grid;
      run(grid);
    } else {
      HGridBottomUp grid;
      run(grid);
    }
    const CostBreakdown model = costBreakdown(psd, geometry, mode, 0.2, true);
    const double n = static_cast<double>(radii.size());
    std::cout << "[          ] " << (mode == kTD ? "TD" : "BU") << ": counted T_cd/N " << counted.pairTests / n
              << " T_ca/N " << counted.cellAccesses / n << ", model " << model.pairTests << " " << model.cellAccesses
              << "\n";
    EXPECT_NEAR(counted.pairTests / n / model.pairTests, 1.0, 0.01);  // 0.1% at this seed
    EXPECT_NEAR(counted.cellAccesses / n / model.cellAccesses, 1.0, 0.005);
  }
}

// ---- optimiser decisions -----------------------------------------------------------------------------

TEST(HGridCostModel, OptimiserPicksLinkedCellForNarrowDistributions) {
  {  // monodisperse, with a skin
    const std::vector<double> radii(5000, 0.5);
    const CostModelPsd psd = CostModelPsd::sample(radii, 5000 * 4.0 / 3 * kPi * 0.125 / 0.6, 0.05);
    const OptimiserResult r = optimiseHGrid(psd);
    EXPECT_TRUE(r.chosen.linkedCell) << r.summary();
    ASSERT_EQ(r.chosen.config.cellSizes.size(), 1u);
    EXPECT_GE(r.chosen.config.cellSizes[0], 1.05);
    EXPECT_NEAR(r.chosen.predicted, costPerParticle(psd, std::vector<double>{1.05}, kTD), 1e-12);
  }
  {  // uniform size, omega = 1.1
    const auto d = powerLaw(0, 1.1);
    const auto radii = systematicSample(*d, 20000);
    const HGridConfig config = optimiseForSpheres(radii, boxVolumeFor(radii, 0.6), 0.0);
    ASSERT_EQ(config.cellSizes.size(), 1u) << config.origin;
    EXPECT_NE(config.origin.find("linked-cell"), std::string::npos) << config.origin;
  }
  {
    // Uniform size, omega = 1.5. With the seed's K = 0.2 the model prefers two top-down levels by 16%
    // (23.93 vs 28.50 at nu = 0.6: the large third of the particles scan about 29 small cells of
    // m = 0.71 each, but both levels get much emptier cells); the linked cell wins from K of about 0.9
    // upwards, which includes the hashed look-up K measured on our machines (calibrate_k).
    const auto d = powerLaw(0, 1.5);
    const auto radii = systematicSample(*d, 20000);
    const CostModelPsd psd = CostModelPsd::sample(radii, boxVolumeFor(radii, 0.6));
    const OptimiserResult seed = optimiseHGrid(psd);
    EXPECT_FALSE(seed.chosen.linkedCell) << seed.summary();
    EXPECT_EQ(seed.chosen.levels, 2);
    EXPECT_NEAR(seed.chosen.predicted, 23.93, 0.02);
    EXPECT_EQ(seed.runnerUp.config.mode, kBU);  // bottom-up (24.93) beats the linked cell (28.50)
    EXPECT_NEAR(seed.runnerUp.predicted, 24.93, 0.02);
    EXPECT_NEAR(seed.table.at(0).topDown.predicted, 28.50, 0.02);
    OptimiserOptions slowCells;
    slowCells.K = 1.0;
    const OptimiserResult r = optimiseHGrid(psd, slowCells);
    EXPECT_TRUE(r.chosen.linkedCell) << r.summary();
    EXPECT_FALSE(r.runnerUp.linkedCell);
    EXPECT_GE(r.runnerUp.predicted, r.chosen.predicted * 0.99);
  }
}

TEST(HGridCostModel, OptimiserPicksTopDownForUniformVolume) {
  const auto d = powerLaw(-3, 50);
  const auto radii = systematicSample(*d, 125001);
  const double volume = boxVolumeFor(radii, 0.62), skin = 0.1;
  const CostModelPsd psd = CostModelPsd::sample(radii, volume, skin);
  const OptimiserResult r = optimiseHGrid(psd);
  std::cout << "[          ] UV omega=50 N=125001: " << r.summary() << " in " << r.seconds << " s\n";
  EXPECT_FALSE(r.chosen.linkedCell);
  EXPECT_EQ(r.chosen.config.mode, kTD);
  EXPECT_GE(r.chosen.levels, 4);
  const auto& s = r.chosen.config.cellSizes;
  EXPECT_TRUE(std::adjacent_find(s.begin(), s.end(), std::greater_equal<double>()) == s.end());
  EXPECT_GE(s.back(), 2.0 * radii.back() + skin);
  EXPECT_NEAR(costPerParticle(psd, s, kTD), r.chosen.predicted, 1e-9 * r.chosen.predicted);
  // Runner-up: bottom-up (better than the linked cell by orders of magnitude).
  EXPECT_FALSE(r.runnerUp.linkedCell);
  EXPECT_EQ(r.runnerUp.config.mode, kBU);
  EXPECT_GT(r.runnerUp.predicted, r.chosen.predicted);
  EXPECT_LT(r.runnerUp.predicted, r.table.at(0).topDown.predicted);
  // Fig. 2.5-style table for both modes.
  ASSERT_EQ(r.table.size(), 30u);
  for (const LevelsRow& row : r.table) {
    EXPECT_TRUE(std::isfinite(row.topDown.predicted) && std::isfinite(row.bottomUp.predicted));
    EXPECT_EQ(row.topDown.cellSizes.size(), static_cast<std::size_t>(row.levels));
  }
#ifdef NDEBUG
  EXPECT_LT(r.seconds, 1.0);
#endif
  // The configurator entry point gives the same grid.
  const HGridConfig config = optimiseForSpheres(radii, volume, skin);
  EXPECT_EQ(config.cellSizes, s);
  EXPECT_EQ(config.mode, kTD);
  EXPECT_NE(config.origin.find("hgrid-td"), std::string::npos);
  // Restricting the mode.
  const HGridConfig bu = optimiseForSpheres(radii, volume, skin, kBU);
  EXPECT_EQ(bu.mode, kBU);
  EXPECT_GT(bu.cellSizes.size(), 1u);
}

TEST(HGridCostModel, ConfiguresTheHGrid) {
  const test::Scene scene =
      test::makeScene({.count = 4000, .distribution = "uniform-volume", .sizeRatio = 20.0, .packing = 0.4, .seed = 9});
  const double skin = 0.1 * scene.minRadius();
  HGridTopDown grid;
  grid.setConfigurator(configureHGrid);
  grid.build(scene.spheres(), scene.box, skin);
  EXPECT_GT(grid.config().cellSizes.size(), 2u) << grid.config().origin;
  EXPECT_NE(grid.config().origin.find("hgrid-td"), std::string::npos) << grid.config().origin;
  std::vector<Pair> got, expected;
  grid.findPairs(scene.spheres(), got);
  BruteForce brute;
  brute.build(scene.spheres(), scene.box, skin);
  brute.findPairs(scene.spheres(), expected);
  sortPairs(got);
  sortPairs(expected);
  EXPECT_EQ(got, expected);
}

TEST(HGridCostModel, OptimiserRejectsBadInput) {
  const std::vector<double> radii{1.0, -1.0};
  EXPECT_THROW(CostModelPsd::sample(radii, 10.0), ConfigError);
  const std::vector<double> good{1.0, 2.0};
  EXPECT_THROW(CostModelPsd::sample(good, 0.0), ConfigError);
  EXPECT_THROW(CostModelPsd::sample(good, 10.0, -0.1), ConfigError);
  EXPECT_THROW(CostModelPsd::sample({}, 10.0), ConfigError);
  EXPECT_TRUE(optimiseForSpheres({}, 10.0, 0.0).cellSizes.empty());
  const auto d = mono();
  EXPECT_THROW(CostModelPsd::analytic(*d, 0.0), ConfigError);
  EXPECT_THROW(linearCellSizes(CostModelPsd::analytic(*d, 0.5), 0), ConfigError);
}

// ---- K calibration -----------------------------------------------------------------------------------

TEST(CalibrateK, MeasuresPlausibleTimesQuickly) {
  const auto t0 = std::chrono::steady_clock::now();
  const KCalibration k = measureK();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::cout << "[          ] K = " << k.K << " (t_pair " << k.pairTestSeconds * 1e9 << " ns, t_cell dense "
            << k.cellAccessSeconds * 1e9 << " ns, hashed " << k.hashedCellAccessSeconds * 1e9 << " ns) in " << seconds
            << " s\n";
  EXPECT_TRUE(k.calibrated);
  EXPECT_GT(k.pairTestSeconds, 1e-11);
  EXPECT_LT(k.pairTestSeconds, 1e-6);
  EXPECT_GT(k.cellAccessSeconds, 1e-11);
  EXPECT_GT(k.hashedCellAccessSeconds, 1e-11);
  EXPECT_NEAR(k.K, k.cellAccessSeconds / k.pairTestSeconds, 1e-12 * k.K);
  EXPECT_GT(k.K, 0.01);
  EXPECT_LT(k.K, 20.0);
#ifdef NDEBUG
  EXPECT_LT(seconds, 0.2 * 2);  // 0.2 s nominal; slack for a loaded machine
#endif
}

TEST(CalibrateK, CachedPerProcessAndDefault) {
  const KCalibration& a = calibratedK();
  const KCalibration& b = calibratedK();
  EXPECT_EQ(&a, &b);
  EXPECT_TRUE(a.calibrated);
  const KCalibration d = defaultKCalibration();
  EXPECT_FALSE(d.calibrated);
  EXPECT_DOUBLE_EQ(d.K, kDefaultCellOverPairCost);
}

// auto keeps linked cell unless the HGrid's predicted work is below it by more than the measured
// hierarchy overhead (2x, docs/benchmarks/model): uniform radius omega = 10 (model: HGrid 1.8x less work,
// measured: linked cell faster) stays linked cell; uniform volume omega = 10 (model: 30x less) gets an
// HGrid; with the overhead set to 1 the plain model decides and picks the HGrid for both.
TEST(AutoSelect, KeepsLinkedCellUnlessTheHGridSavesMoreThanItsOverhead) {
  auto chosenName = [](const test::Scene& scene, double overhead) {
    broadphase::AutoSelect a;
    a.setCostRatio(0.4);
    a.setHierarchyOverhead(overhead);
    a.build(scene.spheres(), scene.box, 0.1 * scene.minRadius());
    return std::string(a.chosen()->name());
  };
  const test::Scene us =
      test::makeScene({.count = 20000, .distribution = "uniform-radius", .sizeRatio = 10.0, .packing = 0.5, .seed = 3});
  const test::Scene uv =
      test::makeScene({.count = 20000, .distribution = "uniform-volume", .sizeRatio = 10.0, .packing = 0.5, .seed = 3});
  EXPECT_EQ(chosenName(us, broadphase::AutoSelect::kDefaultHierarchyOverhead), "linked-cell");
  EXPECT_EQ(chosenName(uv, broadphase::AutoSelect::kDefaultHierarchyOverhead), "hgrid-td");
  EXPECT_EQ(chosenName(us, 1.0), "hgrid-td");
  broadphase::AutoSelect a;
  EXPECT_THROW(a.setHierarchyOverhead(0.5), ConfigError);
  EXPECT_THROW(a.setHierarchyOverhead(std::nan("")), ConfigError);
}

// A distributed run's ranks build on changing shares of the system: with the system's radii as the sample,
// auto chooses once (the choice the whole system gets) and every build on a share is still exact.
TEST(AutoSelect, ASampleFixesTheChoiceForEveryShareOfTheSystem) {
  const test::Scene uv =
      test::makeScene({.count = 20000, .distribution = "uniform-volume", .sizeRatio = 10.0, .packing = 0.5, .seed = 5});
  const double skin = 0.1 * uv.minRadius();
  AutoSelect whole;
  whole.setCostRatio(0.4);
  whole.build(uv.spheres(), uv.box, skin);
  AutoSelect shared;
  shared.setCostRatio(0.4);
  shared.setSample(std::span<const double>(uv.radius.data(), static_cast<std::size_t>(uv.radius.size())), uv.box, skin);
  for (double lo : {0.0, 0.3, 0.55}) {  // slabs of about half the box, as two ranks' particles and ghosts
    std::vector<Index> keep;
    for (Index i = 0; i < uv.radius.size(); ++i) {
      const double x = uv.centre(0, i) / uv.box.length(0);
      if (x >= lo && x < lo + 0.5) keep.push_back(i);
    }
    Eigen::Matrix3Xd centre(3, static_cast<Index>(keep.size()));
    Eigen::VectorXd radius(static_cast<Index>(keep.size()));
    for (std::size_t k = 0; k < keep.size(); ++k) {
      centre.col(static_cast<Index>(k)) = uv.centre.col(keep[k]);
      radius[static_cast<Index>(k)] = uv.radius[keep[k]];
    }
    const SphereView share{centre, radius};
    shared.build(share, uv.box, skin);
    EXPECT_EQ(shared.reason(), whole.reason()) << "slab from " << lo;
    std::vector<Pair> got, expected;
    shared.findPairs(share, got);
    BruteForce brute;
    brute.build(share, uv.box, skin);
    brute.findPairs(share, expected);
    sortPairs(got);
    sortPairs(expected);
    EXPECT_EQ(got, expected) << "slab from " << lo;
  }
  EXPECT_THROW(shared.setSample(std::vector<double>{1.0, 0.0}, uv.box, skin), ConfigError);
  EXPECT_THROW(shared.setSample(std::vector<double>{1.0, std::nan("")}, uv.box, skin), ConfigError);
}

}  // namespace
}  // namespace polydem::broadphase
