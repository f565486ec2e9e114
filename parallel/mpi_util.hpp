#pragma once
// Small MPI helpers of the distributed engines (distributed_dem.cpp, distributed_fire.cpp, keyed_chunks.cpp):
// a failed MPI call or a message too large for MPI's int counts ends the job through rankFailure().
#include <fmt/format.h>
#include <mpi.h>

#include <climits>
#include <string>
#include <vector>

#include "parallel/mpi_session.hpp"

namespace polydem::parallel {

/// Wall-clock seconds spent in MPI calls, added to `total` when the scope ends.
class CommTimer {
 public:
  explicit CommTimer(double& total) : total_(total), start_(MPI_Wtime()) {}
  ~CommTimer() { total_ += MPI_Wtime() - start_; }
  CommTimer(const CommTimer&) = delete;
  CommTimer& operator=(const CommTimer&) = delete;

 private:
  double& total_;
  double start_;
};

inline void mpiCheck(int code, const char* what) {
  if (code != MPI_SUCCESS) {
    char text[MPI_MAX_ERROR_STRING];
    int length = 0;
    MPI_Error_string(code, text, &length);
    rankFailure(fmt::format("{} failed: {}", what, std::string(text, static_cast<std::size_t>(length))), 1);
  }
}

inline int toInt(std::size_t n, const char* what) {
  if (n > static_cast<std::size_t>(INT_MAX)) {
    rankFailure(fmt::format("{}: {} values exceed one MPI message (2^31 - 1)", what, n), 1);
  }
  return static_cast<int>(n);
}

/// Send out[q] to every rank q; `in` receives the messages concatenated in rank order, inCount[q] doubles
/// from rank q. Collective.
inline void allToAll(const std::vector<std::vector<double>>& out, std::vector<double>& in, std::vector<int>& inCount) {
  const auto p = out.size();
  std::vector<int> outCount(p), outDispl(p), inDispl(p);
  inCount.assign(p, 0);
  std::size_t total = 0;
  for (std::size_t q = 0; q < p; ++q) {
    outCount[q] = toInt(out[q].size(), "particle exchange");
    outDispl[q] = toInt(total, "particle exchange");
    total += out[q].size();
  }
  std::vector<double> flat;
  flat.reserve(total);
  for (const auto& o : out) flat.insert(flat.end(), o.begin(), o.end());
  mpiCheck(MPI_Alltoall(outCount.data(), 1, MPI_INT, inCount.data(), 1, MPI_INT, MPI_COMM_WORLD), "MPI_Alltoall");
  std::size_t inTotal = 0;
  for (std::size_t q = 0; q < p; ++q) {
    inDispl[q] = toInt(inTotal, "particle exchange");
    inTotal += static_cast<std::size_t>(inCount[q]);
  }
  in.resize(inTotal);
  mpiCheck(MPI_Alltoallv(flat.data(), outCount.data(), outDispl.data(), MPI_DOUBLE, in.data(), inCount.data(),
                         inDispl.data(), MPI_DOUBLE, MPI_COMM_WORLD),
           "MPI_Alltoallv");
}

}  // namespace polydem::parallel
