// polydem bench, suite levels: Ogarko & Luding, Comput. Phys. Commun. 183 (2012) 931, Fig. 2.5 of the thesis.
#include "apps/polydem/bench_common.hpp"
#include "apps/polydem/summary.hpp"

namespace polydem::app::bench {

// The columns of levels.csv, also the table `tables.levels` of --summary-json.
constexpr const char* kLevelsColumns =
    "distribution,omega,L,packing,m,us_per_particle,spread,slowdown,slowdown_model_ch21,slowdown_model_ch22,pair_tests_"
    "per_particle,cell_accesses_per_particle,model_pair_tests,model_cell_accesses,model_T_per_particle,cell_sizes";

namespace {

struct LevelsOutcome {
  std::string label;
  int bestLevels = 1;
  double speedupOverOneLevel = 1.0;
};

LevelsOutcome levelsCase(const BenchOptions& opt, const BenchScene& scene, const std::string& series, double omega,
                         std::ofstream& csv, std::string& markdown) {
  const Index count = static_cast<Index>(scene.config.radius.size());
  const Configuration& c = scene.config;
  const SphereView spheres{c.position, c.radius};
  std::vector<double> radii(c.radius.data(), c.radius.data() + c.radius.size());
  const double volume = c.box.volume();
  const double K21 = 0.3;  // the seed's ch. 2.1 value for L (m + K)
  const auto appendix = broadphase::appendixProcedure(radii, volume, 0.0, K21, opt.maxLevels);
  const auto psd = broadphase::CostModelPsd::sample(radii, volume, 0.0);
  fmt::print("{}: N = {}, packing {:.3f} ({})\n", scene.label, count, scene.packing, scene.placement);

  struct Row {
    int L;
    double m, t, spread, model21, model22, modelCd, modelCa;
    std::uint64_t tcd, tca;
    std::string sizes;
  };
  std::vector<Row> rows;
  for (const auto& level : appendix.table) {
    broadphase::HGridTopDown grid;
    broadphase::HGridConfig config;
    config.cellSizes = level.cellSizes;
    grid.setConfig(config);
    const Timed t = timeBackend(grid, spheres, c.box, 0.0, opt.repeat);
    const auto geometry = broadphase::snappedGeometry(level.cellSizes, c.box.lengths());
    const auto breakdown = broadphase::costBreakdown(psd, geometry, broadphase::CrossLevel::TopDown);
    const double model22 = breakdown.total;
    std::string sizes;
    for (double s : level.cellSizes) sizes += fmt::format("{}{:.4g}", sizes.empty() ? "" : ";", s);
    rows.push_back({level.levels, level.perCell, t.seconds, t.spread, level.cost, model22, breakdown.pairTests,
                    breakdown.cellAccesses, t.pairTests, t.cellAccesses, sizes});
    fmt::print("  L = {:2d}: m = {:.3f}, {:.4f} us/particle (spread {:.0f}%), model L(m+K) = {:.3f}, T/N = {:.2f}\n",
               level.levels, level.perCell, 1e6 * t.seconds / count, 100 * t.spread, level.cost, model22);
  }
  auto minOf = [&](auto field) {
    double best = std::numeric_limits<double>::infinity();
    for (const Row& r : rows) best = std::min(best, field(r));
    return best;
  };
  const double tMin = minOf([](const Row& r) { return r.t; });
  const double m21Min = minOf([](const Row& r) { return r.model21; });
  const double m22Min = minOf([](const Row& r) { return r.model22; });
  LevelsOutcome outcome;
  outcome.label = scene.label;
  for (const Row& r : rows) {
    csv << fmt::format(
        "{},{},{},{:.6f},{:.6f},{:.5f},{:.4f},{:.5f},{:.5f},{:.5f},{:.5f},{:.5f},{:.5f},{:.5f},{:.5f},{}\n", series,
        omega, r.L, scene.packing, r.m, 1e6 * r.t / count, r.spread, r.t / tMin, r.model21 / m21Min, r.model22 / m22Min,
        static_cast<double>(r.tcd) / count, static_cast<double>(r.tca) / count, r.modelCd, r.modelCa, r.model22,
        r.sizes);
    summary().appendRow(
        "tables.levels", kLevelsColumns,
        {cell(series), cell(omega), cell(r.L), cell(scene.packing), cell(r.m), cell(1e6 * r.t / count), cell(r.spread),
         cell(r.t / tMin), cell(r.model21 / m21Min), cell(r.model22 / m22Min), cell(static_cast<double>(r.tcd) / count),
         cell(static_cast<double>(r.tca) / count), cell(r.modelCd), cell(r.modelCa), cell(r.model22), cell(r.sizes)});
    if (r.t == tMin) outcome.bestLevels = r.L;
  }
  outcome.speedupOverOneLevel = rows.front().t / tMin;
  const Row& bestRow = *std::find_if(rows.begin(), rows.end(), [&](const Row& r) { return r.L == outcome.bestLevels; });
  markdown += fmt::format("| {} | {:.3f} ({}) | {} | {:.1f}x | {:.3f} / {:.3f} | {:.2f} / {:.2f} | {} | {} |\n",
                          scene.label, scene.packing, scene.placement, outcome.bestLevels, outcome.speedupOverOneLevel,
                          static_cast<double>(bestRow.tcd) / count, bestRow.modelCd,
                          static_cast<double>(bestRow.tca) / count, bestRow.modelCa, appendix.optimalLevels, [&] {
                            int best = 1;
                            for (const Row& r : rows)
                              if (r.model22 == m22Min) best = r.L;
                            return best;
                          }());
  return outcome;
}

}  // namespace

int runLevels(const BenchOptions& opt, std::string& markdown, bool /*quick*/) {
  const std::filesystem::path dir = opt.out;
  ReportFile csvFile(dir / "levels.csv");
  std::ofstream& csv = csvFile.stream();
  csv << kLevelsColumns << "\n";
  markdown +=
      "## Slowdown factor against the number of levels (Ogarko & Luding 2012; Ogarko's thesis Fig. 2.5)\n\n"
      "Top-Down HGrid, cell sizes from the seed's ch. 2.1 appendix procedure (equal particles per cell on every\n"
      "level); time = one build + one findPairs (contact detection only; the seed timed whole DEM steps).\n"
      "Models: L (m + K) with K = 0.3 (ch. 2.1) and T/N of eq. 2.35 with K = 0.2 (ch. 2.2), snapped cells.\n\n"
      "The counted work at the fastest L is shown beside the model's (random-centre) prediction: these are\n"
      "non-overlapping packings, where excluded volume breaks the model's assumptions.\n\n"
      "| system | packing | fastest L | speed-up over L = 1 | T_cd/N counted / model | T_ca/N counted / model |"
      " model ONL (ch. 2.1) | model best L (ch. 2.2) |\n"
      "| --- | --- | --- | --- | --- | --- | --- | --- |\n";
  std::vector<std::string> series;
  if (!opt.inputs.empty()) {
    for (const std::string& file : opt.inputs) {
      const BenchScene scene = sceneFromFile(file);
      series.push_back(scene.label);
      const double omega = scene.config.radius.maxCoeff() / scene.config.radius.minCoeff();
      levelsCase(opt, scene, scene.label, omega, csv, markdown);
    }
  } else {
    const Index count = opt.count > 0 ? opt.count : 125001;
    const double packing = opt.packing > 0 ? opt.packing : 0.62;
    for (const char* kind : {"uniform-volume", "uniform-radius"}) {
      DistributionSpec spec;
      spec.kind = kind;
      spec.omega = 50.0;
      Stopwatch prep;
      const BenchScene scene = makeBenchScene(opt, spec, count, packing, 1);
      fmt::print("{} prepared in {:.1f} s\n", scene.label, prep.seconds());
      series.push_back(kind);
      levelsCase(opt, scene, kind, spec.omega, csv, markdown);
    }
  }
  csvFile.commit();
  ReportFile gpFile(dir / "levels.gp");
  std::ofstream& gp = gpFile.stream();
  gp << "set datafile separator ','\nset terminal png size 900,600\nset output '" << (dir / "levels.png").string()
     << "'\nset termoption noenhanced\nset logscale y\nset xlabel 'number of levels L'\nset ylabel 'slowdown factor'\n"
     << "set key top left\nset title 'HGrid slowdown against L, measured vs cost models'\nplot ";
  for (std::size_t k = 0; k < series.size(); ++k) {
    const std::string sel = fmt::format("(strcol(1) eq '{}' ? $3 : 1/0)", series[k]);
    gp << (k ? ", " : "") << "'" << (dir / "levels.csv").string() << "' using " << sel << ":8 with linespoints lc "
       << k + 1 << " title '" << series[k] << " measured', '' using " << sel << ":10 with lines dt 2 lc " << k + 1
       << " title '" << series[k] << " model eq. 2.35', '' using " << sel << ":9 with lines dt 3 lc " << k + 1
       << " title '" << series[k] << " model L(m+K)'";
  }
  gp << "\n";
  gpFile.commit();
  markdown += runGnuplot(dir / "levels.gp", dir / "levels.png") ? "\n![levels](levels.png)\n\n"
                                                                : "\n(gnuplot not available: no plot)\n\n";
  return 0;
}

}  // namespace polydem::app::bench
