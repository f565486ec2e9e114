#include "integrators/fire_descent.hpp"

#include <fmt/format.h>

#include "core/types.hpp"

namespace polydem::integrators::fire {

FireSums reduceChunk(Index begin, Index end, const double* f, const double* v, const double* im) {
  double power[2] = {}, vv[2] = {}, ff[2] = {}, fvm[2] = {}, ffm[2] = {}, fmax[2] = {};
  auto particle = [&](Index i, int lane) {
    const double* fi = f + 3 * i;
    const double* vi = v + 3 * i;
    const double fsq = fi[0] * fi[0] + fi[1] * fi[1] + fi[2] * fi[2];
    const double fv = fi[0] * vi[0] + fi[1] * vi[1] + fi[2] * vi[2];
    power[lane] += fv;
    vv[lane] += vi[0] * vi[0] + vi[1] * vi[1] + vi[2] * vi[2];
    ff[lane] += fsq;
    fvm[lane] += fv * im[i];
    ffm[lane] += fsq * im[i] * im[i];
    fmax[lane] = std::max(fmax[lane], fsq);
  };
  Index i = begin;
  for (; i + 1 < end; i += 2) {
    particle(i, 0);
    particle(i + 1, 1);
  }
  if (i < end) particle(i, 0);
  return {power[0] + power[1], vv[0] + vv[1],   ff[0] + ff[1],
          fvm[0] + fvm[1],     ffm[0] + ffm[1], std::max(fmax[0], fmax[1])};
}

std::array<double, 3> directChunk(Index begin, Index end, const double* f, double* d, const double* previous,
                                  double beta, bool update) {
  double g = 0.0, dmax = 0.0, fmax = 0.0;
  for (Index i = begin; i < end; ++i) {
    const double* fi = f + 3 * i;
    double* di = d + 3 * i;
    if (update) {
      for (int k = 0; k < 3; ++k) di[k] = previous[3 * i + k] + beta * di[k];
    }
    g += fi[0] * di[0] + fi[1] * di[1] + fi[2] * di[2];
    dmax = std::max(dmax, di[0] * di[0] + di[1] * di[1] + di[2] * di[2]);
    fmax = std::max(fmax, fi[0] * fi[0] + fi[1] * fi[1] + fi[2] * fi[2]);
  }
  return {g, dmax, fmax};
}

double alongChunk(Index begin, Index end, const double* f, const double* d) {
  double g = 0.0;
  for (Index k = 3 * begin; k < 3 * end; ++k) g += f[k] * d[k];
  return g;
}

std::array<double, 2> preconditionChunk(Index begin, Index end, const double* f, const double* im, double* previous) {
  double sNew = 0.0, change = 0.0;
  for (Index i = begin; i < end; ++i) {
    for (int k = 0; k < 3; ++k) {
      const Index a = 3 * i + k;
      const double sk = im[i] * f[a];
      sNew += f[a] * sk;
      change += f[a] * (sk - previous[a]);
      previous[a] = sk;
    }
  }
  return {sNew, change};
}

MeasureSums measureChunk(Index begin, Index end, const double* part, const double* radius) {
  MeasureSums s;
  for (Index i = begin; i < end; ++i) {
    s.energy += part[3 * i];
    s.force += part[3 * i + 1];
    s.virial += part[3 * i + 2];
    s.volume += radius[i] * radius[i] * radius[i];
  }
  return s;
}

void jacobiMasses(const contact::ContactList& list, const double* r, Index n, StiffnessRule stiffness, double* im) {
  for (Index i = 0; i < n; ++i) im[i] = stiffness(r[i], r[i]);
  for (Index i = 0; i < n; ++i) {
    const double ri = r[i];
    double mi = im[i];  // j != i: the stores to im[j] leave it alone
    for (Index c = list.offset[i]; c < list.offset[i + 1]; ++c) {
      const Index j = list.neighbour[c];
      const double k = stiffness(ri, r[j]);
      mi += k;
      im[j] += k;
    }
    im[i] = mi;
  }
  for (std::size_t c = 0; c < list.wallParticle.size(); ++c) {
    const Index i = list.wallParticle[c];
    im[i] += 2.0 * stiffness(r[i], r[i]);  // R_eff = r_i against a wall
  }
  for (Index i = 0; i < n; ++i) im[i] = 1.0 / im[i];
}

ContactTally tallyContacts(const contact::ContactModel& model, const contact::ForceContext& ctx,
                           const std::function<bool(Index)>& ownRow, double* part) {
  ContactTally t;
  const contact::ContactList& list = *ctx.list;
  const bool hertz = model.parameters().normal == contact::NormalModel::Hertz;
  const auto lin = model.linearParams();
  const auto hz = model.hertzParams();
  auto normalForce = [&](double overlap, double reff) {
    return hertz ? contact::HertzNormal::force(hz, overlap, 0.0, 1.0, reff).force
                 : contact::LinearNormal::force(lin, overlap, 0.0, 1.0, reff).force;
  };
  const double* x = ctx.position;
  const double* r = ctx.radius;
  for (Index i = 0; i < ctx.count; ++i) {
    if (!ownRow(i)) continue;
    double* pi = part + 3 * i;
    for (Index c = list.offset[i]; c < list.offset[i + 1]; ++c) {
      const Index j = list.neighbour[c];
      double dsq = 0.0;
      for (int k = 0; k < 3; ++k) {  // the kernel's minimum image
        double d = x[3 * i + k] - x[3 * j + k];
        if (d > ctx.halfLength[k]) {
          d -= ctx.length[k];
        } else if (d < -ctx.halfLength[k]) {
          d += ctx.length[k];
        }
        dsq += d * d;
      }
      const double sumR = r[i] + r[j];
      if (dsq >= sumR * sumR) continue;
      const double dist = std::sqrt(dsq);
      const double overlap = sumR - dist;
      const double reff = r[i] * r[j] / sumR;
      const double fn = normalForce(overlap, reff);
      ++t.contacts;
      pi[0] += model.normalEnergy(overlap, reff);
      pi[1] += fn;
      pi[2] += fn * dist;
      t.maxOverlapRatio = std::max(t.maxOverlapRatio, overlap / std::min(r[i], r[j]));
      t.maxOverlap = std::max(t.maxOverlap, overlap);
    }
  }
  for (std::size_t c = 0; c < list.wallParticle.size(); ++c) {
    const Index i = list.wallParticle[c];
    const int face = list.wallFace[c];
    const int axis = face >> 1;
    const double gap = (face & 1) ? ctx.length[axis] - x[3 * i + axis] : x[3 * i + axis];
    const double overlap = r[i] - gap;
    if (!(overlap > 0.0)) continue;
    const double fn = normalForce(overlap, r[i]);
    ++t.wallContacts;
    double* pi = part + 3 * i;
    pi[0] += model.normalEnergy(overlap, r[i]);
    pi[1] += fn;
    pi[2] += fn * gap;  // the lever from the centre to the wall
    t.maxOverlapRatio = std::max(t.maxOverlapRatio, overlap / r[i]);
    t.maxOverlap = std::max(t.maxOverlap, overlap);
  }
  return t;
}

MinimiserReport assembleReport(const ContactTally& tally, const MeasureSums& sums, double forceSq, double stepSq,
                               const Box& box, double pressureUnit, double referenceForce) {
  MinimiserReport rep;
  rep.contacts = tally.contacts;
  rep.wallContacts = tally.wallContacts;
  rep.maxOverlapRatio = tally.maxOverlapRatio;
  rep.maxOverlap = tally.maxOverlap;
  rep.energy = sums.energy;
  const std::size_t all = rep.contacts + rep.wallContacts;
  rep.meanContactForce = all > 0 ? sums.force / static_cast<double>(all) : 0.0;
  rep.pressure = sums.virial / (3.0 * box.volume());
  rep.reducedPressure = rep.pressure / pressureUnit;
  rep.maxForce = std::sqrt(forceSq);
  rep.stepUlps = std::sqrt(stepSq) / (std::numeric_limits<double>::epsilon() * box.lengths().maxCoeff());
  const double scale = std::max(rep.meanContactForce, referenceForce);
  rep.residual = scale > 0.0 ? rep.maxForce / scale : 0.0;
  rep.packingFraction = 4.0 / 3.0 * kPi * sums.volume / box.volume();
  return rep;
}

std::string leftWallMessage(Index id, double radius, int axis, double x, double length, double force) {
  const bool low = x < 0.0;
  const double beyond = low ? -x : x - length;
  const std::string wall =
      fmt::format("{}{} wall ({} = {:g})", low ? "-" : "+", "xyz"[axis], "xyz"[axis], low ? 0.0 : length);
  if (low ? force < 0.0 : force > 0.0) {
    return fmt::format(
        "minimiser: particle id {} (r = {:g}) was pressed through the {} by its contacts: the net force on it "
        "pointed out of the box before the step, and its centre is now {:g} beyond the wall (the soft wall cannot "
        "hold it; a smaller step need not help). The start is denser than the walls hold: start from a lower "
        "--phi0 and raise phi with --delta-phi or --target-pressure, or use periodic boundaries",
        id, radius, wall, beyond);
  }
  return fmt::format(
      "minimiser: particle id {} (r = {:g}) was carried through the {} by its velocity: the net force on it "
      "pointed into the box before the step, yet its centre is now {:g} beyond the wall (FIRE's inertia: a start "
      "with large overlaps releases more energy than the soft wall holds). Lower --dt-max-factor (1: no step "
      "growth) or --dt, or start from a lower --phi0 and raise phi with --delta-phi or --target-pressure",
      id, radius, wall, beyond);
}

}  // namespace polydem::integrators::fire
