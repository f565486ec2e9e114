#pragma once
// Definition of computeForces<Law, kFlags>. Included only by force_kernels_*.cpp, which list the explicit
// instantiations (three laws each, so the two cores of a build share them: the 72 kernels in one file took
// 3 minutes of one core in the checked build); other translation units see the declaration in force_loop.hpp.
#include <Eigen/Core>
#include <Eigen/Geometry>  // cross products
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <type_traits>

#include "contact/force_loop.hpp"
#include "contact/hertz_mindlin.hpp"  // its tangentialForce overload, found by the calls below
#include "core/errors.hpp"
#include "polydem/config.hpp"

namespace polydem::contact {

namespace detail {

using Vec3 = Eigen::Vector3d;

inline Vec3 load(const double* a, Index i) { return Vec3(a[3 * i], a[3 * i + 1], a[3 * i + 2]); }
inline void add(double* a, Index i, const Vec3& v) {
  a[3 * i] += v[0];
  a[3 * i + 1] += v[1];
  a[3 * i + 2] += v[2];
}
inline void subtract(double* a, Index i, const Vec3& v) {
  a[3 * i] -= v[0];
  a[3 * i + 1] -= v[1];
  a[3 * i + 2] -= v[2];
}

/// Cundall-Strack tangential force for one contact. `vt` is the tangential contact-point velocity for
/// the dashpot (predicted v(t + dt)), `vtHalf` the one for the spring increment (v(t + dt/2)). `xi`
/// holds the spring displacement (3 doubles), updated in place. Returns the tangential force on i.
inline Vec3 tangentialForce(const CundallStrack::Params& p, const NormalForce& nf, const Vec3& n, const Vec3& vt,
                            const Vec3& vtHalf, double dt, double* xi) {
  Vec3 s(xi[0], xi[1], xi[2]);
  // Rotate the spring onto the current tangent plane, keeping its length (the contact turned).
  const double along = s.dot(n);
  if (along != 0.0) {
    const double before = s.squaredNorm();
    s -= along * n;
    const double after = s.squaredNorm();
    if (after > 0.0) s *= std::sqrt(before / after);
  }
  s += dt * vtHalf;
  const double kt = p.stiffnessRatio * nf.stiffness;
  const double ct = p.dampingRatio * nf.damping;
  Vec3 ft = -kt * s - ct * vt;
  const double limit = p.friction * std::max(nf.force, 0.0);
  const double ftSq = ft.squaredNorm();
  if (ftSq > limit * limit) {
    // Sliding: cap at the Coulomb limit and shorten the spring to match (LAMMPS gran/hooke/history).
    ft *= limit / std::sqrt(ftSq);
    s = -(ft + ct * vt) / kt;
  }
  xi[0] = s[0];
  xi[1] = s[1];
  xi[2] = s[2];
  return ft;
}

/// LAMMPS gran/hooke/history's tangential force for one contact (see LammpsHistory): the spring grows by
/// v_t(t + dt/2) dt first and is projected onto the tangent plane after; the Coulomb cap is mu |F_n|.
inline Vec3 tangentialForce(const LammpsHistory::Params& p, const NormalForce& nf, const Vec3& n, const Vec3& vt,
                            const Vec3& vtHalf, double dt, double* xi, std::true_type /*lammps*/) {
  Vec3 s(xi[0], xi[1], xi[2]);
  s += dt * vtHalf;
  const bool stretched = s.squaredNorm() != 0.0;  // before the projection, as LAMMPS tests it
  s -= s.dot(n) * n;
  const double kt = p.stiffnessRatio * nf.stiffness;
  const double ct = p.dampingRatio * nf.damping;
  Vec3 ft = -(kt * s + ct * vt);
  const double limit = p.friction * std::abs(nf.force);
  const double ftNorm = ft.norm();
  if (ftNorm > limit) {
    if (stretched) {
      const double scale = limit / ftNorm;
      s = scale * (s + ct * vt / kt) - ct * vt / kt;
      ft *= scale;
    } else {
      ft = Vec3::Zero();
    }
  }
  xi[0] = s[0];
  xi[1] = s[1];
  xi[2] = s[2];
  return ft;
}

/// LammpsHistory's variant (full-radius lever arms, its own spring update), else polydem's Cundall-Strack.
template <class Tangential>
constexpr bool kLammpsTangential = std::is_same_v<Tangential, LammpsHistory>;

/// Tangential force of the law's tangential part (Cundall-Strack or LAMMPS's variant).
template <class Tangential>
inline Vec3 lawTangentialForce(const typename Tangential::Params& p, const NormalForce& nf, const Vec3& n,
                               const Vec3& vt, const Vec3& vtHalf, double dt, double* xi) {
  if constexpr (kLammpsTangential<Tangential>) {
    return tangentialForce(p, nf, n, vt, vtHalf, dt, xi, std::true_type{});
  } else {
    return tangentialForce(p, nf, n, vt, vtHalf, dt, xi);
  }
}

/// The row loops' cross-pair callback of the serial loop, which has none: its type removes the cross-pair
/// tests at compile time.
struct NoCross {
  const double* operator()(Index) const { return nullptr; }
};

/// What both pair loops read, copied out of the context once, and the work per particle and per pair.
/// Each loop function keeps its own local copy: nothing takes the serial loop's copy's address, so the
/// compiler keeps it in registers. (With one set of locals shared by both loops, the OpenMP region's
/// capture let every force store alias them, and the serial loop got 15-20% slower.)
template <class Law, KernelFlags kFlags>
struct PairKernel {
  using Normal = typename Law::NormalLaw;
  static constexpr bool kRotation = Law::kUsesRotation;
  static constexpr int kHistory = Law::kHistorySize;

