#pragma once
// polydem minimise on several MPI ranks (docs/parallel.md): every rank reads the same start and constructs the
// same serial minimiser; the minimisation (or the pressure protocol) then runs on a parallel::DistributedFire,
// whose result is the serial one to the bit; the final state comes back to every rank's minimiser, from which
// rank 0 reports and writes as a serial run does (the other ranks print nothing).
#include <cstdint>

#include "integrators/fire_minimiser.hpp"
#include "integrators/pressure_jamming.hpp"
#include "polydem/mpi_config.hpp"

namespace polydem::app {

#if POLYDEM_WITH_MPI
/// Launched by mpirun with more than one rank.
bool minimiseOnSeveralRanks();
/// Collective: m.minimise() on the ranks; `m` takes the final state. `evaluations`: force evaluations so far.
integrators::FireResult minimiseOnRanks(integrators::FireMinimiser& m, double deltaPhi,
                                        const integrators::FireMinimiser::Progress& progress,
                                        std::int64_t& evaluations);
/// Collective: integrators::jamToPressure() on the ranks; `m` takes the final state.
integrators::PressureJammingResult jamOnRanks(integrators::FireMinimiser& m,
                                              const integrators::PressureJammingSettings& js,
                                              const integrators::JammingStepCallback& onStep,
                                              const integrators::FireMinimiser::Progress& progress,
                                              std::int64_t& evaluations);
/// Rank 0 (a serial run is rank 0).
bool minimiseRoot();
#else
inline bool minimiseOnSeveralRanks() { return false; }
inline bool minimiseRoot() { return true; }
#endif

}  // namespace polydem::app
