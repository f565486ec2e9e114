#pragma once
// The FIRE descent itself (integrators/fire_minimiser.hpp explains the method, the stopping rule and the
// round-off floor), written once over a "system" that owns the particles: the serial FireMinimiser and the
// MPI-distributed one (parallel/distributed_fire.hpp) run this same loop, so both take the same decisions
// from the same sums. What the system must give:
//   MinimiserReport measure()           the observables (collective where distributed)
//   void prepare(const MinimiserReport&) the masses for the start (Hertz: at the current overlaps), v = 0
//   FireSums sums()                     FireSums of the current state, added by chunks of kFireChunk slots in
//                                       chunk order; also polls the interrupt flag (collective)
//   bool interrupted() const            the flag of the last sums()
//   void restart(double dt)             x -= dt/2 v, v = 0 (FIRE 2.0's correction of an uphill step)
//   void advance(double dt, double keep, double toward)
//                                       v = keep (v + dt F/m) + toward F; x += dt v; the list check; forces
//   void finish(FireResult&)            v = 0; the call's counters and seconds into the result
//   double overlapFloor() const         overlaps below this are round-off (64 eps max L)
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>

#include "contact/force_loop.hpp"
#include "core/box.hpp"
#include "core/errors.hpp"
#include "integrators/fire_minimiser.hpp"

