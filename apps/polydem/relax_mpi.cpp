// polydem relax on several MPI ranks (docs/parallel.md): the StepDriver that runs the time loop's steps in a
// parallel::DistributedDem. Rank 0 runs runScene() as in a serial run (every output, check message and
// report comes from its DemSimulation, brought up to the distributed state by a gather before it is read);
// the other ranks serve rank 0's commands (advance n steps, gather, stop) until the loop ends. Only rank 0
// decides (output intervals, wall-clock checkpoints), so the ranks cannot disagree about what happens when.
#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <numeric>

#include "apps/polydem/relax.hpp"
#include "apps/polydem/summary.hpp"
#include "core/errors.hpp"
#include "parallel/distributed_dem.hpp"
#include "parallel/mpi_session.hpp"

namespace polydem::app {

namespace {

struct Spread {
  double min = 0.0, mean = 0.0, max = 0.0;
};

template <class Field>
Spread spread(const std::vector<parallel::RankStats>& ranks, Field field) {
  Spread s{field(ranks.front()), 0.0, field(ranks.front())};
  for (const parallel::RankStats& r : ranks) {
    const double v = field(r);
    s.min = std::min(s.min, v);
    s.max = std::max(s.max, v);
    s.mean += v;
  }
  s.mean /= static_cast<double>(ranks.size());
  return s;
}

/// Rank 0: run `f`; a collective error means the followers are no longer waiting for commands.
template <class F>
void collective(F f) {
  try {
    f();
  } catch (const parallel::CollectiveError&) {
    parallel::setFollowersWaiting(false);
    throw;
  } catch (const std::exception& e) {
    parallel::rankFailure(e.what(), 1);  // rank 0 alone: the others wait in a collective
  }
}

void command(parallel::Command::Op op, std::int64_t value) {
  parallel::Command c{op, value};
  parallel::broadcast(c);
}

enum class Served { Next, Stop, Unknown };

/// Ranks > 0: do rank 0's commands through `serve(command)` until it answers Stop; Fail and unknown commands
/// end the process here.
template <class Serve>
void serveCommands(Serve serve) {
  try {
    for (;;) {
      parallel::Command c;
      parallel::broadcast(c);
      if (c.op == parallel::Command::Fail) parallel::exitFollower(static_cast<int>(c.value));
      const Served s = serve(c);
      if (s == Served::Stop) return;
      if (s == Served::Unknown) parallel::rankFailure(fmt::format("unknown command {} from rank 0", c.op), 1);
    }
  } catch (const parallel::CollectiveError&) {
    throw;  // every rank throws it; rank 0 reports it
  } catch (const std::exception& e) {
    parallel::rankFailure(e.what(), 1);
  }
}

class MpiDriver final : public StepDriver {
 public:
  MpiDriver(const integrators::DemSimulation& sim, parallel::DecompositionKind kind)
      : dem_(sim.state(), sim.settings(), kind) {
    start_ = dem_.stats();
    if (root()) parallel::setFollowersWaiting(true);
  }

  bool root() const override { return parallel::isRoot(); }

  std::int64_t advance(std::int64_t steps) override {
    command(parallel::Command::Advance, steps);
    collective([&] { dem_.advance(steps, true); });
    return dem_.step();
  }

  bool interrupted() const override { return dem_.interrupted(); }

  void sync(integrators::DemSimulation& sim) override {
    command(parallel::Command::Sync, 0);
    integrators::DemState state;
    collective([&] { state = dem_.gather(); });
    sim = integrators::DemSimulation::restore(state, sim.settings());
  }

  void finish() override {
    command(parallel::Command::Stop, 0);
    parallel::setFollowersWaiting(false);
    end_ = dem_.stats();
  }

  std::int64_t resorts() const override { return end_.resorts; }

  integrators::PhaseTimes phaseTimes() const override {
    const auto mean = [&](double parallel::RankStats::*seconds) {
      return spread(end_.ranks, [&](const parallel::RankStats& r) { return r.*seconds; }).mean;
    };
    integrators::PhaseTimes t;
    t.broadPhase = mean(&parallel::RankStats::buildSeconds);
    t.force = mean(&parallel::RankStats::forceSeconds);
    t.integration = mean(&parallel::RankStats::integrationSeconds);
    t.check = mean(&parallel::RankStats::checkSeconds);
    return t;
  }

  void printStart() const override {
    fmt::print("parallel: {} MPI ranks, {}; {}\n", parallel::size(), start_.decomposition, ghostsText(start_));
  }

