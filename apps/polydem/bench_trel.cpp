// polydem bench, suite trel: Ogarko's thesis Fig. 2.6, DEM time relative to the monodisperse system against N.
#include "apps/polydem/bench_common.hpp"
#include "apps/polydem/summary.hpp"

namespace polydem::app::bench {

// The columns of trel.csv, also the table `tables.trel` of --summary-json.
constexpr const char* kTrelColumns =
    "system,N,packing,placement,backend,broad_phase_choice,steps,us_per_particle_step,spread,t_rel,broad_phase_share,"
    "force_share,integration_share,rebuilds,pairs_per_particle,bytes_per_particle";

namespace {

struct DemCase {
  std::string label;
  std::string backend;
  std::unique_ptr<integrators::DemSimulation> sim;
  std::vector<double> cpu;  ///< CPU seconds per timed round
  integrators::PhaseTimes phases;
  std::int64_t timedSteps = 0;
  std::string placement;
  double packing = 0.0;
};

/// A DEM run of the seed's ch. 2.1.4 protocol on `scene`: linear elastic normal contacts (no friction, no
/// rotation), velocities such that two colliding smallest particles reach 1% overlap, dt = t_c,min / 50.
std::unique_ptr<integrators::DemSimulation> demOn(const BenchScene& scene, const std::string& backend) {
  const Index n = static_cast<Index>(scene.config.radius.size());
  ParticleStore particles(n, Features{});
  particles.position() = scene.config.position;
  particles.radius() = scene.config.radius;
  particles.setMassesFromDensity(1.0);
  integrators::DemSettings settings;
  settings.contact.stiffness = 1e4;
  settings.contact.restitution = 1.0;
  settings.broadPhase = backend;
  settings.stability.checkInterval = 0;  // timed rounds only; checked once at the end
  integrators::assignImpactVelocities(contact::ContactModel(settings.contact), particles, 0.01, 7);
  return std::make_unique<integrators::DemSimulation>(std::move(particles), scene.config.box, settings);
}

}  // namespace

namespace {

/// trel.gp and trel.png: T_rel against N per system; the Markdown line for the plot.
std::string plotRelativeTime(const std::filesystem::path& dir, double packing,
                             const std::map<std::string, std::vector<std::pair<Index, double>>>& trel) {
  ReportFile gpFile(dir / "trel.gp");
  std::ofstream& gp = gpFile.stream();
  gp << "set datafile separator ','\nset terminal png size 900,600\nset output '" << (dir / "trel.png").string()
     << "'\nset termoption noenhanced\nset logscale x\nset xlabel 'N'\nset ylabel 'T_rel = T / T(mono, linked cell)'\n"
     << "set key top left\nset yrange [0:*]\nset title 'DEM time relative to monodisperse (seed Fig. 2.6), packing "
     << packing << "'\nplot ";
  int k = 0;
  for (const auto& [label, values] : trel) {
    gp << (k ? ", " : "") << "'" << (dir / "trel.csv").string() << "' using (strcol(1) eq '" << label
       << "' ? $2 : 1/0):10 with linespoints lw 2 title '" << label << "'";
    ++k;
  }
  gp << "\n";
  gpFile.commit();
  return runGnuplot(dir / "trel.gp", dir / "trel.png") ? "\n![trel](trel.png)\n\n" : "\n(gnuplot failed: no plot)\n\n";
}

}  // namespace

int runRelativeTime(const BenchOptions& opt, std::string& markdown, bool quick) {
  const std::filesystem::path dir = opt.out;
  const double packing = opt.packing > 0 ? opt.packing : (quick ? 0.5 : 0.6);
  const std::vector<Index> counts =
      !opt.counts.empty() ? opt.counts
                          : (quick ? std::vector<Index>{2000, 5000} : std::vector<Index>{10000, 30000, 100000});
  const int steps = opt.steps > 0 ? opt.steps : (quick ? 40 : 200);
  const double equilibrate = opt.equilibrate >= 0.0 ? opt.equilibrate : (quick ? 2.0 : 20.0);
  struct System {
    std::string kind;
    double omega;
    std::string backend;
  };
  const std::vector<System> systems = {{"mono", 1.0, "linked-cell"},
                                       {"bi", 10.0, "auto"},
                                       {"uniform-volume", 10.0, "auto"},
                                       {"uniform-volume", 50.0, "auto"}};
  ReportFile csvFile(dir / "trel.csv");
  std::ofstream& csv = csvFile.stream();
  csv << kTrelColumns << "\n";
  markdown += fmt::format(
      "## DEM time relative to the monodisperse system against N (Ogarko & Luding 2012; Ogarko's thesis Fig. 2.6)\n\n"
      "Packing fraction {}, periodic (walls when the box cannot hold two cut-offs of the largest sphere). Every state\n"
      "(random sequential addition, event-driven compression where RSA stalls) is then relaxed by {:g} hard-sphere\n"
      "collisions per particle at fixed density, so all systems have the local structure of a fluid. Linear\n"
      "elastic contacts, 1% impact overlap of the smallest pair, dt = t_c,min / 50, Verlet skin 0.2 r_min.\n"
      "Each round advances every system {} steps, the systems taking turns (interleaved), {} rounds; thread CPU\n"
      "time, median over rounds. T_rel = time of the system / time of the monodisperse system of the same N\n"
      "(linked cell), same number of steps (the seed's definition). Bi: equal volumes of the two sizes, omega = 10\n"
      "(the seed: L = 2 with the two diameters; here `auto` chooses). The split is broad phase (neighbour-list\n"
      "rebuilds), force and integration as shares of the loop's wall time (CPU time is not split).\n\n"
      "| N | system | placement | broad phase | neighbour pairs / particle | us/particle/step | T_rel | broad phase / "
      "force / integration |\n"
      "| --- | --- | --- | --- | --- | --- | --- | --- |\n",
      packing, equilibrate, steps, opt.repeat);
  std::map<std::string, std::vector<std::pair<Index, double>>> trel;
  for (Index n : counts) {
    std::vector<DemCase> cases;
    for (const System& sys : systems) {
      DistributionSpec spec;
      spec.kind = sys.kind;
      spec.omega = sys.omega;
      Stopwatch prep;
      const BenchScene scene = makeBenchScene(opt, spec, n, packing, 6, equilibrate);
      DemCase c;
      c.label = scene.label;
      c.backend = sys.backend;
      c.placement = scene.placement;
      c.packing = scene.packing;
      c.sim = demOn(scene, sys.backend);
      c.sim->advance(std::max(10, steps / 4));  // warm up: contacts form, first rebuilds
      fmt::print("  N = {} {}: packing {:.3f} ({}), {} ({:.1f} s to prepare)\n", n, scene.label, scene.packing,
                 scene.placement, c.sim->neighbours().backend().describe(), prep.seconds());
      cases.push_back(std::move(c));
    }
    for (int round = 0; round < opt.repeat; ++round) {
      for (DemCase& c : cases) {
        const integrators::PhaseTimes before = c.sim->times();
        CpuStopwatch clock;
        c.sim->advance(steps);
        c.cpu.push_back(clock.seconds());
        const integrators::PhaseTimes& after = c.sim->times();
        c.phases.broadPhase += after.broadPhase - before.broadPhase;
        c.phases.force += after.force - before.force;
        c.phases.integration += after.integration - before.integration;
        c.timedSteps += steps;
      }
    }
    const double mono = median(cases.front().cpu);
    for (DemCase& c : cases) {
      c.sim->checkStability();
      const double t = median(c.cpu);
      // Shares of the phases' wall time: under load wall time includes waiting, CPU time is not split.
      const double phaseSum = std::max(1e-12, c.phases.broadPhase + c.phases.force + c.phases.integration);
      const double perStep = 100.0 / phaseSum;
      const double spread =
          (*std::max_element(c.cpu.begin(), c.cpu.end()) - *std::min_element(c.cpu.begin(), c.cpu.end())) / t;
      const std::string choice = c.sim->neighbours().backend().describe();
      csv << fmt::format(
          "\"{}\",{},{:.4f},\"{}\",{},\"{}\",{},{:.5f},{:.3f},{:.4f},{:.1f},{:.1f},{:.1f},{},{:.3f},{:.1f}\n", c.label,
          n, c.packing, c.placement, c.backend, choice, steps, 1e6 * t / (static_cast<double>(steps) * n), spread,
          t / mono, c.phases.broadPhase * perStep, c.phases.force * perStep, c.phases.integration * perStep,
          c.sim->rebuilds(), static_cast<double>(c.sim->neighbours().list().pairCount()) / n,
          static_cast<double>(c.sim->memoryBytes()) / n);
      summary().appendRow(
          "tables.trel", kTrelColumns,
          {cell(c.label), cell(n), cell(c.packing), cell(c.placement), cell(c.backend), cell(choice), cell(steps),
           cell(1e6 * t / (static_cast<double>(steps) * n)), cell(spread), cell(t / mono),
           cell(c.phases.broadPhase * perStep), cell(c.phases.force * perStep), cell(c.phases.integration * perStep),
           cell(c.sim->rebuilds()), cell(static_cast<double>(c.sim->neighbours().list().pairCount()) / n),
           cell(static_cast<double>(c.sim->memoryBytes()) / n)});
      // The table keeps the choice short ("auto -> hgrid-td L=4"); the CSV has the whole description.
      const std::string shortChoice = choice.substr(0, std::min(choice.find(" sizes"), choice.find(" cells of")));
      markdown +=
          fmt::format("| {} | {} | {} | {} | {:.2f} | {:.4f} | {:.2f} | {:.0f}% / {:.0f}% / {:.0f}% |\n", n, c.label,
                      c.placement, shortChoice, static_cast<double>(c.sim->neighbours().list().pairCount()) / n,
                      1e6 * t / (static_cast<double>(steps) * n), t / mono, c.phases.broadPhase * perStep,
                      c.phases.force * perStep, c.phases.integration * perStep);
      fmt::print("  N = {} {:<26} {:.4f} us/particle/step  T_rel {:.2f}  (bp {:.0f}%, force {:.0f}%, int {:.0f}%)\n", n,
                 c.label, 1e6 * t / (static_cast<double>(steps) * n), t / mono, c.phases.broadPhase * perStep,
                 c.phases.force * perStep, c.phases.integration * perStep);
      trel[c.label].push_back({n, t / mono});
    }
  }
  csvFile.commit();
  markdown += "\n| system | T_rel over N | max / min over N |\n| --- | --- | --- |\n";
  for (const auto& [label, values] : trel) {
    std::string list;
    double lo = std::numeric_limits<double>::infinity(), hi = 0.0;
    for (const auto& [n, v] : values) {
      list += fmt::format("{}{:.2f}", list.empty() ? "" : ", ", v);
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
    markdown += fmt::format("| {} | {} | {:.2f} |\n", label, list, hi / lo);
  }
  markdown += plotRelativeTime(dir, packing, trel);
  return 0;
}

}  // namespace polydem::app::bench
