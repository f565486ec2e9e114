#include "apps/polydem/minimise_mpi.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/errors.hpp"
#include "parallel/distributed_fire.hpp"
#include "parallel/mpi_session.hpp"

namespace polydem::app {

namespace {

void printParallel(const char* when, const parallel::ParallelStats& s) {
  if (s.ranks.empty()) return;
  double ghosts = 0.0, owned = 0.0, comm = 0.0, migrated = 0.0;
  double most = 0.0, least = s.ranks.front().owned;
  for (const parallel::RankStats& r : s.ranks) {
    ghosts += r.ghosts;
    owned += r.owned;
    comm = std::max(comm, r.commSeconds);
    migrated += r.migrated;
    most = std::max(most, r.owned);
    least = std::min(least, r.owned);
  }
  const auto P = static_cast<double>(s.ranks.size());
  fmt::print(
      "parallel ({}) {} MPI ranks, {}; ghosts per rank mean {:.1f} ({:.3f} per owned particle); owned per "
      "rank min {:.0f}, max {:.0f}; {:.0f} migrated, {} rebalances; MPI time max {:.2f} s\n",
      when, s.ranks.size(), s.decomposition, ghosts / P, ghosts / std::max(owned, 1.0), least, most, migrated,
      s.rebalances, comm);
}

/// Every rank's minimiser takes the distributed state (for the reports and the output, as a serial run's).
void adopt(integrators::FireMinimiser& m, parallel::DistributedFire& d, std::int64_t& evaluations) {
  const Eigen::Matrix3Xd x = d.positions();
  const Eigen::VectorXd r = d.radii();
  evaluations = d.forceEvaluations();
  printParallel("end", d.stats());
  m.adoptState(x, r);
}

void scaleToDeltaPhi(parallel::DistributedFire& d, double deltaPhi) {
  // As the serial command (minimise.cpp): phi + deltaPhi in (0, 1), checked there before the run.
  if (deltaPhi == 0.0) return;
  const double phi = d.packingFraction();
  d.scaleRadii(std::cbrt((phi + deltaPhi) / phi));
  fmt::print("delta phi               {:g}: phi {:.10f} -> {:.10f}\n", deltaPhi, phi, d.packingFraction());
}

}  // namespace

bool minimiseOnSeveralRanks() { return parallel::size() > 1; }
bool minimiseRoot() { return parallel::isRoot(); }

integrators::FireResult minimiseOnRanks(integrators::FireMinimiser& m, double deltaPhi,
                                        const integrators::FireMinimiser::Progress& progress,
                                        std::int64_t& evaluations) {
  parallel::DistributedFire d(m);
  printParallel("start", d.stats());
  scaleToDeltaPhi(d, deltaPhi);
  const integrators::FireResult r = d.minimise(progress, true);
  adopt(m, d, evaluations);
  return r;
}

integrators::PressureJammingResult jamOnRanks(integrators::FireMinimiser& m,
                                              const integrators::PressureJammingSettings& js,
                                              const integrators::JammingStepCallback& onStep,
                                              const integrators::FireMinimiser::Progress& progress,
                                              std::int64_t& evaluations) {
  parallel::DistributedFire d(m);
  printParallel("start", d.stats());
  const integrators::PressureJammingResult r = integrators::jamToPressure(d, js, onStep, progress, true);
  adopt(m, d, evaluations);
  return r;
}

}  // namespace polydem::app