  /// What row i reads for every pair: loaded once per row.
  struct Row {
    double x0, x1, x2, r, invm;
    Vec3 v;
  };

  PairKernel(const typename Law::Params& p, const ForceContext& ctx)
      : params(p),
        x(ctx.position),
        v(ctx.velocity),
        r(ctx.radius),
        invm(ctx.inverseMass),
        f(ctx.force),
        vh(ctx.velocityHalf),
        w(ctx.angularVelocity),
        wh(ctx.angularVelocityHalf),
        inverseInertia(ctx.inverseInertia),
        torque(ctx.torque),
        offset(ctx.list->offset.data()),
        neighbour(ctx.list->neighbour.data()),
        L0(ctx.length[0]),
        L1(ctx.length[1]),
        L2(ctx.length[2]),
        H0(ctx.halfLength[0]),
        H1(ctx.halfLength[1]),
        H2(ctx.halfLength[2]),
        g0(ctx.gravity[0]),
        g1(ctx.gravity[1]),
        g2(ctx.gravity[2]),
        viscousRate(ctx.viscousRate),
        dt(ctx.dt),
        history(kHistory > 0 ? ctx.pairHistory->values(0) : nullptr),
        batching(ctx.batching) {}

  /// Body force on particle i (gravity, viscous damping; else zero), summed in one fixed order.
  Vec3 bodyForce(Index i) const {
    Vec3 fb = Vec3::Zero();
    if constexpr (kFlags.gravity || kFlags.viscous) {
      const double m = 1.0 / invm[i];
      const double g[3] = {g0, g1, g2};
      for (int k = 0; k < 3; ++k) {
        double fk = 0.0;
        if constexpr (kFlags.gravity) fk += m * g[k];
        if constexpr (kFlags.viscous) fk -= viscousRate * m * v[3 * i + k];
        fb[k] = fk;
      }
    }
    return fb;
  }
  Vec3 bodyTorque(Index i) const {
    Vec3 tb = Vec3::Zero();
    if constexpr (kFlags.viscous && kRotation) {
      const double inertia = 1.0 / inverseInertia[i];
      for (int k = 0; k < 3; ++k) tb[k] = -viscousRate * inertia * w[3 * i + k];
    }
    return tb;
  }
  [[gnu::always_inline]] Row loadRow(Index i) const {
    return Row{x[3 * i], x[3 * i + 1], x[3 * i + 2], r[i], invm[i], load(v, i)};
  }

