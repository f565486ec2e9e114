// polydem relax --sweep dt-factor=10,20,50 | skin=0.05,0.1: the same start run once per setting over the
// same simulated time; a table of error (integrators::convergenceError) against wall time, as CSV and,
// for dt-factor when gnuplot is installed, a PNG.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "apps/polydem/exit_codes.hpp"
#include "apps/polydem/relax.hpp"
#include "apps/polydem/summary.hpp"
#include "core/errors.hpp"
#include "core/io/attributes.hpp"
#include "core/io/safe_output.hpp"
#include "integrators/convergence.hpp"

namespace polydem::app {

namespace {

/// "--sweep NAME=v1,v2,...": strict numbers (no trailing characters, finite), dt-factor >= 5, skin >= 0.
std::vector<double> sweepValues(const std::string& what, const std::string& list) {
  std::vector<double> values;
  std::stringstream in(list);
  for (std::string item; std::getline(in, item, ',');) {
    const auto v = io::parseFiniteDouble(item);
    if (!v) {
      // Name the item; a NaN or infinity is described rather than echoed (reports never print nan).
      const double parsed = std::strtod(item.c_str(), nullptr);
      const bool nonFinite = !item.empty() && !std::isfinite(parsed);
      throw ConfigError(fmt::format("--sweep {}: {} is not a finite number", what,
                                    nonFinite ? fmt::format("value {} (not-a-number or infinite)", values.size() + 1)
                                              : fmt::format("'{}'", item)));
    }
    const double lo = what == "dt-factor" ? integrators::kMinStepsPerContact : 0.0;
    if (*v < lo)
      throw ConfigError(fmt::format("--sweep {}: {} is below the smallest allowed value {:g}", what, item, lo));
    values.push_back(*v);
  }
  if (values.empty() || list.empty() || list.back() == ',') {
    throw ConfigError(fmt::format("--sweep {}: give a comma-separated list of values, e.g. {}=10,20,50", what, what));
  }
  return values;
}

}  // namespace

SweepSpec parseSweep(const RelaxScene& scene, const std::string& spec) {
  const std::size_t eq = spec.find('=');
  if (eq == std::string::npos) throw ConfigError(fmt::format("--sweep '{}': expected dt-factor=... or skin=...", spec));
  SweepSpec sweep{spec.substr(0, eq), {}};
  if (sweep.what != "dt-factor" && sweep.what != "skin") {
    throw ConfigError(fmt::format("--sweep {}: only dt-factor and skin can be swept", sweep.what));
  }
  sweep.values = sweepValues(sweep.what, spec.substr(eq + 1));
  if (sweep.what == "dt-factor" && scene.dem.timeStep > 0.0) {
    throw ConfigError("--sweep dt-factor conflicts with run.dt");
  }
  std::sort(sweep.values.begin(), sweep.values.end());
  return sweep;
}

std::vector<SweepError> sweepErrors(const RelaxScene& scene, const SweepSpec& sweep, const Start& start,
                                    const std::vector<SweepRow>& rows) {
  // Error: energy drift for dissipation-free scenes, else distance to the finest setting (largest dt factor).
  const bool elastic = scene.dem.dissipationFree();
  const SweepRow& finest = sweep.what == "dt-factor" ? rows.back() : rows.front();
  const double rmin = start.particles.radius().minCoeff();
  const double n = static_cast<double>(start.particles.count());
  const integrators::RunEnd reference{finest.run.initialEnergy, finest.run.finalEnergy, finest.run.positions};
  std::vector<SweepError> out;
  for (const SweepRow& r : rows) {
    const integrators::ConvergenceError error = integrators::convergenceError(
        {r.run.initialEnergy, r.run.finalEnergy, r.run.positions}, reference, elastic, start.box, rmin);
    const double us = 1e6 * r.run.wallSeconds / (static_cast<double>(std::max<std::int64_t>(1, r.steps)) * n);
    out.push_back({error.energy, error.position, us});
  }
  return out;
}

std::vector<SweepRow> sweepRows(const RelaxScene& scene, const SweepSpec& sweep, const Start& start,
                                const RunContext& context, bool quiet) {
  const std::string& what = sweep.what;
  std::vector<SweepRow> rows;
  for (double v : sweep.values) {
    RelaxScene s = scene;
    if (what == "dt-factor") {
      s.dem.stepsPerContact = v;
      s.steps = integrators::stepsForSameTime(scene.steps, scene.dem.stepsPerContact, v);
    } else {
      s.dem.skin = v;
    }
    if (!quiet) fmt::print(stderr, "  sweep {} = {:g}: {} steps\n", what, v, s.steps);
    Start copy = start;
    rows.push_back({v, s.steps,
                    runScene(s, integrators::DemSimulation(std::move(copy.particles), copy.box, s.dem), context,
                             RunMode{.quiet = true, .brief = true})});
    if (rows.back().run.interrupted) break;
  }
  return rows;
}

namespace {

/// The table (stdout and CSV text) of `rows` against the reference run, by integrators::convergenceError.
std::string tabulate(const RelaxScene& scene, const SweepSpec& sweep, const Start& start,
                     const std::vector<SweepRow>& rows) {
  const bool elastic = scene.dem.dissipationFree();
  const std::vector<SweepError> errors = sweepErrors(scene, sweep, start, rows);
  std::string table = sweep.what + ",steps,wall_seconds,us_per_particle_step,energy_error,position_error\n";
  fmt::print("\n{:>10} {:>10} {:>12} {:>18} {:>16} {:>16}\n", sweep.what, "steps", "wall s", "us/particle/step",
             elastic ? "energy drift" : "energy vs finest", "max |dx| / r_min");
  std::vector<double> values, wall, perStep, energyError, positionError;
  std::vector<std::int64_t> steps;
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const SweepRow& r = rows[k];
    const SweepError& error = errors[k];
    const double us = error.usPerParticleStep;
    const std::string energyText = error.energy ? fmt::format("{:.4e}", *error.energy) : std::string("undefined");
    fmt::print("{:>10g} {:>10} {:>12.3f} {:>18.4f} {:>16} {:>16.4e}\n", r.value, r.steps, r.run.wallSeconds, us,
               energyText, error.position);
    table += fmt::format("{},{},{:.6g},{:.6g},{},{:.6e}\n", r.value, r.steps, r.run.wallSeconds, us,
                         error.energy ? fmt::format("{:.6e}", *error.energy) : std::string(""), error.position);
    values.push_back(r.value);
    steps.push_back(r.steps);
    wall.push_back(r.run.wallSeconds);
    perStep.push_back(us);
    energyError.push_back(error.energy ? *error.energy : std::nan(""));
    positionError.push_back(error.position);
  }
  SummaryJson& sum = summary();
  sum.put("sweep.key", sweep.what);
  sum.put("sweep.error_reference", elastic ? "energy drift" : "energy vs finest");
  sum.put("sweep.values", values);
  sum.put("sweep.steps", steps);
  sum.put("sweep.wall_seconds", wall);
  sum.put("sweep.us_per_particle_step", perStep);
  // An undefined energy error (a zero reference energy) makes the column undefined, never NaN.
  if (std::all_of(energyError.begin(), energyError.end(), [](double v) { return std::isfinite(v); })) {
    sum.put("sweep.energy_error", energyError);
  } else {
    sum.undefined("sweep.energy_error", "undefined for some rows: a zero reference energy");
  }
  sum.put("sweep.position_error", positionError);
  return table;
}

/// Error against wall time with gnuplot (when installed), written atomically.
void plot(const std::string& csvPath, const std::string& png, const std::string& script, bool elastic) {
  if (std::system("command -v gnuplot > /dev/null 2>&1") != 0) return;
  io::AtomicFile plot(png);
  std::string gp;
  gp += "set terminal pngcairo size 800,560\n";
  gp += "set output '" + plot.temporary().string() + "'\n";
  gp += "set datafile separator ','\n";
  gp += "set logscale xy\n";
  gp += "set xlabel 'wall time (s)'\n";
  gp += std::string("set ylabel '") + (elastic ? "relative energy drift" : "energy error vs finest dt") + "'\n";
  gp += "set title 'polydem relax: error against run time, labels = steps per contact'\n";
  gp += "set key off\n";
  gp += "plot '" + csvPath + "' every ::1 using 3:($5 > 0 ? $5 : 1/0) with linespoints pt 7, " +
        "'' every ::1 using 3:($5 > 0 ? $5 : 1/0):1 with labels offset 1.5,0.8\n";
  io::writeFileAtomically(script, gp);
  if (std::system(("gnuplot " + script).c_str()) == 0 && std::filesystem::exists(plot.temporary())) {
    plot.commit();
    fmt::print("plot: {}\n", png);
  }
}

}  // namespace

