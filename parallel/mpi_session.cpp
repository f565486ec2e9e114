#include "parallel/mpi_session.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <mpi.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>

#include "core/errors.hpp"

namespace polydem::parallel {

namespace {
bool initialised = false;
int worldRank = 0;
int worldSize = 1;
int savedStderr = -1;
bool followersWaiting = false;
}  // namespace

bool launchedByMpi() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "PMI_RANK"}) {
    if (std::getenv(name) != nullptr) return true;
  }
  return false;
}

Session::Session(int& argc, char**& argv) {
  if (!launchedByMpi()) return;
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  initialised = true;
  MPI_Comm_rank(MPI_COMM_WORLD, &worldRank);
  MPI_Comm_size(MPI_COMM_WORLD, &worldSize);
  // Errors come back as codes here and become exceptions at the call: no silent MPI abort without a message.
  MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
  if (worldRank > 0) {
    std::fflush(stdout);
    std::fflush(stderr);
    savedStderr = ::dup(STDERR_FILENO);
    const int null = ::open("/dev/null", O_WRONLY);
    if (null >= 0) {
      ::dup2(null, STDOUT_FILENO);
      ::dup2(null, STDERR_FILENO);
      ::close(null);
    }
  }
}

Session::~Session() {
  if (initialised) MPI_Finalize();
  initialised = false;
}

int Session::finish(int code) {
  if (initialised && worldRank == 0 && followersWaiting) {
    Command c{Command::Fail, code == 0 ? 1 : code};
    broadcast(c);
    followersWaiting = false;
  }
  return code;
}

int size() { return worldSize; }
int rank() { return worldRank; }

void requireParallelSupport(const std::string& subcommand) {
  if (worldSize > 1 && subcommand != "relax" && subcommand != "minimise") {
    throw ConfigError(
        fmt::format("polydem {} runs on one process; under an MPI launcher with {} ranks only `polydem relax` and "
                    "`polydem minimise` are supported "
                    "(docs/parallel.md): run it without mpirun or with -np 1",
                    subcommand, worldSize));
  }
}

void rankFailure(const std::string& message, int code) {
  const std::string text = fmt::format("polydem: rank {} of {}: {}\n", worldRank, worldSize, message);
  const int fd = savedStderr >= 0 ? savedStderr : STDERR_FILENO;
  [[maybe_unused]] const ssize_t written = ::write(fd, text.data(), text.size());
  if (initialised) MPI_Abort(MPI_COMM_WORLD, code);
  std::_Exit(code);
}

void broadcast(Command& c) {
  std::int64_t buffer[2] = {c.op, c.value};
  MPI_Bcast(buffer, 2, MPI_INT64_T, 0, MPI_COMM_WORLD);
  c.op = buffer[0];
  c.value = buffer[1];
}

namespace {

template <class T>
void broadcastArray(T* values, std::size_t count, MPI_Datatype type) {
  // In pieces below INT_MAX elements (MPI counts are int).
  constexpr std::size_t kPiece = std::size_t{1} << 30;
  for (std::size_t done = 0; done < count; done += kPiece) {
    const int n = static_cast<int>(std::min(kPiece, count - done));
    if (MPI_Bcast(values + done, n, type, 0, MPI_COMM_WORLD) != MPI_SUCCESS) rankFailure("MPI_Bcast failed", 1);
  }
}

}  // namespace

void broadcast(double* values, std::size_t count) { broadcastArray(values, count, MPI_DOUBLE); }
void broadcast(std::int32_t* values, std::size_t count) { broadcastArray(values, count, MPI_INT32_T); }

void exitFollower(int code) {
  if (initialised) MPI_Finalize();
  initialised = false;
  std::exit(code);
}

void setFollowersWaiting(bool waiting) { followersWaiting = waiting; }

}  // namespace polydem::parallel
