// polydem bench, suite backends.
#include "apps/polydem/bench_common.hpp"
#include "apps/polydem/summary.hpp"

namespace polydem::app::bench {

// The columns of backends.csv, also the table `tables.backends` of --summary-json.
constexpr const char* kBackendsColumns =
    "distribution,omega,packing,placement,backend,us_per_particle,spread,pairs,contacts,pair_tests_per_particle,cell_"
    "accesses_per_particle,bytes_per_particle,configuration";

int runBackends(const BenchOptions& opt, std::string& markdown, bool quick) {
  const std::filesystem::path dir = opt.out;
  ReportFile csvFile(dir / "backends.csv");
  std::ofstream& csv = csvFile.stream();
  csv << kBackendsColumns << "\n";
  const Index count = opt.count > 0 ? opt.count : (quick ? 4000 : 100000);
  std::vector<std::pair<std::string, double>> dists = {
      {"mono", 1.0}, {"bi", 10.0}, {"uniform-radius", 50.0}, {"uniform-volume", 10.0}, {"uniform-volume", 50.0}};
  std::vector<double> packings = quick ? std::vector<double>{0.3} : std::vector<double>{0.1, 0.4, 0.62};
  std::vector<std::string> names = broadphase::backendNames();
  names.push_back("auto");
  markdown += fmt::format(
      "## Broad phases side by side (N = {}, skin = 0.1 r_min, periodic, RSA configurations)\n\n"
      "Median of {} runs of build + findPairs, thread CPU time in microseconds per particle.\n\n| system | packing |",
      count, opt.repeat);
  for (const auto& n : names) markdown += " " + n + " |";
  markdown += "\n| --- | --- |";
  for (std::size_t k = 0; k < names.size(); ++k) markdown += " --- |";
  markdown += "\n";
  bool agree = true;
  ReportFile matrixFile(dir / "backends_matrix.dat");
  std::ofstream& matrix = matrixFile.stream();  // one row per system, one column per backend
  matrix << "system";
  int plotted = 0;
  for (const auto& n : names) {
    if (n == "brute" && count > 20000) continue;  // skipped below: an all-NaN column breaks the histogram
    matrix << " " << n;
    ++plotted;
  }
  matrix << "\n";
  std::vector<std::function<BenchScene()>> makers;
  if (!opt.inputs.empty()) {
    for (const std::string& file : opt.inputs) makers.push_back([file] { return sceneFromFile(file); });
  } else {
    for (const auto& [kind, omega] : dists) {
      for (double packing : packings) {
        makers.push_back([&opt, kind, omega, count, packing] {
          DistributionSpec spec;
          spec.kind = kind;
          spec.omega = omega;
          return makeBenchScene(opt, spec, count, packing, 2);
        });
      }
    }
  }
  for (const auto& make : makers) {
    {
      const BenchScene scene = make();
      const Index count = static_cast<Index>(scene.config.radius.size());
      const SphereView spheres{scene.config.position, scene.config.radius};
      const double skin = 0.1 * scene.config.radius.minCoeff();
      markdown += fmt::format("| {} | {:.2f} |", scene.label, scene.packing);
      std::string label = fmt::format("{}@{:.2f}", scene.label, scene.packing);
      for (char& ch : label) {
        if (ch == ' ') ch = '_';
      }
      matrix << '"' << label << '"';
      std::size_t reference = 0;
      bool first = true;
      for (const std::string& name : names) {
        if (name == "brute" && count > 20000) {
          markdown += " - |";
          continue;
        }
        auto bp = broadphase::makeBroadPhase(name);
        const Timed t = timeBackend(*bp, spheres, scene.config.box, skin, opt.repeat);
        if (first) reference = t.pairs;
        first = false;
        if (t.pairs != reference) {
          agree = false;
          fmt::print(stderr, "MISMATCH: {} reports {} pairs, expected {} on {} at {}\n", name, t.pairs, reference,
                     scene.label, scene.packing);
        }
        csv << fmt::format("{},{:.4g},{:.4f},{},{},{:.5f},{:.4f},{},{},{:.4f},{:.4f},{:.2f},\"{}\"\n", scene.label,
                           scene.config.radius.maxCoeff() / scene.config.radius.minCoeff(), scene.packing,
                           scene.placement, name, 1e6 * t.seconds / count, t.spread, t.pairs, t.contacts,
                           static_cast<double>(t.pairTests) / count, static_cast<double>(t.cellAccesses) / count,
                           static_cast<double>(t.bytes) / count, t.description);
        summary().appendRow(
            "tables.backends", kBackendsColumns,
            {cell(scene.label), cell(scene.config.radius.maxCoeff() / scene.config.radius.minCoeff()),
             cell(scene.packing), cell(scene.placement), cell(name), cell(1e6 * t.seconds / count), cell(t.spread),
             cell(t.pairs), cell(t.contacts), cell(static_cast<double>(t.pairTests) / count),
             cell(static_cast<double>(t.cellAccesses) / count), cell(static_cast<double>(t.bytes) / count),
             cell(t.description)});
        markdown += fmt::format(" {:.3f} |", 1e6 * t.seconds / count);
        matrix << fmt::format(" {:.5f}", 1e6 * t.seconds / count);
        fmt::print("  {:<28} {:.2f} {:<12} {:10.4f} us/particle  {:8} pairs  {:7.1f} B/particle\n", scene.label,
                   scene.packing, name, 1e6 * t.seconds / count, t.pairs, static_cast<double>(t.bytes) / count);
      }
      markdown += "\n";
      matrix << "\n";
    }
  }
  csvFile.commit();
  matrixFile.commit();
  ReportFile gpFile(dir / "backends.gp");
  std::ofstream& gp = gpFile.stream();
  gp << "set terminal png size 1200,650\nset output '" << (dir / "backends.png").string() << "'\n"
     << "set termoption noenhanced\nset style data histograms\nset style histogram clustered gap 1\nset style fill "
        "solid 0.8 border -1\n"
     << "set logscale y\nset ylabel 'microseconds per particle (build + findPairs)'\nset xtics rotate by -30\n"
     << "set key outside right\nset title 'Broad phases side by side (N = " << count << ")'\n"
     << "plot for [col=2:" << plotted + 1 << "] '" << (dir / "backends_matrix.dat").string()
     << "' using col:xtic(1) title columnheader\n";
  gpFile.commit();
  markdown += runGnuplot(dir / "backends.gp", dir / "backends.png") ? "![backends](backends.png)\n\n"
                                                                    : "(gnuplot failed: no plot)\n\n";
  markdown += fmt::format("\nAll backends report the same pair counts: {}\n\n", agree ? "yes" : "**NO**");
  summary().put("checks.backends_report_the_same_pairs", agree);
  return agree ? 0 : 1;
}

}  // namespace polydem::app::bench