namespace polydem::integrators::fire {

/// The passes over the particles run over fixed chunks of slots, each chunk's sums kept apart and added in
/// chunk order afterwards: the result is the same for any thread count (threads only share out the chunks)
/// and for any rank count (a rank sums the chunks it owns whole; a split chunk is summed by one rank from
/// its particles' values: parallel/keyed_chunks.hpp).
constexpr Index kChunk = 4096;

inline Index chunkCount(Index n) { return (n + kChunk - 1) / kChunk; }

/// The two largest squared displacements since the list's build, for the rebuild rule (listStale()).
struct LargestTwo {
  double first = 0.0, second = 0.0;
  // Branch-free (the same values as `if (dsq > second) {second = min(dsq, first); first = max(dsq, first);}`,
  // a NaN left out as there): the update pass's one loop-carried dependency is then two maxima per particle.
  void add(double dsq) {
    second = std::max(second, std::min(dsq, first));
    first = std::max(first, dsq);
  }
  double drift() const { return std::sqrt(first) + std::sqrt(second); }
};

/// The sums of FIRE's reduction pass: P = F.v, |v|^2, |F|^2, sum (F_i.v_i)/m_i and sum |F_i|^2/m_i^2 (the
/// kicked |v|^2 without a second pass), and the largest |F_i|^2.
struct FireSums {
  static constexpr int kWidth = 6;
  double power = 0.0, vv = 0.0, ff = 0.0, fvm = 0.0, ffm = 0.0, fmaxSq = 0.0;
  void add(const FireSums& o) {
    power += o.power;
    vv += o.vv;
    ff += o.ff;
    fvm += o.fvm;
    ffm += o.ffm;
    fmaxSq = std::max(fmaxSq, o.fmaxSq);
  }
  void store(double* out) const {
    out[0] = power;
    out[1] = vv;
    out[2] = ff;
    out[3] = fvm;
    out[4] = ffm;
    out[5] = fmaxSq;
  }
  static FireSums load(const double* in) { return {in[0], in[1], in[2], in[3], in[4], in[5]}; }
};

/// The sums of particles [begin, end) of one chunk: even and odd ones into separate sums added at the end
/// (two add chains per sum instead of one; four measured the same). The order is fixed, so the result is
/// too. Out of line: the one definition of these roundings for every caller.
[[gnu::noinline]] FireSums reduceChunk(Index begin, Index end, const double* f, const double* v, const double* im);

/// The sums of measure() for one chunk: per particle its row's pairs then its walls (`part`, 3 values per
/// particle: energy, normal force, virial), and the radius cubed; particles [begin, end) in order. Out of line.
struct MeasureSums {
  static constexpr int kWidth = 4;
  double energy = 0.0, force = 0.0, virial = 0.0, volume = 0.0;  ///< volume: sum r^3
};
[[gnu::noinline]] MeasureSums measureChunk(Index begin, Index end, const double* part, const double* radius);

/// The Jacobi masses as inverses (fire_minimiser.hpp): m_i = k_ii + sum_j k_ij over the candidates of i in
/// `list` and its walls, rows 0..n-1 in order. Particle j's sum is k_jj, then the rows i < j that list it in
/// ascending i, then its own row, then its walls: the serial order, so a rank that holds every row listing
/// its particles (its own and its ghosts') gets their masses to the bit.
void jacobiMasses(const contact::ContactList& list, const double* radius, Index n, StiffnessRule stiffness,
                  double* inverseMass);

/// measure()'s pass over the contacts of rows [0, n) of `list` for which `ownRow(i)` holds (and the walls of
/// `list`): adds each row's pairs, then each particle's walls, into `part` (3 per slot, energy, normal force,
/// virial; zero on entry), and returns the counts and the largest overlaps.
struct ContactTally {
  std::size_t contacts = 0, wallContacts = 0;
  double maxOverlapRatio = 0.0, maxOverlap = 0.0;
};
ContactTally tallyContacts(const contact::ContactModel& model, const contact::ForceContext& ctx,
                           const std::function<bool(Index)>& ownRow, double* part);

/// The report from the tallies (MinimiserReport's fields): `sums` the chunked energy, force, virial and sum
/// r^3; `forceSq` the largest |F_i|^2; `stepSq` the largest |F_i|^2 / m_i^2.
MinimiserReport assembleReport(const ContactTally& tally, const MeasureSums& sums, double forceSq, double stepSq,
                               const Box& box, double pressureUnit, double referenceForce);

/// Conjugate gradients' passes over particles [begin, end) of one chunk (fire_minimiser.hpp), out of line (one
/// definition of the roundings for every system):
/// with `update`, first d = previous + beta d; then {F.d, max |d_i|^2, max |F_i|^2}.
std::array<double, 3> directChunk(Index begin, Index end, const double* f, double* d, const double* previous,
                                  double beta, bool update);
/// F.d, component by component.
double alongChunk(Index begin, Index end, const double* f, const double* d);
/// s = M^-1 F into `previous`: {F.s, F.(s - previous)}.
std::array<double, 2> preconditionChunk(Index begin, Index end, const double* f, const double* im, double* previous);

/// The message for a centre found outside a walled box at a list build: particle `id` of radius `radius`, its
/// coordinate `x` along `axis` in a box of `length`, and the net force on it along `axis` at its last
/// position (before the step that carried it out). That force names the cause: pointing out of the box, the
/// particle's contacts press it through the soft wall (a start denser than the walls hold: a random start with
/// large overlaps at a wall); pointing in, FIRE's inertia carried it through (a smaller dt_max helps).
std::string leftWallMessage(Index id, double radius, int axis, double x, double length, double force);

/// The stopping rule after a measurement at force evaluation `it` (every method): the reason to stop, or
/// nullptr (fire_minimiser.hpp: converged, no contacts, overlaps at round-off, round-off floor).
class StopRule {
 public:
  StopRule(const FireSettings& fs, const MinimiserReport& start, double overlapFloor)
      : fs_(fs), overlapFloor_(overlapFloor), knownScale(std::max(start.meanContactForce, fs.referenceForce)) {}

  const char* verdict(const MinimiserReport& now, double fmax, std::int64_t it) {
    if (now.contacts + now.wallContacts == 0) return "no contacts";
    if (now.maxOverlap <= overlapFloor_) return "overlaps at round-off";
    knownScale = std::max(now.meanContactForce, fs_.referenceForce);
    if (fmax <= fs_.forceTolerance * knownScale) return "converged";
    // The round-off floor: the remaining forces ask every particle to move by less than the resolution of
    // its coordinates, and the residual has not halved for the stall window. A tolerance below that floor
    // cannot be met (seen: 10^4 equal spheres at p/k 1e-6, residual hovering at 3-5e-9 against 1e-9 for 1.3
    // million steps); stop and say so rather than spend the iteration budget.
    if (now.residual < 0.5 * bestResidual_) {
      if (std::isfinite(bestResidual_)) halvingGap_ = it - bestAt_;
      bestResidual_ = now.residual;
      bestAt_ = it;
    }
    const std::int64_t window = std::clamp(4 * halvingGap_, kStallMin, kStallMax);
    if (now.stepUlps <= 1.0 && it - bestAt_ >= window) return "round-off floor";
    return nullptr;
  }

