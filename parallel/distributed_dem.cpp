// DistributedDem: the serial time loop of integrators::DemSimulation on a brick grid of MPI ranks. The
// determinism argument is in distributed_dem.hpp and docs/parallel.md; here, the mechanics. Every value that
// decides a trajectory is computed by the same expressions as in dem_simulation.cpp (the half kicks, the
// periodic wrap, the wall candidates) or by the same compiled force kernel.
#include "parallel/distributed_dem.hpp"

#include <fmt/format.h>
#include <mpi.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "broadphase/auto_select.hpp"
#include "broadphase/registry.hpp"
#include "core/interrupt.hpp"
#include "integrators/verlet_list.hpp"
#include "parallel/mpi_session.hpp"
#include "parallel/mpi_util.hpp"
#include "polydem/config.hpp"

namespace polydem::parallel {

namespace {

std::vector<MPI_Request> requests;  // ghost updates: one Irecv and one Isend per partner (grows only)

/// A history key travels as the bit pattern of a double (exact: MPI copies bytes on one machine type).
double keyBits(std::uint64_t key) {
  double d;
  std::memcpy(&d, &key, sizeof d);
  return d;
}
std::uint64_t keyOf(double d) {
  std::uint64_t key;
  std::memcpy(&key, &d, sizeof key);
  return key;
}

/// x in `region`: lo <= x < hi per axis, x <= hi on the box's upper face (as Decomposition::owner descends).
bool inside(const Region& region, const double* x, const Box& box) {
  for (int k = 0; k < 3; ++k) {
    if (x[k] < region.lo[k]) return false;
    if (!(x[k] < region.hi[k]) && region.hi[k] < box.length(k)) return false;
  }
  return true;
}

bool active(const double* values, int width) {
  for (int k = 0; k < width; ++k) {
    if (values[k] != 0.0) return true;
  }
  return false;
}

/// Records of (key bits, width values), sorted by key with duplicates dropped, into keys and values.
void sortedHistory(const std::vector<double>& pool, int width, std::vector<std::uint64_t>& keys,
                   std::vector<double>& values) {
  const std::size_t stride = 1 + static_cast<std::size_t>(width);
  const std::size_t count = pool.size() / stride;
  std::vector<std::size_t> order(count);
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return keyOf(pool[a * stride]) < keyOf(pool[b * stride]); });
  keys.clear();
  values.clear();
  for (const std::size_t e : order) {
    const std::uint64_t key = keyOf(pool[e * stride]);
    // A pair whose two particles arrive from different ranks comes twice, with equal values (both ranks
    // computed it from the same inputs).
    if (!keys.empty() && keys.back() == key) continue;
    keys.push_back(key);
    values.insert(values.end(), pool.begin() + static_cast<std::ptrdiff_t>(e * stride + 1),
                  pool.begin() + static_cast<std::ptrdiff_t>((e + 1) * stride));
  }
}

}  // namespace

// ---- layout of a particle record (migration and new ghosts): key, id, x, v, v_pred, [w, w_pred], r, 1/m, [1/I]

namespace {
constexpr int kX = 2, kV = 5, kVp = 8, kW = 11, kWp = 14;
}

int DistributedDem::recordWidth() const { return (rotation_ ? 20 : 13) + (carryForces_ ? (rotation_ ? 6 : 3) : 0); }

void DistributedDem::packRecord(Index i, std::vector<double>& out) const {
  out.push_back(static_cast<double>(key_[static_cast<std::size_t>(i)]));
  out.push_back(static_cast<double>(id_[static_cast<std::size_t>(i)]));
  for (int k = 0; k < 3; ++k) out.push_back(x_(k, i));
  for (int k = 0; k < 3; ++k) out.push_back(v_(k, i));
  for (int k = 0; k < 3; ++k) out.push_back(vp_(k, i));
  if (rotation_) {
    for (int k = 0; k < 3; ++k) out.push_back(w_(k, i));
    for (int k = 0; k < 3; ++k) out.push_back(wp_(k, i));
  }
  out.push_back(r_[i]);
  out.push_back(invm_[i]);
  if (rotation_) out.push_back(invI_[i]);
  if (carryForces_) {
    for (int k = 0; k < 3; ++k) out.push_back(f_(k, i));
    if (rotation_) {
      for (int k = 0; k < 3; ++k) out.push_back(tq_(k, i));
    }
  }
}

// ---- construction ---------------------------------------------------------------------------------------

DistributedDem::DistributedDem(const integrators::DemState& g, const integrators::DemSettings& settings,
                               DecompositionKind kind, double rebalanceThreshold)
    : box_(g.box),
      settings_(settings),
      model_(settings.contact),
      grid_(Decomposition::brick(g.box, parallel::size())),
      rebalanceThreshold_(rebalanceThreshold) {
  rank_ = parallel::rank();
  size_ = parallel::size();
  const Index n = static_cast<Index>(g.radius.size());
  if (n == 0) throw ConfigError("no particles to simulate");
  total_ = n;
  rmaxGlobal_ = g.radius.maxCoeff();
  if (g.position.cols() != n || g.referencePosition.cols() != n || g.referenceRadius.size() != n ||
      g.id.size() != static_cast<std::size_t>(n)) {
    throw InputError("DistributedDem: inconsistent state sizes");
  }
  rotation_ = g.rotation;
  skin_ = g.skin;
  settings_.skin = skin_;
  selectKernel();
  if (kernel_.rotation && !rotation_) throw InputError("DistributedDem: the kernel needs rotation, the state has none");
  // gather() sends every particle (and each active contact) to rank 0 in one message of doubles.
  const double perParticle = 24.0 + 6.0 * (1.0 + kernel_.historyWidth);
  if (static_cast<double>(n) * perParticle > static_cast<double>(INT_MAX)) {
    throw ConfigError(fmt::format(
        "{} particles are more than rank 0 can gather in one MPI message (about {:.0f} million at most): outputs and "
        "checkpoints are gathered to rank 0 (docs/parallel.md)",
        n, static_cast<double>(INT_MAX) / perParticle / 1e6));
  }
  timeStep_ = g.timeStep;
  dt_ = timeStep_.dt;
  step_ = g.step;
  timeOrigin_ = g.timeOrigin;
  initialEnergy_ = g.initialEnergy;
  growth_ = g.growthSinceBuild;
  backend_ = broadphase::makeBroadPhase(settings_.broadPhase);
  backend_->setThreads(settings_.threads);  // buildList() sorts the rows: the same list for any thread count
  if (auto* chooser = dynamic_cast<broadphase::AutoSelect*>(backend_.get())) {
    // Every rank builds on its own changing share of particles and ghosts: `auto` optimises once for the
    // whole system (global radii and density, as the serial run does) with rank 0's calibrated K, so all
    // ranks choose the same structure and none re-optimises at a build.
    double K = broadphase::modelCostRatio();
    mpiCheck(MPI_Bcast(&K, 1, MPI_DOUBLE, 0, MPI_COMM_WORLD), "MPI_Bcast");
    chooser->setCostRatio(K);
    chooser->setSample(std::span<const double>(g.referenceRadius.data(), static_cast<std::size_t>(n)), box_, skin_);
  }

  // Ownership and ghosts from the positions of the last build: the list is then the serial run's. The
  // bisection weighs particles by count here (every rank has the global state: no communication).
  if (kind == DecompositionKind::Bisection) {
    grid_ = Decomposition::bisection(box_, size_, [&](const Region& region, int axis, double cut) {
      double w = 0.0;
      for (Index s = 0; s < n; ++s) {
        const double* x = &g.referencePosition(0, s);
        if (x[axis] < cut && inside(region, x, box_)) w += 1.0;
      }
      return w;
    });
  }
  std::vector<int> owner(static_cast<std::size_t>(n));
  rmax_.assign(static_cast<std::size_t>(size_), -1.0);
  for (Index s = 0; s < n; ++s) {
    const int q = grid_.owner(&g.referencePosition(0, s));
    owner[static_cast<std::size_t>(s)] = q;
    rmax_[static_cast<std::size_t>(q)] = std::max(rmax_[static_cast<std::size_t>(q)], g.referenceRadius[s]);
  }
  {
    std::vector<double> centres, radii;
    for (Index s = 0; s < n; ++s) {
      if (owner[static_cast<std::size_t>(s)] != rank_) continue;
      for (int k = 0; k < 3; ++k) centres.push_back(g.referencePosition(k, s));
      radii.push_back(g.referenceRadius[s]);
    }
    exchangeReach(centres, radii);
  }
  std::vector<Index> local;
  for (Index s = 0; s < n; ++s) {
    if (owner[static_cast<std::size_t>(s)] == rank_ ||
        needsGhost(&g.referencePosition(0, s), g.referenceRadius[s], rank_)) {
      local.push_back(s);
    }
  }
  n_ = static_cast<Index>(local.size());
  key_.resize(local.size());
  id_.resize(local.size());
  owned_.resize(local.size());
  x_.resize(3, n_);
  v_.resize(3, n_);
  f_.resize(3, n_);
  ref_.resize(3, n_);
  r_.resize(n_);
  invm_.resize(n_);
  refR_.resize(n_);
  if (rotation_) {
    w_.resize(3, n_);
    tq_.resize(3, n_);
    invI_.resize(n_);
  }
  sendSlots_.assign(static_cast<std::size_t>(size_), {});
  recvSlots_.assign(static_cast<std::size_t>(size_), {});
  ownedSlots_.clear();
  for (Index k = 0; k < n_; ++k) {
    const Index s = local[static_cast<std::size_t>(k)];
    key_[static_cast<std::size_t>(k)] = s;
    id_[static_cast<std::size_t>(k)] = g.id[static_cast<std::size_t>(s)];
    const int q = owner[static_cast<std::size_t>(s)];
    owned_[static_cast<std::size_t>(k)] = q == rank_;
    x_.col(k) = g.position.col(s);
    v_.col(k) = g.velocity.col(s);
    f_.col(k) = g.force.col(s);
    ref_.col(k) = g.referencePosition.col(s);
    refR_[k] = g.referenceRadius[s];
    r_[k] = g.radius[s];
    invm_[k] = g.inverseMass[s];
    if (rotation_) {
      w_.col(k) = g.angularVelocity.col(s);
      tq_.col(k) = g.torque.col(s);
      invI_[k] = g.inverseInertia[s];
    }
    if (q == rank_) {
      ownedSlots_.push_back(k);
      for (int t = 0; t < size_; ++t) {
        if (t == rank_) continue;
        stats_.coarseGhosts += coarseGhost(&g.referencePosition(0, s), g.referenceRadius[s], t) ? 1.0 : 0.0;
        if (needsGhost(&g.referencePosition(0, s), g.referenceRadius[s], t)) {
          sendSlots_[static_cast<std::size_t>(t)].push_back(k);
        }
      }
    } else {
      recvSlots_[static_cast<std::size_t>(q)].push_back(k);
    }
  }
  vp_ = v_;  // as DemSimulation: overwritten by the first opening kick before any use
  if (rotation_) wp_ = w_;
  setupGhostBuffers();

  buildList(ref_, refR_);
  builds_ = g.builds;
  if (kernel_.historyWidth > 0) {
    pairHistory_.assign(g.pairKeys, g.pairValues);
    wallHistory_.assign(g.wallKeys, g.wallValues);
    pairHistory_.remap(pairKeys_);
    wallHistory_.remap(wallKeys_);
  }
}