int runSweep(RelaxScene scene, const std::string& spec, bool quiet, const std::vector<std::filesystem::path>& inputs) {
  const SweepSpec sweep = parseSweep(scene, spec);
  const std::string& what = sweep.what;
  const std::string stem = scene.source.stem().string();
  const std::string csvPath = fmt::format("{}_sweep_{}.csv", stem, what);
  const std::string png = fmt::format("{}_sweep_{}.png", stem, what);
  const std::string script = fmt::format("{}_sweep_{}.gp", stem, what);
  scene.timeseries.clear();
  scene.snapshot.clear();
  scene.finalState.clear();
  scene.checkpoint.clear();
  checkOutputs(scene, inputs, {{csvPath, "--sweep table"}, {png, "--sweep plot"}, {script, "--sweep plot script"}});

  Start start = prepare(scene);
  RunContext context;
  context.attributes = start.attributes;
  context.origin = start.origin;
  if (scene.compression) {
    integrators::SoftCompression c(std::move(start.particles), start.box, scene.dem, *scene.compression);
    compressStart(scene, c, start, context, quiet, false);
    if (start.interrupted) return kExitInterrupted;
    if (start.targetNotReached) {
      fmt::print("TARGET NOT REACHED: {}; no sweep run\n", *start.targetNotReached);
      return kExitTargetNotReached;
    }
  }
  setVelocities(scene, start);
  const std::vector<SweepRow> rows = sweepRows(scene, sweep, start, context, quiet);
  if (rows.back().run.interrupted) {
    fmt::print("sweep interrupted at {} = {:g}: no table written\n", what, rows.back().value);
    return kExitInterrupted;
  }
  io::writeFileAtomically(csvPath, tabulate(scene, sweep, start, rows));
  fmt::print("table: {}\n", csvPath);
  if (what == "dt-factor") plot(csvPath, png, script, scene.dem.dissipationFree());
  return kExitOk;
}

}  // namespace polydem::app