  /// d = x_i - x_j, minimum image (halfLength is +inf on walled axes, so those never shift); returns |d|^2.
  [[gnu::always_inline]] double separation(const Row& a, Index j, double& d0, double& d1, double& d2) const {
    d0 = a.x0 - x[3 * j];
    d1 = a.x1 - x[3 * j + 1];
    d2 = a.x2 - x[3 * j + 2];
    if (d0 > H0) [[unlikely]]
      d0 -= L0;
    else if (d0 < -H0) [[unlikely]]
      d0 += L0;
    if (d1 > H1) [[unlikely]]
      d1 -= L1;
    else if (d1 < -H1) [[unlikely]]
      d1 += L1;
    if (d2 > H2) [[unlikely]]
      d2 -= L2;
    else if (d2 < -H2) [[unlikely]]
      d2 += L2;
    return d0 * d0 + d1 * d1 + d2 * d2;
  }

  /// A touching pair's normal, overlap, relative velocity and normal force, from the separation
  /// d = x_i - x_j (minimum image) and rsq = |d|^2 of the contact test. One definition for both loops.
  struct Touch {
    Vec3 nrm;
    double overlap;
    Vec3 vrel;
    NormalForce nf;
  };
  [[gnu::always_inline]] Touch touch(const Row& a, Index j, double d0, double d1, double d2, double rsq) const {
    const Vec3 vrel = a.v - load(v, j);
    return touchFrom(a.r, r[j], a.invm + invm[j], vrel[0], vrel[1], vrel[2], d0, d1, d2, rsq);
  }

  /// The arithmetic of touch() from the pair's gathered inputs: radii, 1/m_i + 1/m_j, v_i - v_j, d and |d|^2.
  /// Without a load through an index, so that the batched loop's compiler vectorises it over the kept pairs.
  [[gnu::always_inline]] Touch touchFrom(double ri, double rj, double invmSum, double vr0, double vr1, double vr2,
                                         double d0, double d1, double d2, double rsq) const {
    const double sumR = ri + rj;
    const double dist = std::sqrt(rsq);
    const double invDist = 1.0 / dist;
    Touch t;
    t.nrm = Vec3(d0 * invDist, d1 * invDist, d2 * invDist);
    t.overlap = sumR - dist;
    const double meff = 1.0 / invmSum;
    const double reff = ri * rj / sumR;
    t.vrel = Vec3(vr0, vr1, vr2);
    const double rate = -((vr0 * t.nrm[0] + vr1 * t.nrm[1]) + vr2 * t.nrm[2]);
    t.nf = Normal::force(params.normal, t.overlap, rate, meff, reff);
    return t;
  }

  /// Candidate pair c = (i, j): false when the spheres do not touch (its history is cleared). Otherwise
  /// fc = force on i (minus the force on j) and, with rotation, the torques on i and j as -tqi, -tqj.
  bool pairForce(Index i, const Row& a, Index c, Index j, Vec3& fc, [[maybe_unused]] Vec3& tqi,
                 [[maybe_unused]] Vec3& tqj) const {
    double d0, d1, d2;
    const double rsq = separation(a, j, d0, d1, d2);
    const double rj = r[j];
    const double sumR = a.r + rj;
    if (rsq >= sumR * sumR) {
      if constexpr (kHistory > 0) std::fill_n(history + kHistory * static_cast<std::size_t>(c), kHistory, 0.0);
      return false;
    }
    const Touch t = touch(a, j, d0, d1, d2, rsq);
    const Vec3& nrm = t.nrm;
    const double overlap = t.overlap;
    const Vec3& vrel = t.vrel;
    const NormalForce& nf = t.nf;
    fc = nf.force * nrm;
    if constexpr (kRotation) {
      constexpr bool kFull = kLammpsTangential<typename Law::TangentialLaw>;  // lever arms r (LAMMPS), r - d/2
      const double ai = kFull ? a.r : a.r - 0.5 * overlap, aj = kFull ? rj : rj - 0.5 * overlap;
      const Vec3 wi = load(w, i), wj = load(w, j);
      Vec3 vc = vrel - (ai * wi + aj * wj).cross(nrm);
      const Vec3 vt = vc - vc.dot(nrm) * nrm;
      const Vec3 vrelHalf = load(vh, i) - load(vh, j);
      Vec3 vch = vrelHalf - (ai * load(wh, i) + aj * load(wh, j)).cross(nrm);
      const Vec3 vtHalf = vch - vch.dot(nrm) * nrm;
      const Vec3 ft = lawTangentialForce<typename Law::TangentialLaw>(params.tangential, nf, nrm, vt, vtHalf, dt,
                                                                      history + kHistory * static_cast<std::size_t>(c));
      fc += ft;
      const Vec3 arm = nrm.cross(ft);  // torque_i = -a_i n x F_t, torque_j = -a_j n x F_t
      tqi = ai * arm;
      tqj = aj * arm;
    }
    return true;
  }