void DistributedDem::selectKernel() {
  // As DemSimulation::selectKernel(): the same flags give the same compiled kernel.
  flags_.walls = box_.hasWalls();
  flags_.gravity = settings_.gravity != Eigen::Vector3d::Zero();
  flags_.viscous = settings_.viscousDamping > 0.0;
  kernel_ = contact::selectForceKernel(model_, flags_, settings_.generalKernel);
  pairHistory_ = contact::ContactHistory(kernel_.historyWidth);
  wallHistory_ = contact::ContactHistory(kernel_.historyWidth);
  const auto& p = model_.parameters();
  bool gravityOnPeriodic = false;
  for (int k = 0; k < 3; ++k) gravityOnPeriodic |= settings_.gravity[k] != 0.0 && box_.periodic(k);
  conservative_ = settings_.dissipationFree() && !gravityOnPeriodic;
  predict_ = settings_.dashpotVelocity == integrators::DashpotVelocity::Predicted &&
             (p.normalDamped() || flags_.viscous || kernel_.rotation);
}

bool DistributedDem::coarseGhost(const double* x, double r, int q) const {
  const double rmaxQ = rmax_[static_cast<std::size_t>(q)];
  if (rmaxQ < 0.0) return false;  // q owns nothing
  // A relative margin far above the rounding of the distance: an extra ghost costs a copy, a missing one a pair.
  const double reach = (r + rmaxQ + skin_) * (1.0 + 1e-9);
  return grid_.distanceSquared(x, q) <= reach * reach;
}

bool DistributedDem::needsGhost(const double* x, double r, int q) const {
  return coarseGhost(x, r, q) && reachAt(q, x) + r >= -1e-9 * (r + skin_);
}

namespace {
// The reach grid has at most kReachCells cells per axis, and no fewer than kReachBallCells cells across the
// largest ball (largest radius + skin + largest radius): the field's cost is the cells inside every boundary
// particle's ball, which on a fixed 32^3 grid of a small box with large particles was thousands of cells per
// particle at every build. Coarser cells give a smaller (still exact) lower bound, so only more ghosts.
constexpr int kReachCells = 32;
constexpr double kReachBallCells = 4.0;
}  // namespace

int DistributedDem::reachCell(const double* x) const {
  int index = 0;
  for (int k = 2; k >= 0; --k) {
    const int G = reachCells_[k];
    const double u = std::floor(x[k] / box_.length(k) * G);
    const int c = std::isfinite(u) ? static_cast<int>(std::clamp(u, 0.0, G - 1.0)) : 0;
    index = index * G + c;
  }
  return index;
}

double DistributedDem::reachAt(int q, const double* x) const {
  const auto& field = reach_[static_cast<std::size_t>(q)];
  const int cell = reachCell(x);
  const auto it = std::lower_bound(field.begin(), field.end(), std::make_pair(static_cast<std::int32_t>(cell), -1e300));
  if (it == field.end() || it->first != cell) return -std::numeric_limits<double>::infinity();
  return it->second;
}

void DistributedDem::exchangeReach(const std::vector<double>& centres, const std::vector<double>& radii) {
  double rmaxAll = 0.0;
  for (const double r : rmax_) rmaxAll = std::max(rmaxAll, r);
  const Region& mine = grid_.region(rank_);
  double cellSize[3];
  const double largestBall = 2.0 * rmaxAll + skin_;  // the same on every rank: rmax_ is gathered, skin_ shared
  for (int k = 0; k < 3; ++k) {
    const double cells = std::floor(kReachBallCells * box_.length(k) / largestBall);
    reachCells_[k] = std::isfinite(cells) ? static_cast<int>(std::clamp(cells, 1.0, double(kReachCells))) : kReachCells;
    cellSize[k] = box_.length(k) / reachCells_[k];
  }
  std::vector<double> field(static_cast<std::size_t>(reachCells_[0]) * reachCells_[1] * reachCells_[2],
                            -std::numeric_limits<double>::infinity());
  std::vector<int> index[3];
  std::vector<double> distance[3];
  for (std::size_t i = 0; i < radii.size(); ++i) {
    const double* x = centres.data() + 3 * i;
    const double ball = radii[i] + skin_ + rmaxAll;
    // A particle whose ball stays inside this rank's region reaches no particle of another rank.
    double depth = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 3; ++k) {
      const double L = box_.length(k);
      if (mine.lo[k] > 0.0 || box_.periodic(k)) {
        if (!(mine.lo[k] <= 0.0 && mine.hi[k] >= L)) depth = std::min(depth, x[k] - mine.lo[k]);
      }
      if (mine.hi[k] < L || box_.periodic(k)) {
        if (!(mine.lo[k] <= 0.0 && mine.hi[k] >= L)) depth = std::min(depth, mine.hi[k] - x[k]);
      }
    }
    if (depth > ball) continue;
    for (int k = 0; k < 3; ++k) {
      const int G = reachCells_[k];
      index[k].clear();
      distance[k].clear();
      const long first = static_cast<long>(std::floor((x[k] - ball) / cellSize[k]));
      const long last = static_cast<long>(std::floor((x[k] + ball) / cellSize[k]));
      const bool periodic = box_.periodic(k);
      if (periodic && last - first + 1 >= G) {
        for (int c = 0; c < G; ++c) index[k].push_back(c);
      } else {
        for (long c = first; c <= last; ++c) {
          if (!periodic && (c < 0 || c >= G)) continue;
          index[k].push_back(static_cast<int>(((c % G) + G) % G));
        }
      }
      for (const int c : index[k]) {
        distance[k].push_back(intervalDistance(x[k], c * cellSize[k], (c + 1) * cellSize[k], box_.length(k), periodic));
      }
    }
    for (std::size_t a = 0; a < index[2].size(); ++a) {
      for (std::size_t b = 0; b < index[1].size(); ++b) {
        const double dzy = distance[2][a] * distance[2][a] + distance[1][b] * distance[1][b];
        if (dzy > ball * ball) continue;
        for (std::size_t c = 0; c < index[0].size(); ++c) {
          const double dsq = dzy + distance[0][c] * distance[0][c];
          if (dsq > ball * ball) continue;
          // Rounded down (a lower bound of the distance): the field is never below the exact value.
          const double value = radii[i] + skin_ - std::sqrt(dsq) * (1.0 - 1e-12);
          double& f = field[static_cast<std::size_t>((index[2][a] * reachCells_[1] + index[1][b]) * reachCells_[0] +
                                                     index[0][c])];
          f = std::max(f, value);
        }
      }
    }
  }
  std::vector<double> sparse;
  for (std::size_t c = 0; c < field.size(); ++c) {
    if (field[c] == -std::numeric_limits<double>::infinity()) continue;
    sparse.push_back(static_cast<double>(c));
    sparse.push_back(field[c]);
  }
  const int count = toInt(sparse.size(), "reach field");
  std::vector<int> counts(static_cast<std::size_t>(size_)), displs(static_cast<std::size_t>(size_));
  std::vector<double> all;
  {
    CommTimer timer(stats_.commSeconds);
    mpiCheck(MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, MPI_COMM_WORLD), "MPI_Allgather");
    std::size_t total = 0;
    for (int q = 0; q < size_; ++q) {
      displs[static_cast<std::size_t>(q)] = toInt(total, "reach field");
      total += static_cast<std::size_t>(counts[static_cast<std::size_t>(q)]);
    }
    all.resize(total);
    mpiCheck(MPI_Allgatherv(sparse.data(), count, MPI_DOUBLE, all.data(), counts.data(), displs.data(), MPI_DOUBLE,
                            MPI_COMM_WORLD),
             "MPI_Allgatherv");
  }
  reach_.assign(static_cast<std::size_t>(size_), {});
  for (int q = 0; q < size_; ++q) {
    const std::size_t begin = static_cast<std::size_t>(displs[static_cast<std::size_t>(q)]);
    const std::size_t end = begin + static_cast<std::size_t>(counts[static_cast<std::size_t>(q)]);
    for (std::size_t e = begin; e < end; e += 2) {
      reach_[static_cast<std::size_t>(q)].emplace_back(static_cast<std::int32_t>(all[e]), all[e + 1]);
    }
  }
}

