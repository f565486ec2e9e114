// polydem relax: what is printed before the time loop and the closing report.
#include <fmt/format.h>
#include <sys/resource.h>

#include <algorithm>
#include <cmath>

#include "apps/polydem/relax.hpp"
#include "core/interrupt.hpp"

namespace polydem::app {

namespace {

double peakMemoryMiB() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // Linux: KiB
}

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
}

void printReport(const RelaxScene& scene, const integrators::DemSimulation& sim, const RunContext& run,
                 const LoopTiming& timing, const std::optional<std::string>& targetNotReached) {
  const contact::ContactStats c = sim.contactStats();
  const integrators::PhaseTimes& t = sim.times();
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
      "integration {:.4f}, checks {:.4f}\n",
      loopSeconds * perParticleStep, loopSeconds, t.broadPhase * perParticleStep, t.force * perParticleStep,
      t.integration * perParticleStep, t.check * perParticleStep);
  fmt::print("neighbour list        {} rebuilds, {} candidate pairs ({:.2f} per particle)\n", sim.rebuilds(),
             sim.neighbours().list().pairCount(), static_cast<double>(sim.neighbours().list().pairCount()) / n);
  fmt::print("memory                {:.1f} MiB held by the run ({:.0f} bytes/particle), peak RSS {:.1f} MiB\n",
             static_cast<double>(sim.memoryBytes()) / (1024.0 * 1024.0), static_cast<double>(sim.memoryBytes()) / n,
             peakMemoryMiB());
  if (targetNotReached) fmt::print("TARGET NOT REACHED    {}\n", *targetNotReached);
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