  /// The look-ahead: the data of the candidate kDistance entries after c (LookAhead::None: nothing).
  template <LookAhead kAhead, Index kDistance = kLookAheadDistance>
  [[gnu::always_inline]] void prefetchAhead(Index c, Index lastCandidate) const {
    if constexpr (kAhead != LookAhead::None) {
      const auto ahead = static_cast<std::size_t>(neighbour[std::min(c + kDistance, lastCandidate)]);
      __builtin_prefetch(x + 3 * ahead);
      __builtin_prefetch(r + ahead);
      if constexpr (kAhead == LookAhead::Contacts) {
        __builtin_prefetch(v + 3 * ahead);
        __builtin_prefetch(f + 3 * ahead, 1);
      }
    }
  }

  /// Kernels without rotation or pair history take the batched loop (rowsFlat) unless the context asks for
  /// the one-pass loop; ForceKernel::batched() states the same rule at run time.
  static constexpr bool kBatched = !kRotation && kHistory == 0;

  /// The serial order for rows [begin, end): each row sums its pairs into F_i and scatters -F to j.
  /// Pairs with j >= `ownedEnd` are cross pairs already computed: `cross(c)` returns a pointer to their
  /// stored force (and torque term), or nullptr when they do not touch. The serial loop passes
  /// ownedEnd = n (no cross pairs).
  template <LookAhead kAhead = LookAhead::None, class Cross>
  void rows(Index begin, Index end, Index ownedEnd, Cross cross) const {
    constexpr bool kCross = !std::is_same_v<Cross, NoCross>;
    if constexpr (kBatched) {
      if (batching == Batching::Batched) {
        rowsFlat<kAhead>(begin, end, ownedEnd, cross);
        return;
      }
    }
    [[maybe_unused]] const Index lastCandidate = offset[end] - 1;  // used only when a row has candidates
    for (Index i = begin; i < end; ++i) {
      const Row a = loadRow(i);
      double fi0 = 0.0, fi1 = 0.0, fi2 = 0.0;
      [[maybe_unused]] Vec3 ti = Vec3::Zero();
      const Index rowEnd = offset[i + 1];
      for (Index c = offset[i]; c < rowEnd; ++c) {
        const Index j = neighbour[c];
        prefetchAhead<kAhead>(c, lastCandidate);
        if (kCross && j >= ownedEnd) {
          if (const double* stored = cross(c)) {
            fi0 += stored[0];
            fi1 += stored[1];
            fi2 += stored[2];
            if constexpr (kRotation) ti -= load(stored + 3, 0);
          }
          continue;
        }
        Vec3 fc, tqi, tqj;
        if (!pairForce(i, a, c, j, fc, tqi, tqj)) continue;
        if constexpr (kRotation) {
          ti -= tqi;
          subtract(torque, j, tqj);
        }
        fi0 += fc[0];
        fi1 += fc[1];
        fi2 += fc[2];
        subtract(f, j, fc);
      }
      f[3 * i] += fi0;
      f[3 * i + 1] += fi1;
      f[3 * i + 2] += fi2;
      if constexpr (kRotation) add(torque, i, ti);
    }
  }

  /// Candidates per batch of rowsFlat: its buffers (23-25 KiB) fit in the L1 data cache (32 KiB here).
  static constexpr Index kBatchCandidates = 256;