void DistributedDem::setupGhostBuffers() {
  const int width = 3 + (ghostsReadHalfStep() ? 3 : 0) + (predict_ ? 3 : 0) + (rotation_ ? 3 + (predict_ ? 3 : 0) : 0);
  sendOffset_.assign(static_cast<std::size_t>(size_) + 1, 0);
  recvOffset_.assign(static_cast<std::size_t>(size_) + 1, 0);
  partners_.clear();
  for (int q = 0; q < size_; ++q) {
    const auto uq = static_cast<std::size_t>(q);
    sendOffset_[uq + 1] = sendOffset_[uq] + width * static_cast<int>(sendSlots_[uq].size());
    recvOffset_[uq + 1] = recvOffset_[uq] + width * static_cast<int>(recvSlots_[uq].size());
    if (!sendSlots_[uq].empty() || !recvSlots_[uq].empty()) partners_.push_back(q);
  }
  sendBuffer_.resize(static_cast<std::size_t>(sendOffset_.back()));
  recvBuffer_.resize(static_cast<std::size_t>(recvOffset_.back()));
  if (requests.size() < 2 * partners_.size()) requests.resize(2 * partners_.size());
  stats_.ghostBytesPerStep = static_cast<double>(sendBuffer_.size() * sizeof(double));
  stats_.owned = static_cast<double>(ownedSlots_.size());
  stats_.ghosts = static_cast<double>(n_) - stats_.owned;
}

namespace {

/// Sorts `v`, whose ranges [runs[k], runs[k + 1]) are usually sorted already (each made in key order by one
/// rank): merges them when every one is, else sorts the whole. Either way the result is the one order of
/// the elements by `less`, which must not rank two elements equal (keys are unique). A build used to sort
/// from scratch: 4-5 % of a rank's loop at 10^6 spheres.
template <class T, class Less>
void sortRuns(std::vector<T>& v, const std::vector<std::size_t>& runs, Less less) {
  const auto at = [&](std::size_t k) { return v.begin() + static_cast<std::ptrdiff_t>(runs[k]); };
  for (std::size_t k = 0; k + 1 < runs.size(); ++k) {
    if (!std::is_sorted(at(k), at(k + 1), less)) {
      std::sort(v.begin(), v.end(), less);
      return;
    }
  }
  for (std::size_t k = 1; k + 1 < runs.size(); ++k) {
    if (runs[k + 1] > runs[k]) std::inplace_merge(v.begin(), at(k), at(k + 1), less);
  }
}

}  // namespace

// ---- the neighbour list ---------------------------------------------------------------------------------

void DistributedDem::buildList(const Eigen::Matrix3Xd& centres, const Eigen::VectorXd& radii) {
  const SphereView spheres{centres, radii};
  pairs_.clear();
  if (n_ > 0) {
    backend_->build(spheres, box_, skin_);
    backend_->findPairs(spheres, pairs_);
  }
  ++builds_;
  // Pairs between two ghosts belong to other ranks: drop them. The rest in CSR (i, j) order, as VerletList.
  std::size_t kept = 0;
  for (const broadphase::Pair& p : pairs_) {
    if (owned_[static_cast<std::size_t>(p.i)] || owned_[static_cast<std::size_t>(p.j)]) pairs_[kept++] = p;
  }
  pairs_.resize(kept);
  list_.offset.assign(static_cast<std::size_t>(n_) + 1, 0);
  for (const broadphase::Pair& p : pairs_) ++list_.offset[static_cast<std::size_t>(p.i) + 1];
  for (Index i = 0; i < n_; ++i)
    list_.offset[static_cast<std::size_t>(i) + 1] += list_.offset[static_cast<std::size_t>(i)];
  fill_.assign(list_.offset.begin(), list_.offset.end() - 1);
  list_.neighbour.resize(pairs_.size());
  for (const broadphase::Pair& p : pairs_)
    list_.neighbour[static_cast<std::size_t>(fill_[static_cast<std::size_t>(p.i)]++)] = p.j;
  for (Index i = 0; i < n_; ++i)
    std::sort(list_.neighbour.begin() + list_.offset[i], list_.neighbour.begin() + list_.offset[i + 1]);

  // Wall candidates of owned particles, in the serial order (slot, then faces -x +x -y +y -z +z).
  list_.wallParticle.clear();
  list_.wallFace.clear();
  if (box_.hasWalls()) {
    for (Index i = 0; i < n_; ++i) {
      if (!owned_[static_cast<std::size_t>(i)]) continue;
      const double r = radii[i];
      for (int axis = 0; axis < 3; ++axis) {
        if (box_.periodic(axis)) continue;
        const double x = centres(axis, i);
        if (x - r <= skin_) {
          list_.wallParticle.push_back(i);
          list_.wallFace.push_back(static_cast<std::int8_t>(2 * axis));
        }
        if (box_.length(axis) - x - r <= skin_) {
          list_.wallParticle.push_back(i);
          list_.wallFace.push_back(static_cast<std::int8_t>(2 * axis + 1));
        }
      }
    }
  }
  if (settings_.threads > 1) {
    list_.buildBlocks(settings_.threads);
    crossScratch_.resize(contact::crossScratchSize(list_.crossCount(), kernel_.rotation));
    crossTouching_.resize(list_.crossCount());
  }
  if (&centres != &ref_) ref_ = centres;
  if (&radii != &refR_) refR_ = radii;
  // The springs' keys, for kernels that keep springs (every use is under historyWidth > 0).
  pairKeys_.clear();
  wallKeys_.clear();
  if (kernel_.historyWidth > 0) {
    pairKeys_.resize(list_.neighbour.size());
    for (Index i = 0; i < n_; ++i) {
      for (Index c = list_.offset[i]; c < list_.offset[i + 1]; ++c) {
        pairKeys_[static_cast<std::size_t>(c)] =
            contact::pairKey(id_[static_cast<std::size_t>(i)], id_[static_cast<std::size_t>(list_.neighbour[c])]);
      }
    }
    wallKeys_.resize(list_.wallParticle.size());
    for (std::size_t c = 0; c < wallKeys_.size(); ++c) {
      wallKeys_[c] = contact::wallKey(id_[static_cast<std::size_t>(list_.wallParticle[c])], list_.wallFace[c]);
    }
  }
  stats_.pairs = static_cast<double>(list_.pairCount());
}

