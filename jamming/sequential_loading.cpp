// Sequential random loading (Donev 2006, §4.6.2, Algorithm 14) for packings with gaps: for each random
// load B and then -B, solve the load LP, scale its motion dR by the largest tau that keeps every sphere
// disjoint along 0..tau dR (the linearised solution is feasible for tau <= 1, §4.3.1; the true
// constraints often allow more, §4.6.2.3), move the spheres, rebuild the constraints and repeat while some
// sphere still moves more than beta D_i in a step (§4.6.2.4). The spheres stay where the loads took them
// (no reset between loads). Displacements are measured against each sphere's own diameter D_i (Table
// 4.2). Not jammed as soon as the accumulated motion of a loaded sphere exceeds maxLimit D_i or the mean
// exceeds meanLimit.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "jamming/load_lp.hpp"
#include "jamming/load_protocols.hpp"

namespace polydem::jamming {

namespace {

// The configuration the loads move, and the statistics of its accumulated displacement.
struct Walk {
  Eigen::VectorXd radius;
  Eigen::Matrix3Xd centre;
  Eigen::Matrix3Xd moved;  // accumulated, unwrapped, length units
  double loadedCount = 0.0;
  double totalMax = 0.0, totalMean = 0.0;  // accumulated displacement now
  double peakMax = 0.0, peakMean = 0.0;    // the largest they have been
};

// Unloaded spheres (rattlers) only make room; an LP may still send them anywhere within the box
// (§4.6.2.2), which is meaningless beyond the gap tolerance. Their coordinates are bounded so that they
// move by less than gapTolerance r_min, the range in which every pair that could collide is a constraint.
std::vector<double> columnBounds(const detail::LoadProblem& problem, double minRadius) {
  const LoadTestOptions& options = problem.options;
  std::vector<double> columnBound(3 * problem.movable.size(), options.maxDisplacement);
  for (std::size_t m = 0; m < problem.movable.size(); ++m) {
    if (problem.loaded[m]) continue;
    for (int k = 0; k < 3; ++k) {
      columnBound[3 * m + static_cast<std::size_t>(k)] =
          0.99 * options.gapTolerance * minRadius / (std::sqrt(3.0) * problem.diameter);
    }
  }
  return columnBound;
}

// Moves the spheres by tau dr; returns the largest step of a loaded sphere (own diameters) and updates the
// accumulated statistics and result.displaced.
double applyStep(const detail::LoadProblem& problem, double tau, const Eigen::Matrix3Xd& dr, Walk& walk,
                 SequentialLoadingResult& result) {
  double stepMax = 0.0;
  walk.totalMax = 0.0;
  double sum = 0.0;
  Index beyond = 0;
  for (std::size_t m = 0; m < problem.movable.size(); ++m) {
    const Index i = problem.movable[m];
    walk.centre.col(i) = problem.box.wrap(walk.centre.col(i) + tau * dr.col(i));
    walk.moved.col(i) += tau * dr.col(i);
    if (!problem.loaded[m]) continue;  // rattlers may wander in their cages
    const double di = 2.0 * walk.radius[i];
    stepMax = std::max(stepMax, tau * dr.col(i).norm() / di);
    const double total = walk.moved.col(i).norm() / di;
    walk.totalMax = std::max(walk.totalMax, total);
    sum += total;
    if (total > problem.options.maxLimit) ++beyond;
  }
  walk.totalMean = sum / walk.loadedCount;
  walk.peakMax = std::max(walk.peakMax, walk.totalMax);
  walk.peakMean = std::max(walk.peakMean, walk.totalMean);
  result.displaced = beyond;
  return stepMax;
}

std::string sequentialVerdict(const LoadTestOptions& options, bool stopped, const Walk& walk,
                              const SequentialLoadingResult& result) {
  const std::string loads = fmt::format("{} random loads and their opposites, {} LPs", options.loads, result.steps);
  const std::string linear =
      fmt::format("the LPs' own motions reach {:.3g} D ({} loaded spheres beyond the ideal limit {:.1e} D)",
                  result.linearLargest, result.linearDisplaced, options.displacementLimit);
  if (result.steps == 0) return "not tested: no LP was solved";
  if (result.jammed) {
    return fmt::format(
        "jammed (sequential random loading, seed Algorithm 14): {}; largest accumulated displacement of a loaded "
        "sphere {:.3g} D_i (limit {:.3g}), largest mean {:.3g} D_i (limit {:.3g}); {}",
        loads, walk.peakMax, options.maxLimit, walk.peakMean, options.meanLimit, linear);
  }
  if (stopped) {
    return fmt::format(
        "unjammed (sequential random loading, seed Algorithm 14): after {} LPs the loaded spheres moved by up to "
        "{:.3g} D_i ({} beyond the limit {:.3g}), mean {:.3g} D_i (limit {:.3g}); {}",
        result.steps, walk.peakMax, result.displaced, options.maxLimit, walk.peakMean, options.meanLimit, linear);
  }
  return fmt::format(
      "undecided (sequential random loading, seed Algorithm 14): a load still moved spheres by more than {:.3g} "
      "D_i per step after {} steps; accumulated max {:.3g} D_i, mean {:.3g} D_i; {}",
      options.beta, options.maxSteps, walk.peakMax, walk.peakMean, linear);
}

void sequentialLoading(detail::LoadProblem& problem, SequentialLoadingResult& result) {
  const LoadTestOptions& options = problem.options;
  const Box& box = problem.box;
  const Index n = problem.n;
  Walk walk{problem.spheres.radius, problem.spheres.centre, Eigen::Matrix3Xd::Zero(3, n),
            static_cast<double>(std::count(problem.loaded.begin(), problem.loaded.end(), 1))};
  const std::vector<double> columnBound = columnBounds(problem, walk.radius.minCoeff());
  bool configurationMoved = false;
  bool stopped = false;    // a threshold was exceeded: unjammed
  bool unsettled = false;  // a load still moved spheres by more than beta after maxSteps LPs
  for (int load = 0; load < options.loads && !stopped; ++load) {
    const std::vector<double> b = problem.randomLoad();
    for (double sign : {1.0, -1.0}) {
      if (stopped) break;
      std::vector<double> beta(b.size());
      for (std::size_t c = 0; c < b.size(); ++c) beta[c] = sign * b[c];
      bool settled = false;
      for (int step = 1; step <= options.maxSteps && !stopped; ++step) {
        detail::LoadLp lp = configurationMoved
                                ? detail::buildLoadLp(SphereView{walk.centre, walk.radius}, box, problem.slot,
                                                      options.gapTolerance, problem.diameter)
                                : problem.lp;
        lp.bound = options.maxDisplacement;
        lp.columnBound = columnBound;
        problem.pin(lp);
        const std::vector<double> x = problem.solve(lp, beta);
        ++result.steps;
        Eigen::Matrix3Xd dr = Eigen::Matrix3Xd::Zero(3, n);
        double linearLargest = 0.0;  // the LP's own motion, in mean diameters (the ideal test's measure)
        Index linearBeyond = 0;
        for (std::size_t m = 0; m < problem.movable.size(); ++m) {
          for (int k = 0; k < 3; ++k) {
            dr(k, problem.movable[m]) = x[3 * m + static_cast<std::size_t>(k)] * problem.diameter;
          }
          if (!problem.loaded[m]) continue;
          const double d = dr.col(problem.movable[m]).norm() / problem.diameter;
          linearLargest = std::max(linearLargest, d);
          if (d > options.displacementLimit) ++linearBeyond;
        }
        if (step == 1 && linearLargest > result.linearLargest) {
          result.linearLargest = linearLargest;
          result.linearDisplaced = linearBeyond;
        }
        const double largestMove = dr.colwise().norm().maxCoeff();
        if (largestMove <= 0.0) {
          settled = true;
          break;
        }
        const double cap = options.gapTolerance * walk.radius.minCoeff() / largestMove;
        const double tau = std::max(detail::largestScaling(lp, walk.centre, walk.radius, box, dr, options.gapTolerance),
                                    std::min(1.0, cap));
        const double stepMax = applyStep(problem, tau, dr, walk, result);
        configurationMoved = true;
        if (options.progress) {
          options.progress(fmt::format(
              "load {}{} step {}: LP motion up to {:.3g} D ({} spheres beyond {:.1e} D), scaled by {:.3g}: step up "
              "to {:.3g} D_i; accumulated max {:.3g} D_i, mean {:.3g} D_i ({:.1f} s so far)",
              load + 1, sign > 0 ? "+" : "-", step, linearLargest, linearBeyond, options.displacementLimit, tau,
              stepMax, walk.totalMax, walk.totalMean, problem.elapsed()));
        }
        if (walk.totalMax > options.maxLimit || walk.totalMean > options.meanLimit) stopped = true;
        if (stepMax <= options.beta) {
          settled = true;
          break;
        }
      }
      if (!settled && !stopped) unsettled = true;
    }
  }
  result.largestDisplacement = walk.peakMax;
  result.meanDisplacement = walk.peakMean;
  result.motion = walk.moved;
  result.jammed = !stopped && !unsettled && result.steps > 0;
  result.outcome = result.steps == 0 ? JammingVerdict::NotTested
                   : result.jammed   ? JammingVerdict::Jammed
                   : stopped         ? JammingVerdict::Unjammed
                                     : JammingVerdict::Undecided;
  result.verdict = sequentialVerdict(options, stopped, walk, result);
}

SequentialLoadingResult sequentialOnce(const SphereView& spheres, const Box& box, const ContactNetwork& network,
                                       const LoadTestOptions& options) {
  detail::LoadProblem problem(spheres, box, network, options, LoadProtocol::Sequential);
  SequentialLoadingResult result;
  if (!problem.prepare(result)) return result;
  sequentialLoading(problem, result);
  result.solver = problem.solverName();
  result.seconds = problem.elapsed();
  return result;
}

// Rounds of Algorithm 13 around the sequential test: the loaded spheres that moved beyond maxLimit are
// removed from the packing (no variables, no constraints: stricter than unloading them) and the rest is
// tested again from the original configuration, until a round passes; that remainder is a jammed
// subpacking, which by Donev's definition makes the packing jammed (§4.2.4.1). A round stopped by the
// mean alone names nobody to remove and ends the search.
SequentialLoadingResult sequentialRounds(const SphereView& spheres, const Box& box, const ContactNetwork& network,
                                         const LoadTestOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  LoadTestOptions round = options;
  round.subpackingRounds = 1;
  SequentialLoadingResult first;
  SubpackingSearch& search = first.search;
  Index removedTotal = 0;
  for (int r = 1; r <= options.subpackingRounds; ++r) {
    if (options.progress) options.progress(fmt::format("subpacking round {}", r));
    SequentialLoadingResult now = sequentialOnce(spheres, box, network, round);
    if (r == 1) {
      first = now;
    } else {
      first.steps += now.steps;
      first.solver += fmt::format(" + round {}: {}", r, now.solver);
    }
    search.rounds = r;
    if (now.jammed) {
      search.subpackingJammed = true;
      search.setAsidePerRound.push_back(0);
      Index tested = 0;
      for (Index i = 0; i < spheres.count(); ++i) tested += network.rattler[static_cast<std::size_t>(i)] ? 0 : 1;
      search.subpacking = tested - static_cast<Index>(options.removed.size()) - removedTotal - now.localRattlers;
      break;
    }
    std::vector<char> gone(static_cast<std::size_t>(spheres.count()), 0);
    for (Index i : round.removed) gone[static_cast<std::size_t>(i)] = 1;
    Index added = 0;
    for (Index i = 0; i < spheres.count(); ++i) {
      if (gone[static_cast<std::size_t>(i)] || network.rattler[static_cast<std::size_t>(i)]) continue;
      if (now.motion.col(i).norm() / (2.0 * spheres.radius[i]) > options.maxLimit) {
        round.removed.push_back(i);
        ++added;
      }
    }
    search.setAsidePerRound.push_back(added);
    removedTotal += added;
    if (added == 0) break;
  }
  search.loose = removedTotal;
  std::string perRound;
  for (Index k : search.setAsidePerRound) perRound += fmt::format("{}{}", perRound.empty() ? "" : ", ", k);
  if (!first.jammed) {
    first.verdict +=
        search.subpackingJammed
            ? fmt::format(
                  "; jammed subpacking of {} spheres after {} rounds (loaded spheres beyond {:.3g} D_i "
                  "removed per round: {})",
                  search.subpacking, search.rounds, options.maxLimit, perRound)
            : fmt::format("; no jammed subpacking in {} rounds (removed per round: {})", search.rounds, perRound);
  }
  first.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return first;
}

}  // namespace

SequentialLoadingResult testSequentialLoading(const SphereView& spheres, const Box& box, const ContactNetwork& network,
                                              const LoadTestOptions& options) {
  detail::requireLoads(options);
  if (options.subpackingRounds > 1) return sequentialRounds(spheres, box, network, options);
  return sequentialOnce(spheres, box, network, options);
}

}  // namespace polydem::jamming
