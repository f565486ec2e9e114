// polydem bench, suite scaling: cost per particle against N and against the size ratio.
#include "apps/polydem/bench_common.hpp"
#include "apps/polydem/summary.hpp"

namespace polydem::app::bench {

// The columns of scaling.csv, also the table `tables.scaling` of --summary-json.
constexpr const char* kScalingColumns =
    "series,distribution,omega,N,packing,backend,us_per_particle,spread,bytes_per_particle,ratio_to_mono_linked_cell";

int runScaling(const BenchOptions& opt, std::string& markdown, bool /*quick*/) {
  const std::filesystem::path dir = opt.out;
  ReportFile csvFile(dir / "scaling.csv");
  std::ofstream& csv = csvFile.stream();
  csv << kScalingColumns << "\n";
  const double packing = opt.packing > 0 ? opt.packing : 0.4;
  const std::vector<Index> sizes =
      opt.count > 0 ? std::vector<Index>{opt.count} : std::vector<Index>{10000, 100000, 1000000};
  markdown += fmt::format(
      "## Cost per particle against N (packing {}, skin 0.1 r_min)\n\n"
      "`auto` on uniform volume omega = 50 beside linked cell on the monodisperse system of the same N and\n"
      "packing fraction (median of {} runs of build + findPairs).\n\n"
      "| N | mono, linked-cell (us) | UV omega=50, auto (us) | ratio |\n| --- | --- | --- | --- |\n",
      packing, opt.repeat);
  for (Index n : sizes) {
    DistributionSpec mono;
    const BenchScene m = makeBenchScene(opt, mono, n, packing, 4);
    auto lc = broadphase::makeBroadPhase("linked-cell");
    const Timed tm = timeBackend(*lc, {m.config.position, m.config.radius}, m.config.box, 0.1, opt.repeat);
    DistributionSpec uv;
    uv.kind = "uniform-volume";
    uv.omega = 50;
    const BenchScene p = makeBenchScene(opt, uv, n, packing, 4);
    auto au = broadphase::makeBroadPhase("auto");
    const Timed tp = timeBackend(*au, {p.config.position, p.config.radius}, p.config.box, 0.1, opt.repeat);
    csv << fmt::format("N,mono,1,{},{:.3f},linked-cell,{:.5f},{:.3f},{:.1f},1\n", n, m.packing, 1e6 * tm.seconds / n,
                       tm.spread, static_cast<double>(tm.bytes) / n);
    summary().appendRow("tables.scaling", kScalingColumns,
                        {cell(std::string("N")), cell(std::string("mono")), cell(std::int64_t{1}), cell(n),
                         cell(m.packing), cell(std::string("linked-cell")), cell(1e6 * tm.seconds / n), cell(tm.spread),
                         cell(static_cast<double>(tm.bytes) / n), cell(std::int64_t{1})});
    csv << fmt::format("N,uniform-volume,50,{},{:.3f},auto,{:.5f},{:.3f},{:.1f},{:.4f}\n", n, p.packing,
                       1e6 * tp.seconds / n, tp.spread, static_cast<double>(tp.bytes) / n, tp.seconds / tm.seconds);
    summary().appendRow("tables.scaling", kScalingColumns,
                        {cell(std::string("N")), cell(std::string("uniform-volume")), cell(std::int64_t{50}), cell(n),
                         cell(p.packing), cell(std::string("auto")), cell(1e6 * tp.seconds / n), cell(tp.spread),
                         cell(static_cast<double>(tp.bytes) / n), cell(tp.seconds / tm.seconds)});
    markdown += fmt::format("| {} | {:.4f} | {:.4f} | {:.2f} |\n", n, 1e6 * tm.seconds / n, 1e6 * tp.seconds / n,
                            tp.seconds / tm.seconds);
    fmt::print("  N = {}: mono linked-cell {:.4f} us, UV50 auto {:.4f} us, ratio {:.2f}\n", n, 1e6 * tm.seconds / n,
               1e6 * tp.seconds / n, tp.seconds / tm.seconds);
  }
  const Index n = opt.count > 0 ? opt.count : 100000;
  markdown += fmt::format(
      "\n## Cost per particle against the size ratio (N = {}, packing {})\n\n"
      "| omega | UV auto (us) | mono linked-cell (us) | ratio | linked-cell on UV (us) |\n"
      "| --- | --- | --- | --- | --- |\n",
      n, packing);
  DistributionSpec mono;
  const BenchScene m = makeBenchScene(opt, mono, n, packing, 5);
  auto lc = broadphase::makeBroadPhase("linked-cell");
  const Timed tm = timeBackend(*lc, {m.config.position, m.config.radius}, m.config.box, 0.1, opt.repeat);
  for (double omega : {1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0}) {
    DistributionSpec uv;
    uv.kind = "uniform-volume";
    uv.omega = omega;
    const BenchScene p = makeBenchScene(opt, uv, n, packing, 5);
    const SphereView sp{p.config.position, p.config.radius};
    auto au = broadphase::makeBroadPhase("auto");
    const Timed tp = timeBackend(*au, sp, p.config.box, 0.1, opt.repeat);
    std::string lcText = "-";
    if (omega <= 20.0) {  // linked cell on wide distributions takes minutes
      auto lcp = broadphase::makeBroadPhase("linked-cell");
      lcText = fmt::format("{:.4f}", 1e6 * timeBackend(*lcp, sp, p.config.box, 0.1, 1).seconds / n);
    }
    csv << fmt::format("omega,uniform-volume,{},{},{:.3f},auto,{:.5f},{:.3f},{:.1f},{:.4f}\n", omega, n, p.packing,
                       1e6 * tp.seconds / n, tp.spread, static_cast<double>(tp.bytes) / n, tp.seconds / tm.seconds);
    summary().appendRow("tables.scaling", kScalingColumns,
                        {cell(std::string("omega")), cell(std::string("uniform-volume")), cell(omega), cell(n),
                         cell(p.packing), cell(std::string("auto")), cell(1e6 * tp.seconds / n), cell(tp.spread),
                         cell(static_cast<double>(tp.bytes) / n), cell(tp.seconds / tm.seconds)});
    markdown += fmt::format("| {:g}{} | {:.4f} | {:.4f} | {:.2f} | {} |\n", omega,
                            p.config.box.fullyPeriodic() ? "" : " (walls)", 1e6 * tp.seconds / n, 1e6 * tm.seconds / n,
                            tp.seconds / tm.seconds, lcText);
    fmt::print("  omega = {}: UV auto {:.4f} us, ratio to mono LC {:.2f}\n", omega, 1e6 * tp.seconds / n,
               tp.seconds / tm.seconds);
  }
  csvFile.commit();
  markdown += "\n";
  return 0;
}

}  // namespace polydem::app::bench