void DistributedDem::remapHistories(std::vector<double>& pool, std::vector<double>& wallPool) {
  if (kernel_.historyWidth == 0) return;
  std::vector<std::uint64_t> keys;
  std::vector<double> values;
  sortedHistory(pool, kernel_.historyWidth, keys, values);
  pairHistory_.assign(keys, values);
  pairHistory_.remap(pairKeys_);
  sortedHistory(wallPool, kernel_.historyWidth, keys, values);
  wallHistory_.assign(keys, values);
  wallHistory_.remap(wallKeys_);
}

// ---- one step -------------------------------------------------------------------------------------------

namespace {

// The arithmetic of dem_simulation.cpp's halfKick<kDrift, kPredict>, particle by particle over the owned
// slots (ascending, so the arrays stream); the flags are template parameters so the inner loop has no
// branch. Returns the largest squared displacement from the reference positions (kDrift) or 0.
template <bool kDrift, bool kPredict, bool kClose = false>
double kickOwned(const std::vector<Index>& owned, double dt, double* __restrict v, const double* __restrict f,
                 const double* __restrict inverse, double* __restrict predicted, double* __restrict x,
                 const double* __restrict ref) {
  const double half = 0.5 * dt;
  double maxSq = 0.0;
  for (const Index i : owned) {
    const double h = half * inverse[i];
    double dsq = 0.0;
    for (int c = 0; c < 3; ++c) {
      const Index a = 3 * i + c;
      if constexpr (kClose) v[a] += h * f[a];  // the previous step's closing half kick (DistributedDem::advance)
      v[a] += h * f[a];
      if constexpr (kDrift) x[a] += dt * v[a];
      if constexpr (kPredict) predicted[a] = v[a] + h * f[a];
      if constexpr (kDrift) {
        const double dx = x[a] - ref[a];
        dsq += dx * dx;
      }
    }
    if constexpr (kDrift) maxSq = std::max(maxSq, dsq);
  }
  return maxSq;
}

}  // namespace

double DistributedDem::openingKickAndDrift(bool close) { return close ? openingPass<true>() : openingPass<false>(); }

template <bool kClose>
double DistributedDem::openingPass() {
  const double maxSq = predict_ ? kickOwned<true, true, kClose>(ownedSlots_, dt_, v_.data(), f_.data(), invm_.data(),
                                                                vp_.data(), x_.data(), ref_.data())
                                : kickOwned<true, false, kClose>(ownedSlots_, dt_, v_.data(), f_.data(), invm_.data(),
                                                                 nullptr, x_.data(), ref_.data());
  if (kernel_.rotation) {
    if (predict_) {
      kickOwned<false, true, kClose>(ownedSlots_, dt_, w_.data(), tq_.data(), invI_.data(), wp_.data(), nullptr,
                                     nullptr);
    } else {
      kickOwned<false, false, kClose>(ownedSlots_, dt_, w_.data(), tq_.data(), invI_.data(), nullptr, nullptr, nullptr);
    }
  }
  return maxSq;
}

void DistributedDem::closingKick() {
  kickOwned<false, false>(ownedSlots_, dt_, v_.data(), f_.data(), invm_.data(), nullptr, nullptr, nullptr);
  if (kernel_.rotation) {
    kickOwned<false, false>(ownedSlots_, dt_, w_.data(), tq_.data(), invI_.data(), nullptr, nullptr, nullptr);
  }
}

void DistributedDem::exchangeGhosts() {
  // What the kernel reads of a ghost and what changes every step: x, v(t + dt/2) (ghostsReadHalfStep()), the
  // predicted v and the same for rotation. Radii and masses change only by growRadii(), which every rank
  // applies to its ghosts too.
  const bool half = ghostsReadHalfStep();
  auto pack = [&](Index i, double* out) {
    int o = 0;
    for (int k = 0; k < 3; ++k) out[o++] = x_(k, i);
    if (half) {
      for (int k = 0; k < 3; ++k) out[o++] = v_(k, i);
    }
    if (predict_) {
      for (int k = 0; k < 3; ++k) out[o++] = vp_(k, i);
    }
    if (rotation_) {
      for (int k = 0; k < 3; ++k) out[o++] = w_(k, i);
      if (predict_) {
        for (int k = 0; k < 3; ++k) out[o++] = wp_(k, i);
      }
    }
    return o;
  };
  for (const int q : partners_) {
    double* out = sendBuffer_.data() + sendOffset_[static_cast<std::size_t>(q)];
    for (const Index i : sendSlots_[static_cast<std::size_t>(q)]) out += pack(i, out);
  }
  {
    CommTimer timer(stats_.commSeconds);
    int r = 0;
    for (const int q : partners_) {
      const auto uq = static_cast<std::size_t>(q);
      mpiCheck(MPI_Irecv(recvBuffer_.data() + recvOffset_[uq], recvOffset_[uq + 1] - recvOffset_[uq], MPI_DOUBLE, q, 7,
                         MPI_COMM_WORLD, &requests[static_cast<std::size_t>(r++)]),
               "MPI_Irecv");
    }
    for (const int q : partners_) {
      const auto uq = static_cast<std::size_t>(q);
      mpiCheck(MPI_Isend(sendBuffer_.data() + sendOffset_[uq], sendOffset_[uq + 1] - sendOffset_[uq], MPI_DOUBLE, q, 7,
                         MPI_COMM_WORLD, &requests[static_cast<std::size_t>(r++)]),
               "MPI_Isend");
    }
    mpiCheck(MPI_Waitall(r, requests.data(), MPI_STATUSES_IGNORE), "MPI_Waitall");
  }
  for (const int q : partners_) {
    const double* in = recvBuffer_.data() + recvOffset_[static_cast<std::size_t>(q)];
    for (const Index i : recvSlots_[static_cast<std::size_t>(q)]) {
      for (int k = 0; k < 3; ++k) x_(k, i) = *in++;
      if (half) {
        for (int k = 0; k < 3; ++k) v_(k, i) = *in++;
      }
      if (predict_) {
        for (int k = 0; k < 3; ++k) vp_(k, i) = *in++;
      }
      if (rotation_) {
        for (int k = 0; k < 3; ++k) w_(k, i) = *in++;
        if (predict_) {
          for (int k = 0; k < 3; ++k) wp_(k, i) = *in++;
        }
      }
    }
  }
}

void DistributedDem::wrapOwned() {
  // Periodic coordinates wrapped exactly as DemSimulation::wrapPositions() does; a non-finite coordinate or one
  // outside a walled box is a fault, reported by the serial check of the gathered state.
  int fault = 0;
  for (const Index i : ownedSlots_) {
    for (int k = 0; k < 3; ++k) {
      double& xk = x_(k, i);
      const double L = box_.length(k);
      if (!std::isfinite(xk)) {
        fault = 1;
      } else if (box_.periodic(k)) {
        if (xk < 0.0 || xk >= L) {
          xk -= L * std::floor(xk / L);
          if (xk >= L) xk = 0.0;
          if (!(xk >= 0.0 && xk < L)) fault = 1;
        }
      } else if (xk < 0.0 || xk > L) {
        fault = 1;
      }
    }
  }
  {
    CommTimer timer(stats_.commSeconds);
    mpiCheck(MPI_Allreduce(MPI_IN_PLACE, &fault, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD), "MPI_Allreduce");
  }
  if (fault != 0) {
    failCollectively(
        fmt::format("step {}: a particle has a non-finite position or left the walled box {} "
                    "(found at a neighbour-list rebuild)",
                    step_, box_.describe()));
  }
}

double DistributedDem::orderDecay() {
  // DemSimulation::orderDecay() on the global slot order (= the keys): the cells' particle counts summed over
  // the ranks give every cell's slot range, then each rank counts its misplaced owned particles. Integer sums:
  // the same count, so the same decision, as the serial run.
  const Index n = static_cast<Index>(total_);
  const int bits = integrators::orderDecayBits(n, settings_.resort.cellParticles);
  if (bits == 0) return 0.0;
  const std::size_t cells = std::size_t{1} << (3 * bits);
  std::vector<std::int64_t> start(cells + 1, 0);
  for (const Index i : ownedSlots_) ++start[integrators::coarseCell(&x_(0, i), box_, bits) + 1];
  CommTimer timer(stats_.commSeconds);
  mpiCheck(
      MPI_Allreduce(MPI_IN_PLACE, start.data() + 1, toInt(cells, "coarse cells"), MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD),
      "MPI_Allreduce");
  for (std::size_t c = 0; c < cells; ++c) start[c + 1] += start[c];
  std::int64_t misplaced = 0;
  for (const Index i : ownedSlots_) {
    const std::uint64_t c = integrators::coarseCell(&x_(0, i), box_, bits);
    const std::int64_t key = key_[static_cast<std::size_t>(i)];
    misplaced += (key < start[c] || key >= start[c + 1]) ? 1 : 0;
  }
  mpiCheck(MPI_Allreduce(MPI_IN_PLACE, &misplaced, 1, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD), "MPI_Allreduce");
  return static_cast<double>(misplaced) / static_cast<double>(n);
}

