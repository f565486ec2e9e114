#pragma once
// Definition of computeForces<Law, kFlags>. Included only by force_loop_instances.cpp, which lists
// the explicit instantiations: other translation units see the declaration in force_loop.hpp.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include <Eigen/Core>
#include <Eigen/Geometry>  // cross products

#include "contact/force_loop.hpp"
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

}  // namespace detail

template <class Law, KernelFlags kFlags>
void computeForces(const typename Law::Params& params, const ForceContext& ctx) {
  using detail::Vec3;
  using Normal = typename Law::NormalLaw;
  constexpr bool kRotation = Law::kUsesRotation;
  constexpr int kHistory = Law::kHistorySize;
  static_assert(kHistory == 0 || kHistory == CundallStrack::kHistorySize, "one history layout so far");

  const Index n = ctx.count;
  const double* x = ctx.position;
  const double* v = ctx.velocity;
  const double* r = ctx.radius;
  const double* invm = ctx.inverseMass;
  double* f = ctx.force;
  [[maybe_unused]] const double* vh = ctx.velocityHalf;
  [[maybe_unused]] const double* w = ctx.angularVelocity;
  [[maybe_unused]] const double* wh = ctx.angularVelocityHalf;
  [[maybe_unused]] double* torque = ctx.torque;

  // Body force and torque on particle i (gravity, viscous damping; else zero), summed in one order.
  auto bodyForce = [&](Index i) {
    Vec3 fb = Vec3::Zero();
    if constexpr (kFlags.gravity || kFlags.viscous) {
      const double m = 1.0 / invm[i];
      for (int k = 0; k < 3; ++k) {
        double fk = 0.0;
        if constexpr (kFlags.gravity) fk += m * ctx.gravity[k];
        if constexpr (kFlags.viscous) fk -= ctx.viscousRate * m * v[3 * i + k];
        fb[k] = fk;
      }
    }
    return fb;
  };
  [[maybe_unused]] auto bodyTorque = [&](Index i) {
    Vec3 tb = Vec3::Zero();
    if constexpr (kFlags.viscous) {
      const double inertia = 1.0 / ctx.inverseInertia[i];
      for (int k = 0; k < 3; ++k) tb[k] = -ctx.viscousRate * inertia * w[3 * i + k];
    }
    return tb;
  };

  const Index* offset = ctx.list->offset.data();
  const Index* neighbour = ctx.list->neighbour.data();
  const double L0 = ctx.length[0], L1 = ctx.length[1], L2 = ctx.length[2];
  const double H0 = ctx.halfLength[0], H1 = ctx.halfLength[1], H2 = ctx.halfLength[2];
  [[maybe_unused]] const double dt = ctx.dt;
  [[maybe_unused]] double* history = nullptr;
  if constexpr (kHistory > 0) history = ctx.pairHistory->values(0);

  // What row i reads for every pair: loaded once per row.
  struct Row {
    double x0, x1, x2, r, invm;
    Vec3 v;
  };
  auto loadRow = [&](Index i) { return Row{x[3 * i], x[3 * i + 1], x[3 * i + 2], r[i], invm[i], detail::load(v, i)}; };

  // Candidate pair c = (i, j): false when the spheres do not touch (its history is cleared). Otherwise
  // fc = force on i (= minus the force on j) and, with rotation, the torques on i and j as -tqi, -tqj.
  auto pairForce = [&](Index i, const Row& a, Index c, Index j, Vec3& fc, [[maybe_unused]] Vec3& tqi,
                       [[maybe_unused]] Vec3& tqj) {
    double d0 = a.x0 - x[3 * j], d1 = a.x1 - x[3 * j + 1], d2 = a.x2 - x[3 * j + 2];
    // Minimum image; halfLength is +inf on walled axes, so those never shift.
    if (d0 > H0) d0 -= L0; else if (d0 < -H0) d0 += L0;
    if (d1 > H1) d1 -= L1; else if (d1 < -H1) d1 += L1;
    if (d2 > H2) d2 -= L2; else if (d2 < -H2) d2 += L2;
    const double rsq = d0 * d0 + d1 * d1 + d2 * d2;
    const double rj = r[j];
    const double sumR = a.r + rj;
    if (rsq >= sumR * sumR) {
      if constexpr (kHistory > 0) std::fill_n(history + kHistory * static_cast<std::size_t>(c), kHistory, 0.0);
      return false;
    }
    const double dist = std::sqrt(rsq);
    const double invDist = 1.0 / dist;
    const Vec3 nrm(d0 * invDist, d1 * invDist, d2 * invDist);
    const double overlap = sumR - dist;
    const double meff = 1.0 / (a.invm + invm[j]);
    const double reff = a.r * rj / sumR;
    const Vec3 vrel = a.v - detail::load(v, j);
    const double rate = -vrel.dot(nrm);
    const NormalForce nf = Normal::force(params.normal, overlap, rate, meff, reff);
    fc = nf.force * nrm;
    if constexpr (kRotation) {
      const double ai = a.r - 0.5 * overlap, aj = rj - 0.5 * overlap;
      const Vec3 wi = detail::load(w, i), wj = detail::load(w, j);
      Vec3 vc = vrel - (ai * wi + aj * wj).cross(nrm);
      const Vec3 vt = vc - vc.dot(nrm) * nrm;
      const Vec3 vrelHalf = detail::load(vh, i) - detail::load(vh, j);
      Vec3 vch = vrelHalf - (ai * detail::load(wh, i) + aj * detail::load(wh, j)).cross(nrm);
      const Vec3 vtHalf = vch - vch.dot(nrm) * nrm;
      const Vec3 ft = detail::tangentialForce(params.tangential, nf, nrm, vt, vtHalf, dt,
                                              history + kHistory * static_cast<std::size_t>(c));
      fc += ft;
      const Vec3 arm = nrm.cross(ft);  // torque_i = -a_i n x F_t, torque_j = -a_j n x F_t
      tqi = ai * arm;
      tqj = aj * arm;
    }
    return true;
  };

#if POLYDEM_WITH_OPENMP
  if (ctx.threads > 1) {
    // Owner computes (see force_loop.hpp): block t owns the forces of rows [blockStart[t], blockStart[t+1]).
    const ContactList& list = *ctx.list;
    POLYDEM_ASSERT(list.blockCount() > 0, "threaded force loop without ContactList::buildBlocks()");
    const Index blocks = list.blockCount();
    const Index* blockStart = list.blockStart.data();
    const Index* crossStart = list.crossStart.data();
    const Index* crossPair = list.crossPair.data();
    const Index* crossRow = list.crossRow.data();
    const Index* targetOffset = list.targetOffset.data();
    const Index* byTarget = list.byTarget.data();
    double* xf = ctx.crossScratch;  // force on i per cross pair
    [[maybe_unused]] double* xt = ctx.crossScratch + 3 * list.crossCount();  // rotation: tqi per cross pair
    std::uint8_t* touching = ctx.crossTouching;
#pragma omp parallel num_threads(ctx.threads)
    {
      // Pass 1, per block of j: body forces, then the cross pairs into the block, ascending (i, j): the
      // first terms of the serial sum of every F_j. Each cross pair is computed (and its history
      // advanced) exactly once, here.
#pragma omp for schedule(static, 1)
      for (Index t = 0; t < blocks; ++t) {
        for (Index j = blockStart[t]; j < blockStart[t + 1]; ++j) {
          const Vec3 fb = bodyForce(j);
          for (int k = 0; k < 3; ++k) f[3 * j + k] = fb[k];
          if constexpr (kRotation) {
            const Vec3 tb = bodyTorque(j);
            for (int k = 0; k < 3; ++k) torque[3 * j + k] = tb[k];
          }
        }
        for (Index m = targetOffset[t]; m < targetOffset[t + 1]; ++m) {
          const Index q = byTarget[m];
          const Index c = crossPair[q], i = crossRow[q], j = neighbour[c];
          Vec3 fc, tqi, tqj;
          touching[q] = pairForce(i, loadRow(i), c, j, fc, tqi, tqj);
          if (!touching[q]) continue;
          detail::subtract(f, j, fc);
          for (int k = 0; k < 3; ++k) xf[3 * static_cast<std::size_t>(q) + k] = fc[k];
          if constexpr (kRotation) {
            detail::subtract(torque, j, tqj);
            for (int k = 0; k < 3; ++k) xt[3 * static_cast<std::size_t>(q) + k] = tqi[k];
          }
        }
      }
      // (implicit barrier: every cross pair is done)
      // Pass 2, per block of i: the serial loop over the block's rows; pairs whose j lies beyond the
      // block are the cross pairs of pass 1, met here in the same (ascending c) order, read back.
#pragma omp for schedule(static, 1)
      for (Index s = 0; s < blocks; ++s) {
        const Index blockEnd = blockStart[s + 1];
        Index q = crossStart[s];
        for (Index i = blockStart[s]; i < blockEnd; ++i) {
          const Row a = loadRow(i);
          double fi0 = 0.0, fi1 = 0.0, fi2 = 0.0;
          [[maybe_unused]] Vec3 ti = Vec3::Zero();
          const Index end = offset[i + 1];
          for (Index c = offset[i]; c < end; ++c) {
            const Index j = neighbour[c];
            if (j >= blockEnd) {
              POLYDEM_ASSERT(crossPair[q] == c, "cross pairs out of step with the rows");
              if (touching[q]) {
                const double* fq = xf + 3 * static_cast<std::size_t>(q);
                fi0 += fq[0];
                fi1 += fq[1];
                fi2 += fq[2];
                if constexpr (kRotation) ti -= detail::load(xt, q);
              }
              ++q;
              continue;
            }
            Vec3 fc, tqi, tqj;
            if (!pairForce(i, a, c, j, fc, tqi, tqj)) continue;
            if constexpr (kRotation) {
              ti -= tqi;
              detail::subtract(torque, j, tqj);
            }
            fi0 += fc[0];
            fi1 += fc[1];
            fi2 += fc[2];
            detail::subtract(f, j, fc);
          }
          f[3 * i] += fi0;
          f[3 * i + 1] += fi1;
          f[3 * i + 2] += fi2;
          if constexpr (kRotation) detail::add(torque, i, ti);
        }
      }
    }
  } else
#endif
  {
    // Serial: body forces first, then each row adds its sum to i and scatters -F to every j > i.
    if constexpr (kFlags.gravity || kFlags.viscous) {
      for (Index i = 0; i < n; ++i) {
        const Vec3 fb = bodyForce(i);
        for (int k = 0; k < 3; ++k) f[3 * i + k] = fb[k];
      }
    } else {
      std::memset(f, 0, sizeof(double) * 3 * static_cast<std::size_t>(n));
    }
    if constexpr (kRotation) {
      if constexpr (kFlags.viscous) {
        for (Index i = 0; i < n; ++i) {
          const Vec3 tb = bodyTorque(i);
          for (int k = 0; k < 3; ++k) torque[3 * i + k] = tb[k];
        }
      } else {
        std::memset(torque, 0, sizeof(double) * 3 * static_cast<std::size_t>(n));
      }
    }
    for (Index i = 0; i < n; ++i) {
      const Row a = loadRow(i);
      double fi0 = 0.0, fi1 = 0.0, fi2 = 0.0;
      [[maybe_unused]] Vec3 ti = Vec3::Zero();
      const Index end = offset[i + 1];
      for (Index c = offset[i]; c < end; ++c) {
        const Index j = neighbour[c];
        Vec3 fc, tqi, tqj;
        if (!pairForce(i, a, c, j, fc, tqi, tqj)) continue;
        if constexpr (kRotation) {
          ti -= tqi;
          detail::subtract(torque, j, tqj);
        }
        fi0 += fc[0];
        fi1 += fc[1];
        fi2 += fc[2];
        detail::subtract(f, j, fc);
      }
      f[3 * i] += fi0;
      f[3 * i + 1] += fi1;
      f[3 * i + 2] += fi2;
      if constexpr (kRotation) detail::add(torque, i, ti);
    }
  }

  if constexpr (kFlags.walls) {
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
        const double a = ri - overlap;  // lever arm to the wall plane
        Vec3 vc = vi - a * detail::load(w, i).cross(nrm);
        const Vec3 vt = vc - vc.dot(nrm) * nrm;
        Vec3 vch = detail::load(vh, i) - a * detail::load(wh, i).cross(nrm);
        const Vec3 vtHalf = vch - vch.dot(nrm) * nrm;
        const Vec3 ft =
            detail::tangentialForce(params.tangential, nf, nrm, vt, vtHalf, dt, wallHistory + kHistory * c);
        fc += ft;
        detail::subtract(torque, i, a * nrm.cross(ft));
      }
      detail::add(f, i, fc);
    }
  }
}

}  // namespace polydem::contact
