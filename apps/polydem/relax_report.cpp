// polydem relax: what is printed before the time loop and the closing report.
#include <fmt/format.h>
#include <sys/resource.h>

#include <algorithm>
#include <cmath>

#include "apps/polydem/relax.hpp"
#include "apps/polydem/summary.hpp"
#include "core/huge_pages.hpp"
#include "core/interrupt.hpp"

namespace polydem::app {

namespace {

double peakMemoryMiB() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // Linux: KiB
}

double toMiB(std::size_t bytes) { return static_cast<double>(bytes) / (1024.0 * 1024.0); }

}  // namespace

void printStart(const RelaxScene& scene, const integrators::DemSimulation& sim, const RunContext& run, bool resumed) {
  const Index n = sim.particles().count();
  const contact::ContactStats s0 = sim.contactStats();
  fmt::print("particles: {} ({}), box {}, packing fraction {:.4f}\n", n, run.origin, sim.box().describe(),
             sim.packingFraction());
  fmt::print("contact: {}; kernel {}{}\n", sim.model().parameters().describe(), sim.kernel().name,
             scene.dem.threads > 1 ? fmt::format(", {} OpenMP threads", scene.dem.threads) : std::string(", serial"));
  fmt::print("time step: {}\n", sim.timeStepChoice().describe());
  fmt::print("broad phase: {} (skin {:.4g}, rebuilt when a particle moved skin/2)\n",
             sim.neighbours().backend().describe(), sim.neighbours().skin());
  if (resumed) {
    fmt::print("resumed at step {}: {} contacts, max overlap / r {:.4g}, total energy {:.6g} J (step 0: {:.6g} J)\n",
               sim.step(), s0.contacts, s0.maxOverlapRatio, sim.energies().total(), sim.initialEnergy());
  } else {
    fmt::print("start: {} contacts, max overlap / r {:.4g}, total energy {:.6g} J\n", s0.contacts, s0.maxOverlapRatio,
               sim.initialEnergy());
  }
  SummaryJson& sum = summary();
  sum.put("start.particles", static_cast<std::int64_t>(n));
  sum.put("start.origin", run.origin);
  sum.put("start.box", sim.box().describe());
  sum.put("start.packing_fraction", sim.packingFraction());
  sum.put("start.resumed_at_step", resumed ? sim.step() : std::int64_t{0});
  sum.put("start.contacts", static_cast<std::int64_t>(s0.contacts));
  sum.put("start.max_overlap_ratio", s0.maxOverlapRatio);
  sum.put("start.total_energy", sim.initialEnergy());
  sum.put("model.contact", sim.model().parameters().describe());
  sum.put("model.kernel", std::string(sim.kernel().name));
  sum.put("model.threads", scene.dem.threads);
  sum.put("model.time_step", sim.timeStepChoice().describe());
  sum.put("model.broad_phase", sim.neighbours().backend().describe());
  sum.put("model.skin", sim.neighbours().skin());
}

