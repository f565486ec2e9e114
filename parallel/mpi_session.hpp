#pragma once
// The MPI session of one polydem process (docs/parallel.md). MPI is initialised only when the process was
// started by an MPI launcher (mpirun, mpiexec, srun: their environment variables say so), so the same binary
// runs serially without mpirun and without any MPI call. Under a launcher, ranks other than 0 write nothing
// to stdout or stderr (rank 0 prints the reports and errors of the run) unless a rank fails on its own, which
// aborts the whole job with its message.
//
// Followers (ranks > 0) serve rank 0's commands during `polydem relax` (apps/polydem/relax_mpi.cpp). If
// rank 0 fails while they wait, finish() tells them its exit code, so every rank exits with the same code.
#include <cstddef>
#include <cstdint>
#include <string>

namespace polydem::parallel {

/// True when the environment says an MPI launcher started this process (OMPI_COMM_WORLD_SIZE, PMI_SIZE,
/// PMIX_RANK or PMI_RANK set).
bool launchedByMpi();

class Session {
 public:
  /// MPI_Init (threads: funneled) when launchedByMpi(); otherwise nothing. Rank > 0: stdout and stderr go
  /// to /dev/null (the original stderr is kept for rankFailure()).
  Session(int& argc, char**& argv);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;
  /// The process exit code after the command returned `code`: on rank 0, followers still waiting for
  /// commands are told to exit with `code`. Returns `code`.
  int finish(int code);
};

/// 1 without MPI.
int size();
/// 0 without MPI.
int rank();
inline bool isRoot() { return rank() == 0; }
/// More than one rank: the subcommand must support it (relax and minimise do). Throws ConfigError otherwise.
void requireParallelSupport(const std::string& subcommand);

/// A failure of this rank alone (the others cannot know it): print `message` on the original stderr with
/// the rank and abort the job with `code`.
[[noreturn]] void rankFailure(const std::string& message, int code);

/// Rank 0's command to its followers (apps/polydem/relax_mpi.cpp).
struct Command {
  enum Op : std::int64_t { Advance = 1, Sync = 2, Stop = 3, Fail = 4, GrowRadii = 5, MaxOverlap = 6 };
  std::int64_t op = 0;
  std::int64_t value = 0;  ///< steps (Advance), exit code (Fail), the factor's bits (GrowRadii)
};
/// Broadcast `c` from rank 0 (collective).
void broadcast(Command& c);
/// Broadcast `count` values from rank 0 (collective).
void broadcast(double* values, std::size_t count);
void broadcast(std::int32_t* values, std::size_t count);
/// A follower told by rank 0 to stop with `code` (rank 0 failed on its own): MPI_Finalize and exit.
[[noreturn]] void exitFollower(int code);
/// Followers are waiting for commands (set by rank 0 while it drives a run): finish() then sends Fail.
void setFollowersWaiting(bool waiting);

}  // namespace polydem::parallel
