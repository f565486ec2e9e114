// polydem analyze: the jamming tests of a packing (jamming/): the ideal-contact LP test and the load test
// (--certify), and the pressure-leak test (--leak-test).
#include <fmt/format.h>

#include <algorithm>
#include <cstdio>

#include "apps/polydem/analyze.hpp"
#include "apps/polydem/summary.hpp"
#include "core/io/safe_output.hpp"
#include "jamming/ideal_contacts.hpp"
#include "jamming/load_protocols.hpp"
#include "jamming/pressure_leak.hpp"

namespace polydem::app::analyze {

namespace {

jamming::LoadTestOptions loadTestOptions(const AnalyzeOptions& opt) {
  jamming::LoadTestOptions loadOptions;
  loadOptions.gapTolerance = opt.loadGap;
  loadOptions.displacementLimit = opt.displacementLimit;
  loadOptions.loads = opt.loads;
  loadOptions.subpackingRounds = opt.subpackingRounds;
  loadOptions.protocol =
      opt.loadTest == "sequential" ? jamming::LoadProtocol::Sequential : jamming::LoadProtocol::SingleLp;
  loadOptions.beta = opt.beta;
  loadOptions.maxLimit = opt.maxLimit;
  loadOptions.meanLimit = opt.meanLimit;
  loadOptions.maxSteps = opt.maxSteps;
  loadOptions.localRattlers = !opt.noLocalRattlers;
  loadOptions.strict = opt.strict;
  loadOptions.progress = [](const std::string& line) {
    fmt::print("  load test: {}\n", line);
    std::fflush(stdout);
  };
  loadOptions.solver = opt.lpSolver == "simplex"    ? jamming::LpSolver::Simplex
                       : opt.lpSolver == "interior" ? jamming::LpSolver::InteriorPoint
                                                    : jamming::LpSolver::Automatic;
  if (opt.removeSphere >= 0) loadOptions.removed.push_back(opt.removeSphere);
  return loadOptions;
}

}  // namespace

void certifyJamming(const AnalyzeOptions& opt, const io::ParticleData& data, const jamming::ContactNetwork& net) {
  const SphereView spheres{data.position, data.radius};
  const Index n = data.count();
  jamming::ContactNetwork tested = net;
  if (opt.removeSphere >= 0) {
    // The sphere disappears from the test (no constraints from it); the rattlers stay those of the
    // intact packing, so its neighbours keep being tested.
    tested.rattler[static_cast<std::size_t>(opt.removeSphere)] = 1;
    fmt::print("removed sphere {} ({} contacts, {}) for the jamming test\n", opt.removeSphere,
               net.coordination[static_cast<std::size_t>(opt.removeSphere)],
               net.rattler[static_cast<std::size_t>(opt.removeSphere)] ? "a rattler" : "a backbone sphere");
  }
  if (!opt.skipIdeal) {
    const jamming::JammingTestResult ideal = jamming::testCollectiveJamming(spheres, data.box, tested);
    fmt::print("ideal-contact LP test   {} ({:.2f} s{})\n", ideal.verdict, ideal.seconds,
               ideal.lps > 0 ? fmt::format("; LP optima: opening {:.3g}, floppy {:.3g}", ideal.openingObjective,
                                           ideal.floppyObjective)
                             : std::string("; no LP solved"));
    std::fflush(stdout);
    SummaryJson& s = summary();
    s.put("certify.ideal_contacts.outcome", std::string(jamming::verdictName(ideal.outcome)));
    s.put("certify.ideal_contacts.verdict", ideal.verdict);
    s.put("certify.ideal_contacts.lps_solved", ideal.lps);
    if (ideal.lps > 0) {
      s.put("certify.ideal_contacts.opening_objective", ideal.openingObjective);
      s.put("certify.ideal_contacts.floppy_objective", ideal.floppyObjective);
    }
    s.put("certify.ideal_contacts.seconds", ideal.seconds);
  }
  const jamming::LoadTestOptions loadOptions = loadTestOptions(opt);
  const jamming::LoadTestResult load = jamming::testJammingUnderLoad(spheres, data.box, tested, loadOptions);
  const jamming::LoadTestSummary& jam = jamming::summaryOf(load);
  if (jam.solver.empty()) {
    fmt::print("jamming test (loads)    {} (no LP solved)\n", jam.verdict);
  } else {
    fmt::print("jamming test (loads)    {} ({} constraints with gap <= {:.2g} (r_i + r_j), {}, {:.2f} s)\n",
               jam.verdict, jam.constraints, loadOptions.gapTolerance, jam.solver, jam.seconds);
  }
  SummaryJson& s = summary();
  if (opt.removeSphere >= 0) s.put("certify.removed_sphere", static_cast<std::int64_t>(opt.removeSphere));
  s.put("certify.loads.protocol", opt.loadTest);
  s.put("certify.loads.outcome", std::string(jamming::verdictName(jam.outcome)));
  s.put("certify.loads.verdict", jam.verdict);
  s.put("certify.loads.largest_displacement", jam.largestDisplacement);
  s.put("certify.loads.displaced_spheres", static_cast<std::int64_t>(jam.displaced));
  s.put("certify.loads.constraints", static_cast<std::int64_t>(jam.constraints));
  s.put("certify.loads.gap_tolerance", loadOptions.gapTolerance);
  s.put("certify.loads.solver", jam.solver);
  s.put("certify.loads.local_rattlers", static_cast<std::int64_t>(jam.localRattlers));
  s.put("certify.loads.seconds", jam.seconds);
  if (!opt.motionCsv.empty()) {
    // Radius, contacts and rattler flag with the motion, so the moving spheres can be told apart.
    std::string text = "i,radius,contacts,rattler,dx,dy,dz,moved_over_diameter\n";
    for (Index i = 0; i < n; ++i) {
      const double r = spheres.radius[i];
      text += fmt::format("{},{:.10g},{},{},{:.10g},{:.10g},{:.10g},{:.6g}\n", i, r,
                          net.coordination[static_cast<std::size_t>(i)],
                          tested.rattler[static_cast<std::size_t>(i)] ? 1 : 0, jam.motion(0, i), jam.motion(1, i),
                          jam.motion(2, i), jam.motion.col(i).norm() / (2.0 * r));
    }
    io::writeFileAtomically(opt.motionCsv, text);
    fmt::print("wrote {}\n", opt.motionCsv);
  }
}

void runLeakTest(const AnalyzeOptions& opt, const io::ParticleData& data, const jamming::ContactNetwork& net) {
  // --remove takes the sphere out of the dynamics too: the hole is the deliberate defect.
  if (opt.removeSphere >= 0) {
    fmt::print("leak test without sphere {} (the last sphere takes its number)\n", opt.removeSphere);
  }
  jamming::LeakTestOptions leak;
  leak.collisionsPerParticle = opt.leakCollisions;
  leak.blocks = opt.leakBlocks;
  leak.pressureTolerance = opt.leakTolerance;
  leak.driftFactor = opt.leakDrift;
  leak.progress = [](const std::string& line) {
    fmt::print("  leak test: {}\n", line);
    std::fflush(stdout);
  };
  const jamming::LeakTestResult result =
      jamming::testPressureLeakWithout(data.position, data.radius, data.box, net.rattler, opt.removeSphere, leak);
  if (result.outcome == jamming::JammingVerdict::NotTested) {
    fmt::print("pressure-leak test      {}\n", result.verdict);
  } else {
    fmt::print("pressure-leak test      {} ({} collisions, {:.1f} s, {:.3g} collisions/s)\n", result.verdict,
               result.counts.collisions, result.seconds,
               static_cast<double>(result.counts.collisions) / std::max(result.seconds, 1e-9));
  }
  SummaryJson& s = summary();
  if (opt.removeSphere >= 0) s.put("leak_test.removed_sphere", static_cast<std::int64_t>(opt.removeSphere));
  s.put("leak_test.outcome", std::string(jamming::verdictName(result.outcome)));
  s.put("leak_test.verdict", result.verdict);
  s.put("leak_test.leaks", result.leaks);
  s.put("leak_test.pressure_change", result.pressureChange);
  s.put("leak_test.drift_ratio", result.driftRatio);
  s.put("leak_test.collisions", static_cast<std::int64_t>(result.counts.collisions));
  s.put("leak_test.seconds", result.seconds);
  std::vector<double> cpp, pressure, meanDisp, maxDisp;
  for (const jamming::LeakBlock& b : result.blocks) {
    cpp.push_back(b.collisionsPerParticle);
    pressure.push_back(b.pressure);
    meanDisp.push_back(b.meanDisplacement);
    maxDisp.push_back(b.maxDisplacement);
  }
  s.put("leak_test.blocks.collisions_per_particle", cpp);
  s.put("leak_test.blocks.reduced_pressure", pressure);
  s.put("leak_test.blocks.mean_displacement", meanDisp);
  s.put("leak_test.blocks.max_displacement", maxDisp);
}

}  // namespace polydem::app::analyze