  void printReport() const override {
    const auto& ranks = end_.ranks;
    const Spread owned = spread(ranks, [](const parallel::RankStats& r) { return r.owned; });
    const Spread ghosts = spread(ranks, [](const parallel::RankStats& r) { return r.ghosts; });
    const Spread bytes = spread(ranks, [](const parallel::RankStats& r) { return r.ghostBytesPerStep; });
    const Spread comm = spread(ranks, [](const parallel::RankStats& r) { return r.commSeconds; });
    const Spread loop = spread(ranks, [](const parallel::RankStats& r) { return r.loopSeconds; });
    const Spread cost = spread(ranks, [](const parallel::RankStats& r) { return r.cost; });
    double migrated = 0.0;
    for (const parallel::RankStats& r : ranks) migrated += r.migrated;
    fmt::print("\n--- parallel ({} MPI ranks, {} at the end, {} rebalances) ---\n", ranks.size(), end_.decomposition,
               end_.rebalances);
    fmt::print("owned per rank        min {:.0f}, mean {:.1f}, max {:.0f}: imbalance max / mean {:.3f}\n", owned.min,
               owned.mean, owned.max, owned.max / std::max(owned.mean, 1.0));
    if (cost.mean > 0.0) {
      fmt::print("cost per rank         particles + candidate pairs at the last build: max / mean {:.3f}\n",
                 cost.max / cost.mean);
    }
    const Spread coarse = spread(ranks, [](const parallel::RankStats& r) { return r.coarseGhosts; });
    fmt::print("ghosts per rank       {}\n", ghostsText(end_));
    fmt::print(
        "ghost rule            the reach field keeps {:.1f} of the {:.1f} ghosts per rank (mean) that the "
        "distance to the region (r_j + r_max + skin) alone would copy\n",
        ghosts.mean, coarse.mean);
    fmt::print("ghost updates         {:.0f} bytes per step per rank (mean; max {:.0f})\n", bytes.mean, bytes.max);
    fmt::print("migrations            {:.0f} particles moved between ranks at neighbour-list builds\n", migrated);
    fmt::print(
        "communication         {:.3f} s per rank (mean; max {:.3f}) of {:.3f} s in the loop (max), gathers to "
        "rank 0 included\n",
        comm.mean, comm.max, loop.max);
    // The loop by phase on each rank: the reduction and the ghost updates are where a rank waits for the others.
    struct Phase {
      const char* label;
      const char* key;
      double parallel::RankStats::*seconds;
    };
    constexpr Phase phases[] = {{"kicks and drift", "integration", &parallel::RankStats::integrationSeconds},
                                {"step reduction", "reduction", &parallel::RankStats::reductionSeconds},
                                {"builds", "build", &parallel::RankStats::buildSeconds},
                                {"ghost updates", "ghost_update", &parallel::RankStats::ghostSeconds},
                                {"forces", "force", &parallel::RankStats::forceSeconds},
                                {"checks", "check", &parallel::RankStats::checkSeconds}};
    std::string line;
    SummaryJson& sum = summary();
    for (const Phase& p : phases) {
      const Spread s = spread(ranks, [&](const parallel::RankStats& r) { return r.*(p.seconds); });
      line += fmt::format("{}{} {:.3f} ({:.3f})", line.empty() ? "" : ", ", p.label, s.mean, s.max);
      sum.put(fmt::format("parallel.phase_seconds.{}_mean", p.key), s.mean);
      sum.put(fmt::format("parallel.phase_seconds.{}_max", p.key), s.max);
    }
    fmt::print("phases per rank       s, mean (max): {}\n", line);
    sum.put("parallel.ranks", static_cast<std::int64_t>(ranks.size()));
    sum.put("parallel.decomposition", end_.decomposition);
    sum.put("parallel.rebalances", end_.rebalances);
    sum.put("parallel.owned_max", owned.max);
    sum.put("parallel.owned_mean", owned.mean);
    sum.put("parallel.ghosts_max", ghosts.max);
    sum.put("parallel.ghosts_mean", ghosts.mean);
    sum.put("parallel.ghosts_distance_rule_mean", coarse.mean);
    sum.put("parallel.ghost_bytes_per_step_max", bytes.max);
    sum.put("parallel.migrated", migrated);
    sum.put("parallel.comm_seconds_max", comm.max);
  }

  RunSummary serve() override {
    serveCommands([&](const parallel::Command& c) {
      switch (c.op) {
        case parallel::Command::Advance:
          dem_.advance(c.value, true);
          return Served::Next;
        case parallel::Command::Sync:
          dem_.gather();
          return Served::Next;
        case parallel::Command::Stop:
          dem_.stats();
          return Served::Stop;
        default:
          return Served::Unknown;
      }
    });
    RunSummary s;
    s.interrupted = dem_.interrupted();
    return s;
  }

 private:
  static std::string ghostsText(const parallel::ParallelStats& s) {
    if (s.ranks.empty()) return {};
    const Spread owned = spread(s.ranks, [](const parallel::RankStats& r) { return r.owned; });
    const Spread ghosts = spread(s.ranks, [](const parallel::RankStats& r) { return r.ghosts; });
    return fmt::format(
        "ghosts per rank min {:.0f}, mean {:.1f}, max {:.0f} ({:.3f} per owned particle); owned per "
        "rank min {:.0f}, max {:.0f}",
        ghosts.min, ghosts.mean, ghosts.max, ghosts.mean / std::max(owned.mean, 1.0), owned.min, owned.max);
  }