Eigen::MatrixXd DistributedDem::gatherOwned(const Eigen::MatrixXd& rows) {
  // Per owned particle (key, its column of `rows`), from every rank; then placed by key.
  const auto width = static_cast<std::size_t>(rows.rows());
  std::vector<double> mine;
  mine.reserve((width + 1) * ownedSlots_.size());
  for (const Index i : ownedSlots_) {
    mine.push_back(static_cast<double>(key_[static_cast<std::size_t>(i)]));
    for (std::size_t k = 0; k < width; ++k) mine.push_back(rows(static_cast<Index>(k), i));
  }
  const auto N = static_cast<std::size_t>(total_);
  std::vector<int> counts(static_cast<std::size_t>(size_)), offsets(static_cast<std::size_t>(size_) + 1, 0);
  std::vector<double> all((width + 1) * N);
  {
    CommTimer timer(stats_.commSeconds);
    const int count = toInt(mine.size(), "gathered particle values");
    mpiCheck(MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, MPI_COMM_WORLD), "MPI_Allgather");
    for (std::size_t q = 0; q < counts.size(); ++q) offsets[q + 1] = offsets[q] + counts[q];
    if (static_cast<std::size_t>(offsets.back()) != all.size()) {
      throw std::logic_error("DistributedDem::gatherOwned: owned particles do not add up to the system");
    }
    mpiCheck(MPI_Allgatherv(mine.data(), count, MPI_DOUBLE, all.data(), counts.data(), offsets.data(), MPI_DOUBLE,
                            MPI_COMM_WORLD),
             "MPI_Allgatherv");
  }
  Eigen::MatrixXd out(static_cast<Index>(width), static_cast<Index>(N));
  for (std::size_t o = 0; o < N; ++o) {
    const double* rec = all.data() + (width + 1) * o;
    const auto key = static_cast<Index>(rec[0]);
    for (std::size_t k = 0; k < width; ++k) out(static_cast<Index>(k), key) = rec[1 + k];
  }
  return out;
}

void DistributedDem::resort() {
  // DemSimulation::resortParticles(): wrap, the Morton order of all centres (integrators::mortonOrder on the
  // global centres in key order, gathered on every rank: the serial function gives the serial order), new keys
  // = new serial slots, then a build, whose migration puts every rank's particles in the new key order.
  wrapOwned();
  const Eigen::Matrix3Xd centres = gatherOwned(x_);
  const std::vector<Index> order = integrators::mortonOrder(centres, box_);
  std::vector<Index> newKey(order.size());
  for (std::size_t k = 0; k < order.size(); ++k) newKey[static_cast<std::size_t>(order[k])] = static_cast<Index>(k);
  for (const Index i : ownedSlots_)
    key_[static_cast<std::size_t>(i)] = newKey[static_cast<std::size_t>(key_[static_cast<std::size_t>(i)])];
  ++resorts_;
  rebuild();
}