void printReport(const RelaxScene& scene, const integrators::DemSimulation& sim, const RunContext& run,
                 const LoopTiming& timing, const std::optional<std::string>& targetNotReached) {
  const contact::ContactStats c = sim.contactStats();
  const integrators::PhaseTimes& t = timing.rankPhases ? *timing.rankPhases : sim.times();
  const std::int64_t stepsRun = timing.stepsRun;
  const double loopSeconds = timing.loopSeconds;
  const std::int64_t total = timing.totalSteps;
  const bool interrupted = timing.interrupted;
  const integrators::Energies e = sim.energies();
  const Index n = sim.particles().count();
  const double perParticleStep = 1e6 / (static_cast<double>(std::max<std::int64_t>(1, stepsRun)) * n);
  fmt::print("\n--- relax report ---\n");
  if (interrupted) {
    fmt::print("INTERRUPTED           by signal {} at step {} of {}\n", interruptSignal(), sim.step(), total);
  }
  fmt::print("steps                 {} (dt = {:.6g} s, simulated time {:.6g} s)\n", sim.step(), sim.dt(), sim.time());
  fmt::print("contacts              {} particle pairs, {} with walls: {:.3f} contacts per particle (z = 2 C / N)\n",
             c.contacts, c.wallContacts, 2.0 * static_cast<double>(c.contacts) / n);
  fmt::print("max overlap / radius  {:.4g}\n", c.maxOverlapRatio);
  fmt::print("energy (J)            kinetic {:.6g}, rotational {:.6g}, elastic {:.6g}, potential {:.6g}\n", e.kinetic,
             e.rotational, e.elastic, e.potential);
  const std::string relative =
      sim.initialEnergy() != 0.0
          ? fmt::format("relative change {:+.3e}", (e.total() - sim.initialEnergy()) / std::abs(sim.initialEnergy()))
          : std::string("relative change undefined: the start energy is 0");
  fmt::print("                      total {:.8g} (start {:.8g}, {})\n", e.total(), sim.initialEnergy(), relative);
  fmt::print(
      "time                  {:.4f} us/particle/step in the loop ({:.3f} s): broad phase {:.4f}, force {:.4f}, "
      "integration {:.4f}, checks {:.4f}{}\n",
      loopSeconds * perParticleStep, loopSeconds, t.broadPhase * perParticleStep, t.force * perParticleStep,
      t.integration * perParticleStep, t.check * perParticleStep,
      timing.rankPhases ? " (mean over the ranks; the rest in the parallel section)" : "");
  fmt::print("neighbour list        {} rebuilds, {} re-sorts, {} candidate pairs ({:.2f} per particle)\n",
             sim.rebuilds(), timing.resorts, sim.neighbours().list().pairCount(),
             static_cast<double>(sim.neighbours().list().pairCount()) / n);
  const std::optional<std::size_t> hugeBytes = residentHugePageBytes();
  fmt::print("memory                {:.1f} MiB held by the run ({:.0f} bytes/particle), peak RSS {:.1f} MiB{}\n",
             static_cast<double>(sim.memoryBytes()) / (1024.0 * 1024.0), static_cast<double>(sim.memoryBytes()) / n,
             peakMemoryMiB(),
             hugeBytes ? fmt::format(", {:.0f} MiB on huge pages ({:.0f} MiB advised)", toMiB(*hugeBytes),
                                     toMiB(sim.hugePageBytesAdvised()))
                       : std::string());
  if (targetNotReached) fmt::print("TARGET NOT REACHED    {}\n", *targetNotReached);
  SummaryJson& sum = summary();
  if (interrupted) sum.put("report.interrupted_by_signal", interruptSignal());
  if (targetNotReached) sum.put("report.target_not_reached", *targetNotReached);
  sum.put("report.steps", sim.step());
  sum.put("report.steps_run", stepsRun);
  sum.put("report.steps_requested", total);
  sum.put("report.dt", sim.dt());
  sum.put("report.simulated_time", sim.time());
  sum.put("report.contacts", static_cast<std::int64_t>(c.contacts));
  sum.put("report.wall_contacts", static_cast<std::int64_t>(c.wallContacts));
  sum.put("report.contacts_per_particle", 2.0 * static_cast<double>(c.contacts) / n);
  sum.put("report.max_overlap_ratio", c.maxOverlapRatio);
  sum.put("report.energy.kinetic", e.kinetic);
  sum.put("report.energy.rotational", e.rotational);
  sum.put("report.energy.elastic", e.elastic);
  sum.put("report.energy.potential", e.potential);
  sum.put("report.energy.total", e.total());
  sum.put("report.energy.start", sim.initialEnergy());
  if (sim.initialEnergy() != 0.0) {
    sum.put("report.energy.relative_change", (e.total() - sim.initialEnergy()) / std::abs(sim.initialEnergy()));
  } else {
    sum.undefined("report.energy.relative_change", "the start energy is 0");
  }
  sum.put("report.time.loop_seconds", loopSeconds);
  sum.put("report.time.us_per_particle_step", loopSeconds * perParticleStep);
  sum.put("report.time.broad_phase_seconds", t.broadPhase);
  sum.put("report.time.force_seconds", t.force);
  sum.put("report.time.integration_seconds", t.integration);
  sum.put("report.time.check_seconds", t.check);
  sum.put("report.neighbours.rebuilds", static_cast<std::int64_t>(sim.rebuilds()));
  sum.put("report.neighbours.resorts", timing.resorts);
  sum.put("report.neighbours.candidate_pairs", static_cast<std::int64_t>(sim.neighbours().list().pairCount()));
  sum.put("report.memory.bytes_held", static_cast<std::int64_t>(sim.memoryBytes()));
  sum.put("report.memory.peak_rss_mib", peakMemoryMiB());
  sum.put("report.memory.huge_pages_advised_mib", toMiB(sim.hugePageBytesAdvised()));
  if (hugeBytes) {
    sum.put("report.memory.huge_pages_mib", toMiB(*hugeBytes));
  } else {
    sum.undefined("report.memory.huge_pages_mib", "/proc/self/smaps_rollup is not readable here");
  }
  if (!scene.finalState.empty()) sum.put("outputs.final_state", scene.finalState);
  if (!scene.timeseries.empty()) sum.put("outputs.time_series", scene.timeseries);
  if (!scene.checkpoint.empty()) sum.put("outputs.checkpoint", scene.checkpoint);
  if (!scene.finalState.empty()) fmt::print("final state           {}\n", scene.finalState);
  if (!scene.timeseries.empty()) fmt::print("time series           {}\n", scene.timeseries);
  if (!run.checkpointNote.empty()) {
    fmt::print("checkpoint            {}\n", run.checkpointNote);
  } else if (!scene.checkpoint.empty()) {
    fmt::print("checkpoint            {} (step {}): continue with polydem relax --resume {}{}\n", scene.checkpoint,
               sim.step(), scene.checkpoint, interrupted ? "" : " --steps N");
  } else if (interrupted) {
    fmt::print("checkpoint            none (set output.checkpoint to make a run resumable)\n");
  }
}

}  // namespace polydem::app