  /// The same sums as rows(), in the same order, computed in three passes over batches of candidates
  /// taken flat across rows: (0) the row of each candidate of the batch, from the row starts; (1) the contact test of
  /// every candidate, which keeps the touching ones (a cross pair: when its stored force says it touches) in a buffer;
  /// (2) the force of every kept pair, independent of each other, so that their square roots and divisions overlap; (3)
  /// the sums in the order of rows(): F_i over the row in candidate order, -F scattered to j. The contact test no
  /// longer decides a branch (it mispredicted at a rate of the touching share), and a row without a touching pair costs
  /// nothing: the one-pass loop adds +0.0 to its F_i, which changes no force (the forces start at +0.0 or a body force
  /// and only ever get pair forces subtracted, so none is -0.0, the one value +0.0 would change).
  template <LookAhead kAhead, class Cross>
  [[gnu::noinline]] void rowsFlat(Index begin, Index end, Index ownedEnd, Cross cross) const {
    constexpr bool kCross = !std::is_same_v<Cross, NoCross>;
    const Index first = offset[begin], last = offset[end];
    [[maybe_unused]] const Index lastCandidate = last - 1;
    // A cross pair's stored force (the pair touches) per kept entry; the cross pairs that do not touch are not kept.
    alignas(64) const double* keptStored[kCross ? kBatchCandidates : 1];
    alignas(64) Index keptI[kBatchCandidates];
    alignas(64) Index keptJ[kBatchCandidates];
    alignas(64) double keep0[kBatchCandidates];  // separation d = x_i - x_j, then the force on i
    alignas(64) double keep1[kBatchCandidates];
    alignas(64) double keep2[kBatchCandidates];
    alignas(64) double keepSq[kBatchCandidates];    // |d|^2
    alignas(64) double gatherRi[kBatchCandidates];  // pass 2's inputs: r_i, r_j, 1/m_i + 1/m_j, v_i - v_j
    alignas(64) double gatherRj[kBatchCandidates];
    alignas(64) double gatherInvm[kBatchCandidates];
    alignas(64) double gatherV0[kBatchCandidates];
    alignas(64) double gatherV1[kBatchCandidates];
    alignas(64) double gatherV2[kBatchCandidates];
    alignas(64) Index rowOf[kBatchCandidates];  // the row starting at each candidate of the batch, or -1
    Index current = begin;                      // the row whose sum F_i is open
    Index nextRow = begin;                      // the first row not yet placed in a batch
    Index carried = begin;                      // the row of the candidate before the batch
    double fi0 = 0.0, fi1 = 0.0, fi2 = 0.0;
    for (Index start = first; start < last; start += kBatchCandidates) {
      const Index stop = std::min(last, start + kBatchCandidates);
      const Index width = stop - start;
      // Pass 0: every row starting inside the batch marks its first slot (an empty row marks the slot of the
      // next row, which overwrites it: rows go in ascending order); the contact tests below take the running
      // maximum of the marks as the row of each candidate.
      std::fill_n(rowOf, width, Index{-1});
      for (; nextRow < end && offset[nextRow] < stop; ++nextRow) rowOf[offset[nextRow] - start] = nextRow;
      Index kept = 0;
      for (Index c = start; c < stop; ++c) {
        carried = std::max(carried, rowOf[c - start]);
        const Index i = carried;
        const Index j = neighbour[c];
        prefetchAhead<kAhead, kBatchedLookAheadDistance>(c, lastCandidate);
        const Row a = loadRow(i);
        double d0, d1, d2;
        const double rsq = separation(a, j, d0, d1, d2);
        const double sumR = a.r + r[j];
        keptI[kept] = i;
        keptJ[kept] = j;
        keep0[kept] = d0;
        keep1[kept] = d1;
        keep2[kept] = d2;
        keepSq[kept] = rsq;
        bool keep = !(rsq >= sumR * sumR);
        if constexpr (kCross) {
          // Rare and clustered (rows next to the block's end): a branch. The lookup advances through the block's
          // cross pairs, so it is asked for every one, touching or not, in candidate order. A kept cross pair's
          // force is computed below too, from valid data, and not used.
          const double* stored = nullptr;
          if (j >= ownedEnd) {
            stored = cross(c);
            keep = stored != nullptr;
          }
          keptStored[kept] = stored;
        }
        kept += static_cast<Index>(keep);
      }
      // Pass 2: the forces of the kept pairs, (a) gathering each pair's inputs into columns, (b) the arithmetic of
      // touch() over the columns, two pairs per instruction where the law's expressions vectorise (the square
      // roots and divisions included).
      for (Index e = 0; e < kept; ++e) {
        const Index i = keptI[e], j = keptJ[e];
        gatherRi[e] = r[i];
        gatherRj[e] = r[j];
        gatherInvm[e] = invm[i] + invm[j];
        gatherV0[e] = v[3 * i] - v[3 * j];
        gatherV1[e] = v[3 * i + 1] - v[3 * j + 1];
        gatherV2[e] = v[3 * i + 2] - v[3 * j + 2];
      }
      for (Index e = 0; e < kept; ++e) {
        const Touch t = touchFrom(gatherRi[e], gatherRj[e], gatherInvm[e], gatherV0[e], gatherV1[e], gatherV2[e],
                                  keep0[e], keep1[e], keep2[e], keepSq[e]);
        keep0[e] = t.nf.force * t.nrm[0];
        keep1[e] = t.nf.force * t.nrm[1];
        keep2[e] = t.nf.force * t.nrm[2];
      }
      for (Index e = 0; e < kept; ++e) {
        const Index i = keptI[e];
        if (i != current) {
          f[3 * current] += fi0;
          f[3 * current + 1] += fi1;
          f[3 * current + 2] += fi2;
          fi0 = fi1 = fi2 = 0.0;
          current = i;
        }
        const Index j = keptJ[e];
        if (kCross && j >= ownedEnd) {
          const double* stored = keptStored[e];
          fi0 += stored[0];
          fi1 += stored[1];
          fi2 += stored[2];
          continue;
        }
        fi0 += keep0[e];
        fi1 += keep1[e];
        fi2 += keep2[e];
        f[3 * j] -= keep0[e];
        f[3 * j + 1] -= keep1[e];
        f[3 * j + 2] -= keep2[e];
      }
    }
    if (current < end) {
      f[3 * current] += fi0;
      f[3 * current + 1] += fi1;
      f[3 * current + 2] += fi2;
    }
  }