 private:
  // The stall window of the round-off floor: 4 x the evaluations the residual's last halving took, within
  // [kStallMin, kStallMax] (the window follows the descent's own pace: 16384 whatever the pace wasted 10-20% of
  // a near-jamming minimisation at N = 10^4 after the floor was reached).
  static constexpr std::int64_t kStallMin = 2048, kStallMax = 16384;
  const FireSettings& fs_;
  double overlapFloor_;
  double bestResidual_ = std::numeric_limits<double>::infinity();
  std::int64_t bestAt_ = 0, halvingGap_ = kStallMax;

 public:
  double knownScale;  ///< max(<|F_c|>, referenceForce) at the last measurement
};

/// The state is measured every this many force evaluations (and whenever the residual looks converged).
constexpr std::int64_t kMeasureEvery = 256;

/// The bookkeeping of one descent (FIRE or CG): measurements timed, and the result filled at the stop.
template <class System>
class Descent {
 public:
  explicit Descent(System& s) : s_(s) {}
  MinimiserReport measure() {
    const auto t0 = std::chrono::steady_clock::now();
    MinimiserReport r = s_.measure();
    seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return r;
  }
  /// The result of a stop at force evaluation `it` with the last step `dt`; `report` the measurement that
  /// decided it, or nullptr (measured now).
  FireResult finish(bool converged, const char* reason, std::int64_t it, double dt, const MinimiserReport* report) {
    result.converged = converged;
    result.stopReason = reason;
    result.iterations = it;
    result.last = report ? *report : measure();
    result.last.iteration = it;
    result.last.dt = dt;
    result.seconds.measure = seconds_;
    s_.finish(result);
    return result;
  }
  /// A progress report at force evaluation `it` (also refreshes the rule's force scale).
  void report(const std::function<void(const MinimiserReport&)>& progress, std::int64_t it, double dt, StopRule& rule,
              const FireSettings& fs) {
    MinimiserReport now = measure();
    now.iteration = it;
    now.dt = dt;
    rule.knownScale = std::max(now.meanContactForce, fs.referenceForce);
    progress(now);
  }
  FireResult result;