void DistributedDem::rebuild() {
  // 1. Wrap (DemSimulation::rebuild() wraps first too).
  wrapOwned();
  if (resample_) {
    auto* chooser = dynamic_cast<broadphase::AutoSelect*>(backend_.get());
    chooser->setSample(std::span<const double>(sampleRadii_.data(), static_cast<std::size_t>(sampleRadii_.size())),
                       box_, skin_);
    resample_ = false;
  }

  rebalance();

  // 2. New owners; the springs of every active contact go with each of its particles that moves, and stay
  //    here when one of its particles stays.
  const auto P = static_cast<std::size_t>(size_);
  const int width = kernel_.historyWidth;
  std::vector<int> dest(static_cast<std::size_t>(n_), -1);
  for (const Index i : ownedSlots_) dest[static_cast<std::size_t>(i)] = grid_.owner(&x_(0, i));
  std::vector<std::vector<double>> pairOut(P), wallOut(P), particleOut(P);
  std::vector<double> pairPool, wallPool;
  auto put = [&](std::vector<double>& to, std::uint64_t key, const double* values) {
    to.push_back(keyBits(key));
    to.insert(to.end(), values, values + width);
  };
  if (width > 0) {
    for (Index i = 0; i < n_; ++i) {
      for (Index c = list_.offset[i]; c < list_.offset[i + 1]; ++c) {
        const double* values = pairHistory_.values(static_cast<std::size_t>(c));
        if (!active(values, width)) continue;
        const Index j = list_.neighbour[c];
        const int di = dest[static_cast<std::size_t>(i)], dj = dest[static_cast<std::size_t>(j)];
        const std::uint64_t key = pairKeys_[static_cast<std::size_t>(c)];
        if (di == rank_ || dj == rank_) put(pairPool, key, values);
        if (di >= 0 && di != rank_) put(pairOut[static_cast<std::size_t>(di)], key, values);
        if (dj >= 0 && dj != rank_ && dj != di) put(pairOut[static_cast<std::size_t>(dj)], key, values);
      }
    }
    for (std::size_t c = 0; c < list_.wallParticle.size(); ++c) {
      const double* values = wallHistory_.values(c);
      if (!active(values, width)) continue;
      const int d = dest[static_cast<std::size_t>(list_.wallParticle[c])];
      put(d == rank_ ? wallPool : wallOut[static_cast<std::size_t>(d)], wallKeys_[c], values);
    }
  }
  // Kept particles stay in their slots (ascending slots follow ascending keys); only the leaving ones are packed.
  std::vector<Index> kept;
  kept.reserve(ownedSlots_.size());
  for (const Index i : ownedSlots_) {
    const int d = dest[static_cast<std::size_t>(i)];
    if (d == rank_) {
      kept.push_back(i);
    } else {
      packRecord(i, particleOut[static_cast<std::size_t>(d)]);
      stats_.migrated += 1.0;
    }
  }
  const auto W = static_cast<std::size_t>(recordWidth());
  std::vector<double> arrivals;  // records of the particles that came, one run per sender
  std::vector<int> arrivalCount;
  {
    CommTimer timer(stats_.commSeconds);
    allToAll(particleOut, arrivals, arrivalCount);
    std::vector<double> in;
    std::vector<int> inCount;
    allToAll(pairOut, in, inCount);
    pairPool.insert(pairPool.end(), in.begin(), in.end());
    allToAll(wallOut, in, inCount);
    wallPool.insert(wallPool.end(), in.begin(), in.end());
  }

  // 3. Owned particles in key order, as (key, code): code < kept.size() is the kept particle in slot kept[code],
  //    a larger code the arrival code - kept.size(). The largest owned radius of every rank.
  const int rOff = rotation_ ? 17 : 11;
  const std::size_t keptCount = kept.size();
  const std::size_t owned = keptCount + arrivals.size() / W;
  const auto arrival = [&](std::size_t code) { return arrivals.data() + (code - keptCount) * W; };
  const auto centreOf = [&](std::size_t code) -> const double* {
    return code < keptCount ? &x_(0, kept[code]) : arrival(code) + kX;
  };
  const auto radiusOf = [&](std::size_t code) { return code < keptCount ? r_[kept[code]] : arrival(code)[rOff]; };
  std::vector<std::pair<double, std::size_t>> order;
  order.reserve(owned);
  for (std::size_t o = 0; o < keptCount; ++o)
    order.emplace_back(static_cast<double>(key_[static_cast<std::size_t>(kept[o])]), o);
  for (std::size_t code = keptCount; code < owned; ++code) order.emplace_back(arrival(code)[0], code);
  std::vector<std::size_t> ownedRuns{0, keptCount};  // the kept particles, then one run per sender
  for (const int c : arrivalCount) ownedRuns.push_back(ownedRuns.back() + static_cast<std::size_t>(c) / W);
  sortRuns(order, ownedRuns, [](const auto& a, const auto& b) { return a.first < b.first; });
  double rmaxMine = -1.0;
  for (std::size_t code = 0; code < owned; ++code) rmaxMine = std::max(rmaxMine, radiusOf(code));
  {
    CommTimer timer(stats_.commSeconds);
    mpiCheck(MPI_Allgather(&rmaxMine, 1, MPI_DOUBLE, rmax_.data(), 1, MPI_DOUBLE, MPI_COMM_WORLD), "MPI_Allgather");
  }

  {
    std::vector<double> centres, radii;
    centres.reserve(3 * owned);
    radii.reserve(owned);
    for (std::size_t code = 0; code < owned; ++code) {
      const double* x = centreOf(code);
      centres.insert(centres.end(), x, x + 3);
      radii.push_back(radiusOf(code));
    }
    exchangeReach(centres, radii);
  }

  // 4. Ghosts: every owned particle that can come within the skin of some particle of rank q.
  std::vector<std::vector<double>> ghostOut(P);
  std::vector<std::vector<std::size_t>> sendIndex(P);  // position in `order` of each particle sent to q
  stats_.coarseGhosts = 0.0;
  for (std::size_t o = 0; o < owned; ++o) {
    const std::size_t code = order[o].second;
    const double* x = centreOf(code);
    const double r = radiusOf(code);
    for (int q = 0; q < size_; ++q) {
      if (q == rank_) continue;
      stats_.coarseGhosts += coarseGhost(x, r, q) ? 1.0 : 0.0;
      if (!needsGhost(x, r, q)) continue;
      std::vector<double>& out = ghostOut[static_cast<std::size_t>(q)];
      if (code < keptCount) {
        packRecord(kept[code], out);
      } else {
        out.insert(out.end(), arrival(code), arrival(code) + W);
      }
      sendIndex[static_cast<std::size_t>(q)].push_back(o);
    }
  }
  std::vector<double> ghosts;
  std::vector<int> ghostCount;
  {
    CommTimer timer(stats_.commSeconds);
    allToAll(ghostOut, ghosts, ghostCount);
  }

  // 5. Owned and ghosts merged in key order, into new arrays (the kept particles are read from the old ones).
  const std::size_t ghostTotal = ghosts.size() / W;
  std::vector<std::pair<double, std::size_t>> merged;  // (key, o < owned: order[o]; else owned + ghost index)
  merged.reserve(owned + ghostTotal);
  for (std::size_t o = 0; o < owned; ++o) merged.emplace_back(order[o].first, o);
  for (std::size_t gI = 0; gI < ghostTotal; ++gI) merged.emplace_back(ghosts[gI * W], owned + gI);
  std::vector<std::size_t> mergedRuns{0, owned};  // the owned particles, then one run of ghosts per sender
  for (const int c : ghostCount) mergedRuns.push_back(mergedRuns.back() + static_cast<std::size_t>(c) / W);
  sortRuns(merged, mergedRuns, std::less<>{});
  const auto n = static_cast<Index>(merged.size());
  std::vector<Index> key(merged.size()), id(merged.size());
  std::vector<std::uint8_t> mine(merged.size());
  Eigen::Matrix3Xd x(3, n), v(3, n), vp(3, n), w, wp, tq;
  Eigen::VectorXd r(n), invm(n), invI;
  if (rotation_) {
    w.resize(3, n);
    wp.resize(3, n);
    tq.resize(3, n);
    invI.resize(n);
    // Without a rotating kernel nothing writes torques (the serial store keeps its zeros); with one, the
    // force loop overwrites them.
    tq.setZero();
  }
  // Forces are read only where they were carried (a build within a compression step); the force loop
  // overwrites them otherwise.
  Eigen::Matrix3Xd f(3, n);
  const int fOff = rOff + (rotation_ ? 3 : 2);
  std::vector<Index> slotOf(merged.size());
  ownedSlots_.clear();
  for (std::size_t s = 0; s < merged.size(); ++s) {
    const std::size_t code = merged[s].second;
    const auto k = static_cast<Index>(s);
    slotOf[code] = k;
    mine[s] = code < owned;
    if (mine[s]) ownedSlots_.push_back(k);
    const std::size_t source = mine[s] ? order[code].second : 0;
    if (mine[s] && source < keptCount) {
      const Index i = kept[source];
      key[s] = key_[static_cast<std::size_t>(i)];
      id[s] = id_[static_cast<std::size_t>(i)];
      x.col(k) = x_.col(i);
      v.col(k) = v_.col(i);
      vp.col(k) = vp_.col(i);
      if (rotation_) {
        w.col(k) = w_.col(i);
        wp.col(k) = wp_.col(i);
        invI[k] = invI_[i];
      }
      r[k] = r_[i];
      invm[k] = invm_[i];
      if (carryForces_) {
        f.col(k) = f_.col(i);
        if (rotation_) tq.col(k) = tq_.col(i);
      }
      continue;
    }
    const double* rec = mine[s] ? arrival(source) : ghosts.data() + (code - owned) * W;
    key[s] = static_cast<Index>(rec[0]);
    id[s] = static_cast<Index>(rec[1]);
    for (int c = 0; c < 3; ++c) {
      x(c, k) = rec[kX + c];
      v(c, k) = rec[kV + c];
      vp(c, k) = rec[kVp + c];
    }
    if (rotation_) {
      for (int c = 0; c < 3; ++c) {
        w(c, k) = rec[kW + c];
        wp(c, k) = rec[kWp + c];
      }
      invI[k] = rec[rOff + 2];
    }
    r[k] = rec[rOff];
    invm[k] = rec[rOff + 1];
    if (carryForces_) {
      for (int c = 0; c < 3; ++c) f(c, k) = rec[fOff + c];
      if (rotation_) {
        for (int c = 0; c < 3; ++c) tq(c, k) = rec[fOff + 3 + c];
      }
    }
  }
  n_ = n;
  key_.swap(key);
  id_.swap(id);
  owned_.swap(mine);
  x_.swap(x);
  v_.swap(v);
  vp_.swap(vp);
  f_.swap(f);
  r_.swap(r);
  invm_.swap(invm);
  if (rotation_) {
    w_.swap(w);
    wp_.swap(wp);
    tq_.swap(tq);
    invI_.swap(invI);
  }
  std::size_t ghostBase = owned;
  for (std::size_t q = 0; q < P; ++q) {
    sendSlots_[q].clear();
    for (const std::size_t o : sendIndex[q]) sendSlots_[q].push_back(slotOf[o]);
    recvSlots_[q].clear();
    const std::size_t count = static_cast<std::size_t>(ghostCount[q]) / W;
    for (std::size_t gI = 0; gI < count; ++gI) recvSlots_[q].push_back(slotOf[ghostBase + gI]);
    ghostBase += count;
    // Slots follow the global keys on every rank, so both ends listed in ascending slots name the same particles
    // in the same order (ascending key), and the per-step packing and unpacking stream through the arrays
    // instead of jumping (in record order they cost 6% of a rank at N = 50,000).
    std::sort(sendSlots_[q].begin(), sendSlots_[q].end());
    std::sort(recvSlots_[q].begin(), recvSlots_[q].end());
  }
  setupGhostBuffers();

  // 6. The list and the springs.
  refR_ = r_;
  buildList(x_, refR_);
  growth_ = 0.0;
  remapHistories(pairPool, wallPool);
}

void DistributedDem::rebalance() {
  // Cost of an owned particle: 1 + its candidate pairs in the list of the last build.
  std::vector<double> weight(static_cast<std::size_t>(n_), 0.0);
  for (Index i = 0; i < n_; ++i) {
    for (Index c = list_.offset[i]; c < list_.offset[i + 1]; ++c) {
      weight[static_cast<std::size_t>(i)] += 1.0;
      weight[static_cast<std::size_t>(list_.neighbour[c])] += 1.0;
    }
  }
  double cost = 0.0;
  for (const Index i : ownedSlots_) {
    weight[static_cast<std::size_t>(i)] += 1.0;
    cost += weight[static_cast<std::size_t>(i)];
  }
  stats_.cost = cost;
  double reduced[2] = {cost, cost};
  {
    CommTimer timer(stats_.commSeconds);
    mpiCheck(MPI_Allreduce(MPI_IN_PLACE, &reduced[0], 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD), "MPI_Allreduce");
    mpiCheck(MPI_Allreduce(MPI_IN_PLACE, &reduced[1], 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD), "MPI_Allreduce");
  }
  const double mean = reduced[1] / size_;
  if (grid_.kind() != DecompositionKind::Bisection || !(reduced[0] > (1.0 + rebalanceThreshold_) * mean)) return;
  CommTimer timer(stats_.commSeconds);
  grid_ = Decomposition::bisection(box_, size_, [&](const Region& region, int axis, double cut) {
    double w = 0.0;
    for (const Index i : ownedSlots_) {
      const double* x = &x_(0, i);
      if (x[axis] < cut && inside(region, x, box_)) w += weight[static_cast<std::size_t>(i)];
    }
    mpiCheck(MPI_Allreduce(MPI_IN_PLACE, &w, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD), "MPI_Allreduce");
    return w;
  });
  ++rebalances_;
}

