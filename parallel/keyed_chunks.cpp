#include "parallel/keyed_chunks.hpp"

#include <stdexcept>

#include "parallel/mpi_util.hpp"

namespace polydem::parallel {

void KeyedChunks::setup(const std::vector<Index>& key, const std::vector<Index>& ownedSlots, Index total, Index chunk) {
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  key_ = &key;
  chunk_ = chunk;
  chunks_ = (total + chunk - 1) / chunk;
  const auto C = static_cast<std::size_t>(chunks_);
  std::vector<Index> mine(C, 0);
  for (const Index i : ownedSlots) ++mine[static_cast<std::size_t>(key[static_cast<std::size_t>(i)] / chunk)];
  // The leader of a chunk: the owner of most of its particles (the lowest such rank), so the fewest values
  // travel and split chunks spread over the ranks that hold them.
  std::vector<double> owned(C * static_cast<std::size_t>(size));
  {
    std::vector<double> count(mine.begin(), mine.end());
    mpiCheck(MPI_Allgather(count.data(), toInt(C, "chunks"), MPI_DOUBLE, owned.data(), toInt(C, "chunks"), MPI_DOUBLE,
                           MPI_COMM_WORLD),
             "MPI_Allgather");
  }
  std::vector<int> leader(C, 0);
  for (std::size_t c = 0; c < C; ++c) {
    for (int q = 1; q < size; ++q) {
      if (owned[static_cast<std::size_t>(q) * C + c] > owned[static_cast<std::size_t>(leader[c]) * C + c])
        leader[c] = q;
    }
  }

  whole_.clear();
  led_.clear();
  ledOf_.assign(C, -1);
  ledParticles_ = 0;
  sendSlots_.assign(static_cast<std::size_t>(size), {});
  std::size_t o = 0;  // position in ownedSlots (ascending key)
  for (std::size_t c = 0; c < C; ++c) {
    const Index first = static_cast<Index>(c) * chunk;
    const Index count = std::min(total, first + chunk) - first;
    const std::size_t begin = o;
    while (o < ownedSlots.size() && key[static_cast<std::size_t>(ownedSlots[o])] < first + count) ++o;
    if (o == begin) continue;
    if (mine[c] == count) {
      const Index b = ownedSlots[begin];
      if (ownedSlots[o - 1] - b + 1 != count) {
        throw std::logic_error("KeyedChunks: a chunk owned whole is not a contiguous run of local slots");
      }
      whole_.push_back({static_cast<Index>(c), b, b + count});
    } else if (leader[c] == rank) {
      ledOf_[c] = static_cast<Index>(led_.size());
      led_.push_back({static_cast<Index>(c), first, count, ledParticles_,
                      std::vector<Index>(ownedSlots.begin() + static_cast<std::ptrdiff_t>(begin),
                                         ownedSlots.begin() + static_cast<std::ptrdiff_t>(o))});
      ledParticles_ += count;
    } else {
      auto& to = sendSlots_[static_cast<std::size_t>(leader[c])];
      to.insert(to.end(), ownedSlots.begin() + static_cast<std::ptrdiff_t>(begin),
                ownedSlots.begin() + static_cast<std::ptrdiff_t>(o));
    }
  }
  sendCount_.assign(static_cast<std::size_t>(size), 0);
  recvCount_.assign(static_cast<std::size_t>(size), 0);
  sendTotal_ = 0;
  for (int q = 0; q < size; ++q) {
    sendCount_[static_cast<std::size_t>(q)] = toInt(sendSlots_[static_cast<std::size_t>(q)].size(), "chunk values");
    sendTotal_ += sendSlots_[static_cast<std::size_t>(q)].size();
  }
  mpiCheck(MPI_Alltoall(sendCount_.data(), 1, MPI_INT, recvCount_.data(), 1, MPI_INT, MPI_COMM_WORLD), "MPI_Alltoall");
  recvTotal_ = 0;
  for (const int n : recvCount_) recvTotal_ += static_cast<std::size_t>(n);

  // The keys travel once here; each reduction sends values only, in the same order, and every value's place
  // in the staging buffer (the leader's particles of a chunk in key order) is known from now on.
  auto place = [&](Index k) {
    const Led& l = led_[static_cast<std::size_t>(ledOf_[static_cast<std::size_t>(k / chunk_)])];
    return l.offset + k - l.first;
  };
  send_.clear();
  for (const std::vector<Index>& slots : sendSlots_) {
    for (const Index i : slots) send_.push_back(static_cast<double>(key[static_cast<std::size_t>(i)]));
  }
  double ignored = 0.0;
  exchange(1, &ignored);
  recvPlace_.resize(recvTotal_);
  for (std::size_t k = 0; k < recvTotal_; ++k) recvPlace_[k] = place(static_cast<Index>(recv_[k]));
  minePlace_.clear();
  for (const Led& l : led_) {
    for (const Index i : l.mine) minePlace_.push_back(place(key[static_cast<std::size_t>(i)]));
  }
}

void KeyedChunks::exchange(std::size_t record, double* commSeconds) {
  const std::size_t P = sendCount_.size();
  counts_.resize(P);
  displs_.resize(P);
  rcounts_.resize(P);
  rdispls_.resize(P);
  std::size_t s = 0, r = 0;
  for (std::size_t q = 0; q < P; ++q) {
    counts_[q] = toInt(static_cast<std::size_t>(sendCount_[q]) * record, "chunk values");
    displs_[q] = toInt(s, "chunk values");
    s += static_cast<std::size_t>(counts_[q]);
    rcounts_[q] = toInt(static_cast<std::size_t>(recvCount_[q]) * record, "chunk values");
    rdispls_[q] = toInt(r, "chunk values");
    r += static_cast<std::size_t>(rcounts_[q]);
  }
  recv_.resize(r);
  CommTimer timer(*commSeconds);
  mpiCheck(MPI_Alltoallv(send_.data(), counts_.data(), displs_.data(), MPI_DOUBLE, recv_.data(), rcounts_.data(),
                         rdispls_.data(), MPI_DOUBLE, MPI_COMM_WORLD),
           "MPI_Alltoallv");
}

void KeyedChunks::sumOverRanks(double* commSeconds) {
  CommTimer timer(*commSeconds);
  mpiCheck(MPI_Allreduce(MPI_IN_PLACE, result_.data(), toInt(result_.size(), "chunk sums"), MPI_DOUBLE, MPI_SUM,
                         MPI_COMM_WORLD),
           "MPI_Allreduce");
}

}  // namespace polydem::parallel