  parallel::DistributedDem dem_;
  parallel::ParallelStats start_, end_;
};

/// A soft compression's steps on the ranks (integrators::CompressionEngine): rank 0 runs compressStart() with
/// this engine, every call a command its followers serve in serve() until finish().
class MpiCompression final : public integrators::CompressionEngine {
 public:
  MpiCompression(const integrators::DemSimulation& sim, parallel::DecompositionKind kind)
      : dem_(sim.state(), sim.settings(), kind) {
    if (parallel::isRoot()) parallel::setFollowersWaiting(true);
  }

  void advance(std::int64_t steps) override {
    command(parallel::Command::Advance, steps);
    collective([&] { dem_.advance(steps, false); });
  }
  void growRadii(double factor) override {
    command(parallel::Command::GrowRadii, std::bit_cast<std::int64_t>(factor));
    collective([&] { dem_.growRadii(factor); });
  }
  double maxOverlapRatio() override {
    command(parallel::Command::MaxOverlap, 0);
    double r = 0.0;
    collective([&] { r = dem_.maxOverlapRatio(); });
    return r;
  }
  void sync(integrators::DemSimulation& sim) override {
    command(parallel::Command::Sync, 0);
    integrators::DemState state;
    collective([&] { state = dem_.gather(); });
    sim = integrators::DemSimulation::restore(state, sim.settings());
  }
  void finish() {
    command(parallel::Command::Stop, 0);
    parallel::setFollowersWaiting(false);
  }
  /// Ranks > 0: serve until rank 0's finish().
  void serve() {
    serveCommands([&](const parallel::Command& c) {
      switch (c.op) {
        case parallel::Command::Advance:
          dem_.advance(c.value, false);
          return Served::Next;
        case parallel::Command::GrowRadii:
          dem_.growRadii(std::bit_cast<double>(c.value));
          return Served::Next;
        case parallel::Command::MaxOverlap:
          dem_.maxOverlapRatio();
          return Served::Next;
        case parallel::Command::Sync:
          dem_.gather();
          return Served::Next;
        case parallel::Command::Stop:
          return Served::Stop;
        default:
          return Served::Unknown;
      }
    });
  }

 private:
  parallel::DistributedDem dem_;
};

parallel::DecompositionKind decompositionKind(const std::string& decomposition) {
  if (decomposition != "rcb" && decomposition != "brick") {
    throw ConfigError(fmt::format("--decomposition {}: expected rcb or brick", decomposition));
  }
  return decomposition == "brick" ? parallel::DecompositionKind::Brick : parallel::DecompositionKind::Bisection;
}

}  // namespace

bool severalRanks() { return parallel::size() > 1; }

void compressOnRanks(const RelaxScene& scene, integrators::SoftCompression& c, Start& start, const RunContext& run,
                     bool quiet, const std::string& decomposition) {
  MpiCompression engine(c.simulation(), decompositionKind(decomposition));
  c.runOn(&engine);
  if (parallel::isRoot()) {
    compressStart(scene, c, start, run, quiet, true);
    engine.finish();
  } else {
    engine.serve();
  }
  c.runOn(nullptr);
  // Every rank needs the compressed state for the run (each constructs the distributed run from it) and the
  // outcome: rank 0's, broadcast.
  std::int32_t outcome[2] = {start.targetNotReached ? 1 : 0, start.interrupted ? 1 : 0};
  parallel::broadcast(outcome, 2);
  if (!parallel::isRoot()) {
    start.particles = c.particles();
    start.box = c.simulation().box();
    if (outcome[0] != 0) start.targetNotReached = "(rank 0 reports it)";
    start.interrupted = outcome[1] != 0;
  }
  ParticleStore& p = start.particles;  // every array, so that every rank holds rank 0's store byte for byte
  auto all = [](auto& a) { parallel::broadcast(a.data(), static_cast<std::size_t>(a.size())); };
  all(p.position());
  all(p.velocity());
  all(p.force());
  all(p.radius());
  all(p.inverseMass());
  all(p.id());
  if (p.features().rotation) {
    all(p.angularVelocity());
    all(p.torque());
    all(p.inverseInertia());
  }
}

std::unique_ptr<StepDriver> makeStepDriver(const integrators::DemSimulation& sim, const std::string& decomposition) {
  return std::make_unique<MpiDriver>(sim, decompositionKind(decomposition));
}

void requireParallelSupport(bool sweep) {
  const int ranks = parallel::size();
  if (sweep) {
    throw ConfigError(fmt::format(
        "relax --sweep runs on one process (it reruns the scene per setting); run it without mpirun ({} ranks given)",
        ranks));
  }
}

}  // namespace polydem::app