contact::ForceContext DistributedDem::context() {
  contact::ForceContext c;
  c.count = n_;
  c.position = x_.data();
  c.velocityHalf = v_.data();
  c.velocity = predict_ ? vp_.data() : v_.data();
  c.radius = r_.data();
  c.inverseMass = invm_.data();
  c.force = f_.data();
  if (kernel_.rotation) {
    c.angularVelocityHalf = w_.data();
    c.angularVelocity = predict_ ? wp_.data() : w_.data();
    c.inverseInertia = invI_.data();
    c.torque = tq_.data();
  }
  c.list = &list_;
  c.pairHistory = &pairHistory_;
  c.wallHistory = &wallHistory_;
  for (int k = 0; k < 3; ++k) {
    c.length[k] = box_.length(k);
    c.halfLength[k] = box_.periodic(k) ? 0.5 * box_.length(k) : std::numeric_limits<double>::infinity();
    c.gravity[k] = settings_.gravity[k];
  }
  c.viscousRate = settings_.viscousDamping;
  c.dt = dt_;
  c.threads = settings_.threads;
  c.crossScratch = crossScratch_.data();
  c.crossTouching = crossTouching_.data();
  // Centres only: a rank does not track its touching share (the choice changes no result).
  c.lookAhead = contact::chooseLookAhead(n_, 0.0, kernel_.batched());
  return c;
}

void DistributedDem::computeForces() {
  if (n_ > 0) kernel_.run(model_, context());
}

void DistributedDem::growRadii(double factor) {
  // DemSimulation::growRadii() on every local particle (ghosts included: the same multiplication gives the
  // owner's bytes), with the serial growth bound from the global largest radius (max r_i x factor is the largest
  // of the products: rounding is monotonic). A build it makes comes between two steps, so the forces of the last
  // step travel with the migrating particles (the next opening kick uses them).
  if (!(factor >= 1.0 && std::isfinite(factor))) {
    throw ConfigError(fmt::format("growRadii: factor must be >= 1, got {}", factor));
  }
  if (conservative_) {
    // The serial run restarts its energy check from the total energy, a global sum in serial order.
    throw std::logic_error("DistributedDem::growRadii: a dissipation-free run (its energy reference) is not supported");
  }
  const double f3 = factor * factor * factor;
  auto* chooser = dynamic_cast<broadphase::AutoSelect*>(backend_.get());
  if (chooser && sampleRadii_.size() == 0) {
    sampleRadii_ = gatherOwned(r_.transpose()).row(0).transpose();  // once: only a compression pays it
  }
  growth_ += (factor - 1.0) * rmaxGlobal_;
  rmaxGlobal_ *= factor;
  r_ *= factor;
  if (chooser) {
    // `auto` chose for the system's radii (the constructor): the next build chooses for the grown ones, on every
    // rank alike (the same radii, box, skin and K).
    sampleRadii_ *= factor;
    resample_ = true;
  }
  invm_ /= f3;
  if (rotation_) invI_ /= f3 * factor * factor;
  if (growth_ > 0.5 * skin_) {
    carryForces_ = true;
    rebuild();
    carryForces_ = false;
  }
}

double DistributedDem::maxOverlapRatio() {
  double local = n_ > 0 ? contact::measureContacts(model_, context()).maxOverlapRatio : 0.0;
  CommTimer timer(stats_.commSeconds);
  mpiCheck(MPI_Allreduce(MPI_IN_PLACE, &local, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD), "MPI_Allreduce");
  return local;
}

std::int64_t DistributedDem::advance(std::int64_t steps, bool stopOnInterrupt) {
  const double start = MPI_Wtime();
  // As DemSimulation::advance: a step's closing half kick joins the next step's opening pass when that step
  // follows at once. The decision uses only what every rank shares (the step, the reduced interrupt flag).
  const std::int64_t checkInterval = settings_.stability.checkInterval;
  bool closePending = false;
  for (std::int64_t s = 0; s < steps; ++s) {
    const double limit = std::max(0.0, 0.5 * skin_ - growth_);
    // One reduction per step: the largest displacement (the rebuild decision, exact) and the interrupt flag.
    const double t0 = MPI_Wtime();
    double reduced[2] = {openingKickAndDrift(closePending), interruptRequested() ? 1.0 : 0.0};
    const double t1 = MPI_Wtime();
    {
      CommTimer timer(stats_.commSeconds);
      mpiCheck(MPI_Allreduce(MPI_IN_PLACE, reduced, 2, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD), "MPI_Allreduce");
    }
    const double t2 = MPI_Wtime();
    if (reduced[1] > 0.0) interrupted_ = true;
    // As DemSimulation::advance: a re-sort at fixed steps when the order has decayed, else the rebuild rule.
    const integrators::ResortRule& rule = settings_.resort;
    bool built = true;
    if (settings_.spatialSort && rule.interval > 0 && (step_ + 1) % rule.interval == 0 &&
        orderDecay() > rule.threshold) {
      resort();
    } else if (reduced[0] > limit * limit) {
      rebuild();
    } else {
      built = false;
      exchangeGhosts();
    }
    const double t3 = MPI_Wtime();
    computeForces();
    const double t4 = MPI_Wtime();
    closePending = integrators::joinClosingKick(s, steps, step_ + 1, checkInterval, stopOnInterrupt && interrupted_);
    if (!closePending) closingKick();
    const double t5 = MPI_Wtime();
    stats_.integrationSeconds += (t1 - t0) + (t5 - t4);
    stats_.reductionSeconds += t2 - t1;
    (built ? stats_.buildSeconds : stats_.ghostSeconds) += t3 - t2;
    stats_.forceSeconds += t4 - t3;
    ++step_;
    if (settings_.stability.checkInterval > 0 && step_ % settings_.stability.checkInterval == 0) {
      check();
      stats_.checkSeconds += MPI_Wtime() - t5;
    }
    if (stopOnInterrupt && interrupted_) {
      stats_.loopSeconds += MPI_Wtime() - start;
      return s + 1;
    }
  }
  stats_.loopSeconds += MPI_Wtime() - start;
  return steps;
}

// ---- checks, gather, statistics -------------------------------------------------------------------------

void DistributedDem::check() {
  // The serial check's local parts here; its messages (and the energy of elastic runs, a global sum) from the
  // serial code on the gathered state, so a failing run reports what the serial run reports.
  double local[2] = {0.0, 0.0};
  for (const Index i : ownedSlots_) {
    bool bad = !x_.col(i).allFinite() || !v_.col(i).allFinite() || (rotation_ && !w_.col(i).allFinite());
    for (int k = 0; k < 3; ++k) bad |= !box_.periodic(k) && (x_(k, i) < 0.0 || x_(k, i) > box_.length(k));
    if (bad) local[0] = 1.0;
  }
  if (n_ > 0) local[1] = contact::measureContacts(model_, context()).maxOverlapRatio;
  {
    CommTimer timer(stats_.commSeconds);
    mpiCheck(MPI_Allreduce(MPI_IN_PLACE, local, 2, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD), "MPI_Allreduce");
  }
  const bool fault = local[0] > 0.0 || !(local[1] <= settings_.stability.maxOverlapFraction);
  if (!fault && !conservative_) return;
  const integrators::DemState state = gather();
  std::string message;
  if (rank_ == 0) {
    try {
      integrators::DemSimulation::restore(state, settings_).checkStability();
    } catch (const std::exception& e) {
      message = e.what();
    }
  }
  std::int64_t length = static_cast<std::int64_t>(message.size());
  {
    CommTimer timer(stats_.commSeconds);
    mpiCheck(MPI_Bcast(&length, 1, MPI_INT64_T, 0, MPI_COMM_WORLD), "MPI_Bcast");
    message.resize(static_cast<std::size_t>(length));
    if (length > 0)
      mpiCheck(MPI_Bcast(message.data(), static_cast<int>(length), MPI_CHAR, 0, MPI_COMM_WORLD), "MPI_Bcast");
  }
  if (!message.empty()) throw CollectiveError(message);
  if (fault) {
    throw CollectiveError(
        fmt::format("step {}: the stability check failed on some rank (non-finite state, a particle "
                    "outside the walled box or an overlap above {:g} of the smaller radius)",
                    step_, settings_.stability.maxOverlapFraction));
  }
}

void DistributedDem::failCollectively(const std::string& fallback) {
  const integrators::DemState state = gather();
  std::string message;
  if (rank_ == 0) {
    try {
      integrators::DemSimulation::restore(state, settings_).checkStability();
    } catch (const std::exception& e) {
      message = e.what();
    }
  }
  std::int64_t length = static_cast<std::int64_t>(message.size());
  mpiCheck(MPI_Bcast(&length, 1, MPI_INT64_T, 0, MPI_COMM_WORLD), "MPI_Bcast");
  message.resize(static_cast<std::size_t>(length));
  if (length > 0)
    mpiCheck(MPI_Bcast(message.data(), static_cast<int>(length), MPI_CHAR, 0, MPI_COMM_WORLD), "MPI_Bcast");
  throw CollectiveError(message.empty() ? fallback : message);
}