  const typename Law::Params& params;
  const double* const x;
  const double* const v;
  const double* const r;
  const double* const invm;
  double* const f;
  const double* const vh;
  const double* const w;
  const double* const wh;
  const double* const inverseInertia;
  double* const torque;
  const Index* const offset;
  const Index* const neighbour;
  const double L0, L1, L2, H0, H1, H2, g0, g1, g2, viscousRate, dt;
  double* const history;
  const Batching batching;
};

template <class Law, KernelFlags kFlags>
void serialPairs(const typename Law::Params& params, const ForceContext& ctx) {
  const PairKernel<Law, kFlags> k(params, ctx);
  double* f = ctx.force;
  const auto n3 = 3 * static_cast<std::size_t>(ctx.count);
  // Body forces first, then each row adds its sum to i and scatters -F to every j > i.
  if constexpr (kFlags.gravity || kFlags.viscous) {
    for (Index i = 0; i < ctx.count; ++i) {
      const Vec3 fb = k.bodyForce(i);
      for (int q = 0; q < 3; ++q) f[3 * i + q] = fb[q];
    }
  } else {
    std::memset(f, 0, sizeof(double) * n3);
  }
  if constexpr (Law::kUsesRotation) {
    if constexpr (kFlags.viscous) {
      for (Index i = 0; i < ctx.count; ++i) {
        const Vec3 tb = k.bodyTorque(i);
        for (int q = 0; q < 3; ++q) ctx.torque[3 * i + q] = tb[q];
      }
    } else {
      std::memset(ctx.torque, 0, sizeof(double) * n3);
    }
  }
  const NoCross none;
  switch (ctx.lookAhead) {
    case LookAhead::None:
      k.template rows<LookAhead::None>(0, ctx.count, ctx.count, none);
      break;
    case LookAhead::Centres:
      k.template rows<LookAhead::Centres>(0, ctx.count, ctx.count, none);
      break;
    case LookAhead::Contacts:
      k.template rows<LookAhead::Contacts>(0, ctx.count, ctx.count, none);
      break;
  }
}

#if POLYDEM_WITH_OPENMP
/// Owner sums (see force_loop.hpp): block t owns the forces of rows [blockStart[t], blockStart[t+1]).
template <class Law, KernelFlags kFlags>
void threadedPairs(const typename Law::Params& params, const ForceContext& ctx) {
  constexpr bool kRotation = Law::kUsesRotation;
  constexpr std::size_t kStride = kRotation ? 9 : 3;  // stored per cross pair: F_i (and tq_i, tq_j)
  const PairKernel<Law, kFlags> k(params, ctx);
  const ContactList& list = *ctx.list;
  POLYDEM_ASSERT(list.blockCount() > 0, "threaded force loop without ContactList::buildBlocks()");
  const Index blocks = list.blockCount();
  const auto crossCount = static_cast<Index>(list.crossCount());
  const Index* blockStart = list.blockStart.data();
  const Index* crossStart = list.crossStart.data();
  const Index* crossPair = list.crossPair.data();
  const Index* crossRow = list.crossRow.data();
  const Index* targetOffset = list.targetOffset.data();
  const Index* byTarget = list.byTarget.data();
  double* stored = ctx.crossScratch;
  std::uint8_t* touching = ctx.crossTouching;
#pragma omp parallel num_threads(ctx.threads)
  {
    // Pass 1: every cross pair's force (and spring), exactly once, shared evenly between the threads: they
    // write only their own pairs' slots. (The owner of j used to compute them, so with two blocks the thread
    // of the second block did them all while the other waited at the barrier.)
#pragma omp for schedule(static)
    for (Index e = 0; e < crossCount; ++e) {
      const Index c = crossPair[e], i = crossRow[e], j = k.neighbour[c];
      Vec3 fc, tqi, tqj;
      const bool touch = k.pairForce(i, k.loadRow(i), c, j, fc, tqi, tqj);
      touching[e] = touch;
      if (!touch) continue;
      double* out = stored + kStride * static_cast<std::size_t>(e);
      for (int q = 0; q < 3; ++q) out[q] = fc[q];
      if constexpr (kRotation) {
        for (int q = 0; q < 3; ++q) out[3 + q] = tqi[q];
        for (int q = 0; q < 3; ++q) out[6 + q] = tqj[q];
      }
    }
    // (implicit barrier: every cross pair is done)
    // Pass 2, per block: body forces of the block, then the cross pairs into it in ascending (i, j), the
    // first terms of the serial sum of every F_j (rows of earlier blocks come first in the serial order), then
    // the serial loop over the block's rows, which meets the block's own cross pairs in the order they were
    // listed (ascending c) and reads them back.
#pragma omp for schedule(static, 1)
    for (Index s = 0; s < blocks; ++s) {
      for (Index j = blockStart[s]; j < blockStart[s + 1]; ++j) {
        const Vec3 fb = k.bodyForce(j);
        for (int q = 0; q < 3; ++q) k.f[3 * j + q] = fb[q];
        if constexpr (kRotation) {
          const Vec3 tb = k.bodyTorque(j);
          for (int q = 0; q < 3; ++q) k.torque[3 * j + q] = tb[q];
        }
      }
      for (Index m = targetOffset[s]; m < targetOffset[s + 1]; ++m) {
        const Index e = byTarget[m];
        if (!touching[e]) continue;
        const Index j = k.neighbour[crossPair[e]];
        const double* in = stored + kStride * static_cast<std::size_t>(e);
        subtract(k.f, j, load(in, 0));
        if constexpr (kRotation) subtract(k.torque, j, load(in + 6, 0));
      }
      Index e = crossStart[s];
      const auto crossForce = [&](Index c) -> const double* {
        POLYDEM_ASSERT(crossPair[e] == c, "cross pairs out of step with the rows");
        (void)c;
        const Index here = e++;
        return touching[here] ? stored + kStride * static_cast<std::size_t>(here) : nullptr;
      };
      // Centres at most: a prefetch for writing could pull another block's forces from its thread.
      if (ctx.lookAhead == LookAhead::None) {
        k.rows(blockStart[s], blockStart[s + 1], blockStart[s + 1], crossForce);
      } else {
        k.template rows<LookAhead::Centres>(blockStart[s], blockStart[s + 1], blockStart[s + 1], crossForce);
      }
    }
  }
}
#endif

}  // namespace detail

template <class Law, KernelFlags kFlags>
void computeForces(const typename Law::Params& params, const ForceContext& ctx) {
  using detail::Vec3;
  using Normal = typename Law::NormalLaw;
  constexpr bool kRotation = Law::kUsesRotation;
  constexpr int kHistory = Law::kHistorySize;
  static_assert(kHistory == 0 || kHistory == CundallStrack::kHistorySize, "one history layout so far");

#if POLYDEM_WITH_OPENMP
  if (ctx.threads > 1) {
    detail::threadedPairs<Law, kFlags>(params, ctx);
  } else
#endif
  {
    detail::serialPairs<Law, kFlags>(params, ctx);
  }

  // Walls: serial (a surface's worth of candidates), after every pair force, whatever the thread count.
  if constexpr (kFlags.walls) {
    const double* x = ctx.position;
    const double* v = ctx.velocity;
    const double* r = ctx.radius;
    const double* invm = ctx.inverseMass;
    double* f = ctx.force;
    [[maybe_unused]] const double* vh = ctx.velocityHalf;
    [[maybe_unused]] const double* w = ctx.angularVelocity;
    [[maybe_unused]] const double* wh = ctx.angularVelocityHalf;
    [[maybe_unused]] double* torque = ctx.torque;
    [[maybe_unused]] const double dt = ctx.dt;
    const Index* wallParticle = ctx.list->wallParticle.data();
    const std::int8_t* wallFace = ctx.list->wallFace.data();
    const std::size_t count = ctx.list->wallParticle.size();
    [[maybe_unused]] double* wallHistory = nullptr;
    if constexpr (kHistory > 0) wallHistory = ctx.wallHistory->values(0);
    for (std::size_t c = 0; c < count; ++c) {
      const Index i = wallParticle[c];
      const int face = wallFace[c];
      const int axis = face >> 1;
      const bool high = (face & 1) != 0;
      const double ri = r[i];
      const double gap = high ? ctx.length[axis] - x[3 * i + axis] : x[3 * i + axis];
      const double overlap = ri - gap;
      if (overlap <= 0.0) {
        if constexpr (kHistory > 0) std::fill_n(wallHistory + kHistory * c, kHistory, 0.0);
        continue;
      }
      Vec3 nrm = Vec3::Zero();
      nrm[axis] = high ? -1.0 : 1.0;  // from the wall into the box
      const Vec3 vi = detail::load(v, i);
      const double meff = 1.0 / invm[i];
      const NormalForce nf = Normal::force(params.normal, overlap, -vi.dot(nrm), meff, ri);
      Vec3 fc = nf.force * nrm;
      if constexpr (kRotation) {
        // Lever arm to the wall plane (LAMMPS variant: the radius).
        const double a = detail::kLammpsTangential<typename Law::TangentialLaw> ? ri : ri - overlap;
        Vec3 vc = vi - a * detail::load(w, i).cross(nrm);
        const Vec3 vt = vc - vc.dot(nrm) * nrm;
        Vec3 vch = detail::load(vh, i) - a * detail::load(wh, i).cross(nrm);
        const Vec3 vtHalf = vch - vch.dot(nrm) * nrm;
        const Vec3 ft = detail::lawTangentialForce<typename Law::TangentialLaw>(params.tangential, nf, nrm, vt, vtHalf,
                                                                                dt, wallHistory + kHistory * c);
        fc += ft;
        detail::subtract(torque, i, a * nrm.cross(ft));
      }
      detail::add(f, i, fc);
    }
  }
}

}  // namespace polydem::contact

// The eight flag sets of one law, instantiated; force_kernels_*.cpp use it once per law. Adding a law: one
// line in one of those files, one case in paramsFor() and selectForceKernel() (force_kernel_select.cpp).
#define POLYDEM_FORCE_KERNEL_INSTANCES(LAW)                                                                    \
  template void computeForces<LAW, KernelFlags{false, false, false}>(const LAW::Params&, const ForceContext&); \
  template void computeForces<LAW, KernelFlags{true, false, false}>(const LAW::Params&, const ForceContext&);  \
  template void computeForces<LAW, KernelFlags{false, true, false}>(const LAW::Params&, const ForceContext&);  \
  template void computeForces<LAW, KernelFlags{true, true, false}>(const LAW::Params&, const ForceContext&);   \
  template void computeForces<LAW, KernelFlags{false, false, true}>(const LAW::Params&, const ForceContext&);  \
  template void computeForces<LAW, KernelFlags{true, false, true}>(const LAW::Params&, const ForceContext&);   \
  template void computeForces<LAW, KernelFlags{false, true, true}>(const LAW::Params&, const ForceContext&);   \
  template void computeForces<LAW, KernelFlags{true, true, true}>(const LAW::Params&, const ForceContext&);