 private:
  System& s_;
  double seconds_ = 0.0;
};

/// FIRE 2.0 from the system's current state (the header of fire_minimiser.hpp).
template <class System>
FireResult descend(System& s, const FireSettings& fs, const std::function<void(const MinimiserReport&)>& progress,
                   bool stopOnInterrupt) {
  Descent<System> call(s);
  const MinimiserReport start = call.measure();
  s.prepare(start);
  StopRule rule(fs, start, s.overlapFloor());
  const double dtMax = fs.dt * fs.dtMaxFactor;
  const double dtMin = fs.dt * fs.dtMinFactor;
  double dt = fs.dt;
  double alpha = fs.alphaStart;
  std::int64_t downhill = 0, uphill = 0;
  auto finish = [&](bool converged, const char* reason, std::int64_t it, const MinimiserReport* report) {
    return call.finish(converged, reason, it, dt, report);
  };

  for (std::int64_t it = 0;; ++it) {
    auto [power, vv, ff, fvm, ffm, fmaxSq] = s.sums();
    if (!std::isfinite(ff) || !std::isfinite(vv)) {
      throw SimulationError(fmt::format("minimiser: non-finite forces or velocities at FIRE step {}", it));
    }
    const double fmax = std::sqrt(fmaxSq);
    if (fmax <= fs.forceTolerance * rule.knownScale || fmaxSq == 0.0 || it % kMeasureEvery == 0) {
      const MinimiserReport now = call.measure();
      if (const char* why = rule.verdict(now, fmax, it)) return finish(true, why, it, &now);
    }
    if (it >= fs.maxIterations) return finish(false, "iteration budget", it, nullptr);
    if (stopOnInterrupt && s.interrupted()) return finish(false, "interrupted", it, nullptr);
    if (progress && fs.progressInterval > 0 && it % fs.progressInterval == 0) call.report(progress, it, dt, rule, fs);

    if (power > 0.0) {
      ++downhill;
      uphill = 0;
      if (downhill > fs.nDelay) {
        dt = std::min(dt * fs.fInc, dtMax);
        alpha *= fs.fAlpha;
      }
    } else {
      downhill = 0;
      ++uphill;
      ++call.result.uphillSteps;
      if (uphill > fs.maxUphill) return finish(false, "uphill", it, nullptr);
      if (!(fs.initialDelay && it < fs.nDelay)) {
        if (dt * fs.fDec >= dtMin) dt *= fs.fDec;
        alpha = fs.alphaStart;
      }
      // FIRE 2.0: correct the overshoot by half a step back, then restart from rest.
      s.restart(dt);
      vv = 0.0;
      fvm = 0.0;
    }

    // Semi-implicit Euler with the FIRE mixing between kick and drift: v += dt F/m; v = (1 - alpha) v +
    // alpha |v| F/|F|; x += dt v. |v| after the kick from the sums above (no second pass).
    const double kicked = std::sqrt(std::max(0.0, vv + 2.0 * dt * fvm + dt * dt * ffm));
    const double fNorm = std::sqrt(ff);
    const double keep = fNorm > 0.0 ? 1.0 - alpha : 1.0;
    const double toward = fNorm > 0.0 ? alpha * kicked / fNorm : 0.0;
    s.advance(dt, keep, toward);
  }
}

/// Preconditioned Polak-Ribiere+ conjugate gradients from the system's current state (fire_minimiser.hpp:
/// s = M^-1 F, d = s + beta d, a line search of one trial move and one secant move; `dt` holds the line step,
/// in units of M^-1 F). Besides descend()'s system calls:
///   std::array<double, 3> direct(double beta, bool update)   {F.d, max |d_i|^2, max |F_i|^2}, with `update`
///                                                            first d = s + beta d; polls the interrupt flag
///   double along()                                           F.d
///   std::array<double, 2> precondition()                     s = M^-1 F: {F.s, F.(s - s_old)}
///   void resetPrevious()                                     s_old = 0
///   void restartDirection()                                  d = s
///   void moveAlong(double a)                                 x += a d; the list check; forces
///   double skin() const
template <class System>
FireResult descendByCg(System& s, const FireSettings& fs, const std::function<void(const MinimiserReport&)>& progress,
                       bool stopOnInterrupt) {
  Descent<System> call(s);
  const MinimiserReport start = call.measure();
  s.prepare(start);
  StopRule rule(fs, start, s.overlapFloor());
  double dt = 0.0;
  auto finish = [&](bool converged, const char* reason, std::int64_t it, const MinimiserReport* report) {
    return call.finish(converged, reason, it, dt, report);
  };
  s.resetPrevious();
  double sOld = s.precondition()[0];  // F.M^-1 F at the last iteration
  s.restartDirection();
  std::array<double, 3> dir = s.direct(0.0, false);
  dt = 0.5;  // the line minimum of a mode of preconditioned stiffness 2 (about the stiffest) lies at 0.5
  std::int64_t evaluations = 0;
  for (std::int64_t iteration = 0;; ++iteration) {
    double g0 = dir[0], dmaxSq = dir[1];
    const double fmaxSq = dir[2];
    if (!std::isfinite(fmaxSq)) {
      throw SimulationError(fmt::format("minimiser: non-finite forces at CG iteration {}", iteration));
    }
    const double fmax = std::sqrt(fmaxSq);
    // Every 128 iterations = 256 force evaluations, as FIRE measures.
    if (fmax <= fs.forceTolerance * rule.knownScale || fmaxSq == 0.0 || iteration % (kMeasureEvery / 2) == 0) {
      const MinimiserReport now = call.measure();
      if (const char* why = rule.verdict(now, fmax, evaluations)) return finish(true, why, evaluations, &now);
    }
    if (evaluations >= fs.maxIterations) return finish(false, "iteration budget", evaluations, nullptr);
    if (stopOnInterrupt && s.interrupted()) return finish(false, "interrupted", evaluations, nullptr);
    if (progress && fs.progressInterval > 0 && iteration % ((fs.progressInterval + 1) / 2) == 0) {
      call.report(progress, evaluations, dt, rule, fs);
    }
    if (!(g0 > 0.0)) {  // not a descent direction: restart along M^-1 F
      ++call.result.uphillSteps;
      g0 = sOld;
      s.restartDirection();
      dmaxSq = s.direct(0.0, false)[1];
    }
    // No line move carries a sphere further than one skin (a guard: near jamming the moves are ~1e-6 of it;
    // without it, a direction without positive curvature would grow the step 4x per iteration unbounded).
    const double reach = dmaxSq > 0.0 ? s.skin() / std::sqrt(dmaxSq) : 4.0 * dt;
    const double trial = std::min(dt, reach);
    s.moveAlong(trial);
    const double g1 = s.along();
    // The secant root of g(a) = F(x + a d).d; where g did not fall (no positive curvature along d), go on
    // downhill by the cap.
    const double secant = g0 > g1 ? trial * g0 / (g0 - g1) : 4.0 * trial;
    const double best = std::min({secant, 4.0 * trial, reach});
    s.moveAlong(best - trial);
    evaluations += 2;
    dt = std::max(best, 1e-4);  // the next trial: the last line step (kept off zero)
    const std::array<double, 2> pre = s.precondition();
    const double beta = sOld > 0.0 ? std::max(0.0, pre[1] / sOld) : 0.0;
    sOld = pre[0];
    dir = s.direct(beta, true);
  }
}

/// x_i += a d_i (a conjugate-gradient move): returns the squared displacement from `ref`.
inline double moveParticle(Index i, double a, const double* __restrict d, double* __restrict x,
                           const double* __restrict ref) {
  double dsq = 0.0;
  for (int k = 0; k < 3; ++k) {
    const Index j = 3 * i + k;
    x[j] += a * d[j];
    const double dx = x[j] - ref[j];
    dsq += dx * dx;
  }
  return dsq;
}

/// |a|^2 of a 3-vector, left to right (measure()'s max |F_i|^2 on every system).
inline double squaredNorm3(const double* a) { return a[0] * a[0] + a[1] * a[1] + a[2] * a[2]; }

/// The kick-mix-drift of particle i (the arithmetic of descend()'s step, one definition for every system):
/// returns the squared displacement from `ref`.
inline double kickMixDrift(Index i, double dt, double keep, double toward, const double* __restrict f,
                           double* __restrict v, double* __restrict x, const double* __restrict im,
                           const double* __restrict ref) {
  // Registers first, stores last: the arrays may alias as far as the compiler knows (see halfKick).
  const double h = dt * im[i];
  double fa[3], va[3], xa[3];
  for (int k = 0; k < 3; ++k) {
    fa[k] = f[3 * i + k];
    va[k] = v[3 * i + k];
    xa[k] = x[3 * i + k];
  }
  double dsq = 0.0;
  for (int k = 0; k < 3; ++k) {
    va[k] = keep * (va[k] + h * fa[k]) + toward * fa[k];
    xa[k] += dt * va[k];
    const double dx = xa[k] - ref[3 * i + k];
    dsq += dx * dx;
  }
  for (int k = 0; k < 3; ++k) {
    v[3 * i + k] = va[k];
    x[3 * i + k] = xa[k];
  }
  return dsq;
}

}  // namespace polydem::integrators::fire