integrators::DemState DistributedDem::gather() {
  CommTimer timer(stats_.commSeconds);
  // Per owned particle: key, id, x, v, F, [w, torque], r, 1/m, [1/I], x_build, r_build.
  const int W = rotation_ ? 24 : 17;
  std::vector<double> mine;
  mine.reserve(ownedSlots_.size() * static_cast<std::size_t>(W));
  for (const Index i : ownedSlots_) {
    mine.push_back(static_cast<double>(key_[static_cast<std::size_t>(i)]));
    mine.push_back(static_cast<double>(id_[static_cast<std::size_t>(i)]));
    for (int k = 0; k < 3; ++k) mine.push_back(x_(k, i));
    for (int k = 0; k < 3; ++k) mine.push_back(v_(k, i));
    for (int k = 0; k < 3; ++k) mine.push_back(f_(k, i));
    if (rotation_) {
      for (int k = 0; k < 3; ++k) mine.push_back(w_(k, i));
      for (int k = 0; k < 3; ++k) mine.push_back(tq_(k, i));
    }
    mine.push_back(r_[i]);
    mine.push_back(invm_[i]);
    if (rotation_) mine.push_back(invI_[i]);
    for (int k = 0; k < 3; ++k) mine.push_back(ref_(k, i));
    mine.push_back(refR_[i]);
  }
  // Active springs: each pair once, by the owner of its row (the lower slot); walls by their particle's owner.
  const int width = kernel_.historyWidth;
  std::vector<double> springs, wallSprings;
  if (width > 0) {
    for (Index i = 0; i < n_; ++i) {
      if (!owned_[static_cast<std::size_t>(i)]) continue;
      for (Index c = list_.offset[i]; c < list_.offset[i + 1]; ++c) {
        const double* values = pairHistory_.values(static_cast<std::size_t>(c));
        if (!active(values, width)) continue;
        springs.push_back(keyBits(pairKeys_[static_cast<std::size_t>(c)]));
        springs.insert(springs.end(), values, values + width);
      }
    }
    for (std::size_t c = 0; c < list_.wallParticle.size(); ++c) {
      const double* values = wallHistory_.values(c);
      if (!active(values, width)) continue;
      wallSprings.push_back(keyBits(wallKeys_[c]));
      wallSprings.insert(wallSprings.end(), values, values + width);
    }
  }
  auto gatherAll = [&](const std::vector<double>& local) {
    const int count = toInt(local.size(), "gather to rank 0");
    std::vector<int> counts(static_cast<std::size_t>(size_)), displs(static_cast<std::size_t>(size_));
    mpiCheck(MPI_Gather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, MPI_COMM_WORLD), "MPI_Gather");
    std::vector<double> all;
    if (rank_ == 0) {
      std::size_t total = 0;
      for (int q = 0; q < size_; ++q) {
        displs[static_cast<std::size_t>(q)] = toInt(total, "gather to rank 0");
        total += static_cast<std::size_t>(counts[static_cast<std::size_t>(q)]);
      }
      toInt(total, "gather to rank 0");
      all.resize(total);
    }
    mpiCheck(MPI_Gatherv(local.data(), count, MPI_DOUBLE, all.data(), counts.data(), displs.data(), MPI_DOUBLE, 0,
                         MPI_COMM_WORLD),
             "MPI_Gatherv");
    return all;
  };
  const std::vector<double> particles = gatherAll(mine);
  const std::vector<double> allSprings = gatherAll(springs);
  const std::vector<double> allWallSprings = gatherAll(wallSprings);
  integrators::DemState s;
  if (rank_ != 0) return s;

  const auto n = static_cast<Index>(particles.size() / static_cast<std::size_t>(W));
  s.box = box_;
  s.step = step_;
  s.timeOrigin = timeOrigin_;
  s.timeStep = timeStep_;
  s.skin = skin_;
  s.initialEnergy = initialEnergy_;
  s.growthSinceBuild = growth_;
  s.builds = builds_;
  s.rotation = rotation_;
  s.id.resize(static_cast<std::size_t>(n));
  s.position.resize(3, n);
  s.velocity.resize(3, n);
  s.force.resize(3, n);
  s.radius.resize(n);
  s.inverseMass.resize(n);
  s.referencePosition.resize(3, n);
  s.referenceRadius.resize(n);
  if (rotation_) {
    s.angularVelocity.resize(3, n);
    s.torque.resize(3, n);
    s.inverseInertia.resize(n);
  }
  std::vector<std::uint8_t> seen(static_cast<std::size_t>(n), 0);
  for (Index e = 0; e < n; ++e) {
    const double* rec = particles.data() + static_cast<std::size_t>(e) * static_cast<std::size_t>(W);
    const auto k = static_cast<Index>(rec[0]);
    if (k < 0 || k >= n || seen[static_cast<std::size_t>(k)]) {
      throw std::logic_error(fmt::format("DistributedDem::gather: slot {} missing or owned twice", k));
    }
    seen[static_cast<std::size_t>(k)] = 1;
    s.id[static_cast<std::size_t>(k)] = static_cast<Index>(rec[1]);
    int o = 2;
    for (int c = 0; c < 3; ++c) s.position(c, k) = rec[o++];
    for (int c = 0; c < 3; ++c) s.velocity(c, k) = rec[o++];
    for (int c = 0; c < 3; ++c) s.force(c, k) = rec[o++];
    if (rotation_) {
      for (int c = 0; c < 3; ++c) s.angularVelocity(c, k) = rec[o++];
      for (int c = 0; c < 3; ++c) s.torque(c, k) = rec[o++];
    }
    s.radius[k] = rec[o++];
    s.inverseMass[k] = rec[o++];
    if (rotation_) s.inverseInertia[k] = rec[o++];
    for (int c = 0; c < 3; ++c) s.referencePosition(c, k) = rec[o++];
    s.referenceRadius[k] = rec[o++];
  }
  if (width > 0) {
    // The serial list of the last build (same pairs, same order as DemSimulation::restore() rebuilds), then
    // every spring from the ranks, zero for the inactive ones.
    integrators::VerletList serial(broadphase::makeBroadPhase(settings_.broadPhase), skin_);
    serial.build(SphereView{s.referencePosition, s.referenceRadius}, box_);
    serial.keys(s.id, s.pairKeys, s.wallKeys);
    auto fill = [&](const std::vector<double>& pool, const std::vector<std::uint64_t>& listKeys,
                    std::vector<double>& values) {
      std::vector<std::uint64_t> keys;
      std::vector<double> sortedValues;
      sortedHistory(pool, width, keys, sortedValues);
      values.assign(listKeys.size() * static_cast<std::size_t>(width), 0.0);
      for (std::size_t c = 0; c < listKeys.size(); ++c) {
        const auto it = std::lower_bound(keys.begin(), keys.end(), listKeys[c]);
        if (it == keys.end() || *it != listKeys[c]) continue;
        const auto a = static_cast<std::size_t>(it - keys.begin());
        std::copy_n(sortedValues.begin() + static_cast<std::ptrdiff_t>(a * static_cast<std::size_t>(width)), width,
                    values.begin() + static_cast<std::ptrdiff_t>(c * static_cast<std::size_t>(width)));
      }
    };
    fill(allSprings, s.pairKeys, s.pairValues);
    fill(allWallSprings, s.wallKeys, s.wallValues);
  }
  return s;
}

ParallelStats DistributedDem::stats() {
  ParallelStats out;
  out.decomposition = grid_.describe();
  out.rebalances = rebalances_;
  out.resorts = resorts_;
  constexpr int kFields = 15;
  const double mine[kFields] = {stats_.owned,
                                stats_.ghosts,
                                stats_.pairs,
                                stats_.ghostBytesPerStep,
                                stats_.migrated,
                                stats_.cost,
                                stats_.coarseGhosts,
                                stats_.commSeconds,
                                stats_.loopSeconds,
                                stats_.integrationSeconds,
                                stats_.reductionSeconds,
                                stats_.buildSeconds,
                                stats_.ghostSeconds,
                                stats_.forceSeconds,
                                stats_.checkSeconds};
  std::vector<double> all(static_cast<std::size_t>(kFields * size_));
  mpiCheck(MPI_Gather(mine, kFields, MPI_DOUBLE, all.data(), kFields, MPI_DOUBLE, 0, MPI_COMM_WORLD), "MPI_Gather");
  if (rank_ != 0) return out;
  for (int q = 0; q < size_; ++q) {
    const double* a = all.data() + kFields * q;
    out.ranks.push_back(
        RankStats{a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11], a[12], a[13], a[14]});
  }
  return out;
}

}  // namespace polydem::parallel
