// polydem bench, suite model: Ogarko's thesis §2.2.5, predicted vs measured Top-Down / Bottom-Up across alpha and
// omega.
#include "apps/polydem/bench_common.hpp"
#include "apps/polydem/summary.hpp"

namespace polydem::app::bench {

// The columns of model.csv, also the table `tables.model` of --summary-json.
constexpr const char* kModelColumns =
    "alpha,omega,N,packing,placement,method,L,model_T_per_particle,model_pair_tests,model_cell_accesses,counted_pair_"
    "tests,counted_cell_accesses,counted_T_per_particle,us_per_particle,spread,cell_sizes";

namespace {

/// model.gp and model.png: predicted work against measured time; the Markdown line for the plot.
std::string plotModel(const std::filesystem::path& dir) {
  // Predicted work against measured time: one point per (distribution, method); a line through the origin
  // would mean time proportional to the model's work.
  ReportFile gpFile(dir / "model.gp");
  std::ofstream& gp = gpFile.stream();
  gp << "set datafile separator ','\nset terminal png size 900,600\nset output '" << (dir / "model.png").string()
     << "'\nset termoption noenhanced\nset logscale xy\nset xlabel 'model T/N (pair tests + K cell accesses)'\n"
     << "set ylabel 'measured us per particle'\nset key top left\n"
     << "set title 'Cost model vs measurement, power laws (Krijgsman et al. 2014, thesis 2.2.5)'\nplot ";
  const char* methodsList[] = {"top-down optimal", "bottom-up optimal", "top-down constant m", "linked cell"};
  for (int k = 0; k < 4; ++k) {
    gp << (k ? ", " : "") << "'" << (dir / "model.csv").string() << "' using (strcol(6) eq '" << methodsList[k]
       << "' ? $8 : 1/0):14 with points pt " << 5 + 2 * k << " ps 1.5 title '" << methodsList[k] << "'";
  }
  gp << "\n";
  gpFile.commit();
  return runGnuplot(dir / "model.gp", dir / "model.png") ? "\n![model](model.png)\n\n"
                                                         : "\n(gnuplot failed: no plot)\n\n";
}

}  // namespace

int runModel(const BenchOptions& opt, std::string& markdown, bool quick) {
  const std::filesystem::path dir = opt.out;
  const Index count = opt.count > 0 ? opt.count : (quick ? 5000 : 100000);
  const double packing = opt.packing > 0 ? opt.packing : 0.5;
  const std::vector<double> alphas =
      quick ? std::vector<double>{0.0, -3.0} : std::vector<double>{0.0, -1.0, -2.0, -3.0};
  const std::vector<double> omegas = quick ? std::vector<double>{10.0} : std::vector<double>{10.0, 100.0};
  const double K = broadphase::modelCostRatio();
  ReportFile csvFile(dir / "model.csv");
  std::ofstream& csv = csvFile.stream();
  csv << kModelColumns << "\n";
  markdown += fmt::format(
      "## Cost model against measurement: Top-Down, Bottom-Up and linked cell across alpha and omega "
      "(Krijgsman, Ogarko & Luding 2014; Ogarko's thesis §2.2.5)\n\n"
      "Power-law size distributions f(r) ~ r^alpha on [r_min, omega r_min], N = {}, packing {}, skin 0.1 r_min,\n"
      "periodic. For each mode the optimiser's best L and sizes (eq. 2.35 minimised, K = {:.3f} from the\n"
      "calibration micro-benchmark); the seed's recommendation 3 (constant particles per cell, Top-Down) at its\n"
      "best L; linked cell where the model predicts under 3000 tests per particle. Model T/N = T_cd + K T_ca;\n"
      "counted = the same sum from the grid's own counters on this packing; time = build + findPairs, median of {}.\n\n"
      "| alpha | omega | method | L | model T/N | counted T/N | us/particle | predicted / measured BU:TD | picked by "
      "model | fastest measured |\n"
      "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n",
      count, packing, K, opt.repeat);
  for (double omega : omegas) {
    for (double alpha : alphas) {
      DistributionSpec spec;
      spec.kind = "power-law";
      spec.alpha = alpha;
      spec.omega = omega;
      const BenchScene scene = makeBenchScene(opt, spec, count, packing, 8);
      const SphereView spheres{scene.config.position, scene.config.radius};
      const double skin = 0.1 * scene.config.radius.minCoeff();
      std::vector<double> radii(scene.config.radius.data(), scene.config.radius.data() + count);
      const auto psd = broadphase::CostModelPsd::sample(radii, scene.config.box.volume(), skin);
      broadphase::OptimiserOptions oo;
      oo.K = K;
      oo.maxLevels = 20;
      const broadphase::OptimiserResult best = broadphase::optimiseHGrid(psd, oo);
      struct Method {
        std::string name;
        broadphase::CrossLevel mode;
        std::vector<double> sizes;
        double predicted;
      };
      std::vector<Method> methods;
      auto bestOf = [&](auto pick) {
        int bestL = 1;
        double bestT = std::numeric_limits<double>::infinity();
        for (const auto& row : best.table) {
          const double t = pick(row).predicted;
          if (t < bestT * (1.0 - oo.tolerance)) {
            bestT = t;
            bestL = row.levels;
          }
        }
        return std::make_pair(bestL, pick(best.table[static_cast<std::size_t>(bestL - 1)]));
      };
      const auto [ltd, td] = bestOf([](const broadphase::LevelsRow& r) { return r.topDown; });
      const auto [lbu, bu] = bestOf([](const broadphase::LevelsRow& r) { return r.bottomUp; });
      const auto [lcm, cm] = bestOf([](const broadphase::LevelsRow& r) { return r.constantMTopDown; });
      methods.push_back({fmt::format("top-down optimal"), broadphase::CrossLevel::TopDown, td.cellSizes, td.predicted});
      methods.push_back(
          {fmt::format("bottom-up optimal"), broadphase::CrossLevel::BottomUp, bu.cellSizes, bu.predicted});
      methods.push_back(
          {fmt::format("top-down constant m"), broadphase::CrossLevel::TopDown, cm.cellSizes, cm.predicted});
      const double lcModel = best.table.front().topDown.predicted;
      if (lcModel < 3000.0) {
        methods.push_back({"linked cell", broadphase::CrossLevel::TopDown, {psd.maxDiameter()}, lcModel});
      }
      const int levelsOf[] = {ltd, lbu, lcm, 1};
      std::vector<double> times;
      std::string fastest;
      double fastestTime = std::numeric_limits<double>::infinity();
      double tdTime = 0.0, buTime = 0.0;
      std::vector<std::string> rows;
      for (std::size_t k = 0; k < methods.size(); ++k) {
        const Method& m = methods[k];
        // Linked cell as a one-level grid of the largest diameter: the same counters as the model's L = 1.
        std::unique_ptr<broadphase::BroadPhase> bp = gridWith(m.mode, m.sizes);
        const Timed t = timeBackend(*bp, spheres, scene.config.box, skin, opt.repeat);
        const auto geometry = broadphase::snappedGeometry(m.sizes, scene.config.box.lengths());
        const auto breakdown = broadphase::costBreakdown(psd, geometry, m.mode);
        const double counted = (static_cast<double>(t.pairTests) + K * static_cast<double>(t.cellAccesses)) / count;
        std::string sizes;
        for (double sz : m.sizes) sizes += fmt::format("{}{:.4g}", sizes.empty() ? "" : ";", sz);
        csv << fmt::format("{},{},{},{:.4f},\"{}\",{},{},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.5f},{:.3f},{}\n",
                           alpha, omega, count, scene.packing, scene.placement, m.name, levelsOf[k], m.predicted,
                           breakdown.pairTests, breakdown.cellAccesses, static_cast<double>(t.pairTests) / count,
                           static_cast<double>(t.cellAccesses) / count, counted, 1e6 * t.seconds / count, t.spread,
                           sizes);
        summary().appendRow(
            "tables.model", kModelColumns,
            {cell(alpha), cell(omega), cell(count), cell(scene.packing), cell(scene.placement), cell(m.name),
             cell(levelsOf[k]), cell(m.predicted), cell(breakdown.pairTests), cell(breakdown.cellAccesses),
             cell(static_cast<double>(t.pairTests) / count), cell(static_cast<double>(t.cellAccesses) / count),
             cell(counted), cell(1e6 * t.seconds / count), cell(t.spread), cell(sizes)});
        if (k == 0) tdTime = t.seconds;
        if (k == 1) buTime = t.seconds;
        if (t.seconds < fastestTime) {
          fastestTime = t.seconds;
          fastest = fmt::format("{} (L = {})", m.name, levelsOf[k]);
        }
        rows.push_back(fmt::format("| {:g} | {:g} | {} | {} | {:.2f} | {:.2f} | {:.4f} |", alpha, omega, m.name,
                                   levelsOf[k], m.predicted, counted, 1e6 * t.seconds / count));
        fmt::print("  alpha {:g} omega {:g} {:<20} L = {:2d}: model {:.2f}, counted {:.2f}, {:.4f} us/particle\n",
                   alpha, omega, m.name, levelsOf[k], m.predicted, counted, 1e6 * t.seconds / count);
      }
      const std::string pick =
          best.chosen.linkedCell
              ? std::string("linked cell")
              : fmt::format("{} (L = {})",
                            best.chosen.config.mode == broadphase::CrossLevel::TopDown ? "top-down" : "bottom-up",
                            best.chosen.levels);
      for (std::size_t k = 0; k < rows.size(); ++k) {
        markdown += rows[k];
        if (k == 0) {
          markdown += fmt::format(" {:.2f} / {:.2f} | {} | {} |\n", bu.predicted / td.predicted, buTime / tdTime, pick,
                                  fastest);
        } else {
          markdown += " | | |\n";
        }
      }
    }
  }
  csvFile.commit();
  markdown += plotModel(dir);
  return 0;
}

}  // namespace polydem::app::bench
