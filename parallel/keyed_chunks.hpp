#pragma once
// Sums over all particles of a distributed run that are the serial sums to the bit (docs/parallel.md).
//
// The serial minimiser adds its per-particle terms by fixed chunks of slots (kChunk = 4096 consecutive slots,
// integrators/fire_descent.hpp): each chunk's terms in slot order, then the chunks' sums in chunk order. A
// distributed run keys its particles by serial slot, so a chunk is a range of keys, and:
//   - a chunk whose particles one rank owns all of ("whole") is summed by that rank from its local arrays,
//     where the chunk is a contiguous run of local slots (no ghost can carry a key of it);
//   - a chunk split over several ranks is summed by its "leader" (the owner of most of its particles, the
//     lowest rank among equals): the other owners send it their particles' values (a few doubles each; the
//     keys travel once per setup()), the leader puts them in key order and runs the same chunk function;
//   - every chunk's result, zero on the ranks that did not compute it, is summed over the ranks in one
//     MPI_Allreduce: x + 0 + ... + 0 = x exactly, whatever order MPI adds in. Each rank then adds the chunks in
//     chunk order, as the serial code does.
// A split chunk costs its particles' values once per reduction (with RCB on 2 ranks about 16% of the particles
// at N = 10^6: the chunks a cut plane crosses); the Allreduce carries chunks x width doubles (10 KB at 10^6).
// setup() after every change of ownership (a neighbour-list build that migrates particles).
#include <algorithm>
#include <vector>

#include "core/types.hpp"

namespace polydem::parallel {

class KeyedChunks {
 public:
  /// Collective. `key`: every local slot's key, ascending; `ownedSlots`: the owned local slots, ascending;
  /// `total`: particles in the system; `chunk`: slots per chunk.
  void setup(const std::vector<Index>& key, const std::vector<Index>& ownedSlots, Index total, Index chunk);

  Index chunks() const { return chunks_; }

  /// Collective. Every chunk's `width` values, chunk-major, the same on every rank, followed by the `extra`
  /// values of every rank summed (flags, counts). whole(c, begin, end, out): chunk c from local slots
  /// [begin, end). pack(slot, out): `packWidth` values of an owned particle of a split chunk. fold(c, count,
  /// packed, out): chunk c from its `count` particles' packed values in key order. Returns a buffer valid until
  /// the next call.
  template <class Whole, class Pack, class Fold>
  const std::vector<double>& reduce(int width, int packWidth, Whole whole, Pack pack, Fold fold,
                                    const std::vector<double>& extra, double* commSeconds) {
    result_.assign(static_cast<std::size_t>(chunks_) * static_cast<std::size_t>(width) + extra.size(), 0.0);
    double* out = result_.data();
    for (const Run& r : whole_) whole(r.chunk, r.begin, r.end, out + r.chunk * width);
    const auto record = static_cast<std::size_t>(packWidth);
    send_.resize(sendTotal_ * record);
    double* s = send_.data();
    for (const std::vector<Index>& slots : sendSlots_) {
      for (const Index i : slots) {
        pack(i, s);
        s += packWidth;
      }
    }
    exchange(record, commSeconds);
    // Each led chunk's particles into its run of the staging buffer, in key order (places from setup()).
    staging_.resize(static_cast<std::size_t>(ledParticles_) * record);
    double* staged = staging_.data();
    std::size_t m = 0;
    for (const Led& l : led_) {
      for (const Index i : l.mine) pack(i, staged + static_cast<std::size_t>(minePlace_[m++]) * record);
    }
    for (std::size_t k = 0; k < recvTotal_; ++k) {
      const double* rec = recv_.data() + k * record;
      std::copy(rec, rec + record, staged + static_cast<std::size_t>(recvPlace_[k]) * record);
    }
    for (const Led& l : led_) fold(l.chunk, l.count, staging_.data() + l.offset * packWidth, out + l.chunk * width);
    std::copy(extra.begin(), extra.end(), result_.end() - static_cast<std::ptrdiff_t>(extra.size()));
    sumOverRanks(commSeconds);
    return result_;
  }

 private:
  void exchange(std::size_t record, double* commSeconds);
  void sumOverRanks(double* commSeconds);

  struct Run {
    Index chunk, begin, end;
  };
  struct Led {
    Index chunk, first, count, offset;  ///< first key, particles, first particle in the staging buffer
    std::vector<Index> mine;            ///< this rank's slots in it
  };
  const std::vector<Index>* key_ = nullptr;
  Index chunks_ = 0;
  std::vector<Run> whole_;
  std::vector<Led> led_;
  std::vector<std::vector<Index>> sendSlots_;  ///< per rank: owned slots of split chunks it leads
  std::size_t sendTotal_ = 0;
  std::vector<int> sendCount_, recvCount_;  ///< particles per rank
  std::size_t recvTotal_ = 0;
  Index chunk_ = 1, ledParticles_ = 0;
  std::vector<Index> ledOf_;                  ///< per chunk: its index in led_, or -1
  std::vector<Index> recvPlace_, minePlace_;  ///< staging place of each received value, of each own led particle
  std::vector<int> counts_, displs_, rcounts_, rdispls_;
  std::vector<double> send_, recv_, staging_, result_;
};

}  // namespace polydem::parallel
