// One LP per random load (Donev 2006, §4.6.1, Algorithm 13), with the rounds that search for a jammed
// subpacking: spheres a load displaces beyond the limit are set aside (unloaded, like rattlers, but they
// keep their constraints, §4.6.2.2) and the rest is loaded again, until a round displaces nobody: that
// remainder is a jammed subpacking (§4.2.4.1). Round 1 decides the packing as a whole and gives its
// unjamming motion.
#include <fmt/format.h>

#include <algorithm>

#include "jamming/load_lp.hpp"
#include "jamming/load_protocols.hpp"

namespace polydem::jamming {

namespace {

// One load LP's motion and how far it took the loaded spheres (and, strict, the cell boundary).
struct LoadOutcome {
  double largest = 0.0;  // mean diameters
  Index displaced = 0;
  Eigen::Matrix3Xd motion;
};

LoadOutcome evaluateLoad(const detail::LoadProblem& problem, const std::vector<double>& x,
                         std::vector<char>& displacedNow, SingleLoadResult& result) {
  const LoadTestOptions& options = problem.options;
  LoadOutcome out;
  out.motion = Eigen::Matrix3Xd::Zero(3, problem.n);
  if (options.strict) {
    // The cell deformation as a displacement of the cell boundary, |eps| L_max, in mean diameters,
    // judged like a sphere's displacement.
    const std::size_t e = static_cast<std::size_t>(problem.cols - 6);
    Eigen::Matrix3d eps;
    eps << x[e], 0.5 * x[e + 5], 0.5 * x[e + 4], 0.5 * x[e + 5], x[e + 1], 0.5 * x[e + 3], 0.5 * x[e + 4],
        0.5 * x[e + 3], x[e + 2];
    const double boundary = eps.norm() * problem.box.lengths().maxCoeff() / problem.diameter;
    if (boundary > result.strainDisplacement) {
      result.strainDisplacement = boundary;
      result.strain = eps;
    }
    out.largest = std::max(out.largest, boundary);
  }
  for (std::size_t m = 0; m < problem.movable.size(); ++m) {
    Eigen::Vector3d dr;
    for (int k = 0; k < 3; ++k) dr[k] = x[3 * m + static_cast<std::size_t>(k)];
    out.motion.col(problem.movable[m]) = dr * problem.diameter;
    if (!problem.loaded[m]) continue;  // rattlers may wander in their cages
    out.largest = std::max(out.largest, dr.norm());
    if (dr.norm() > options.displacementLimit) {
      ++out.displaced;
      displacedNow[m] = 1;
    }
  }
  return out;
}

// The rounds; the verdict of round 1 is the packing's.
void loadRounds(detail::LoadProblem& problem, SingleLoadResult& result) {
  const LoadTestOptions& options = problem.options;
  Index loose = 0;
  for (int round = 1; round <= std::max(1, options.subpackingRounds); ++round) {
    const std::int64_t loadedCount = std::count(problem.loaded.begin(), problem.loaded.end(), 1);
    if (loadedCount < 2) break;
    problem.pin(problem.lp);
    LoadOutcome worst;
    worst.largest = -1.0;
    std::vector<char> displacedNow(problem.movable.size(), 0);
    for (int load = 0; load < options.loads; ++load) {
      const std::vector<double> b = problem.randomLoad();  // no net force
      for (double sign : {1.0, -1.0}) {
        std::vector<double> beta(b.size());
        for (std::size_t c = 0; c < b.size(); ++c) beta[c] = sign * b[c];
        const std::vector<double> x = problem.solve(problem.lp, beta);
        double objective = 0.0;
        for (std::size_t c = 0; c < beta.size(); ++c) objective += beta[c] * x[c];
        result.objectives.push_back(objective);
        LoadOutcome now = evaluateLoad(problem, x, displacedNow, result);
        if (options.progress) {
          options.progress(
              fmt::format("round {} load {}{}: {} backbone spheres beyond {:.1e} D, largest {:.3g} D ({:.1f} s so far)",
                          round, load + 1, sign > 0 ? "+" : "-", now.displaced, options.displacementLimit, now.largest,
                          problem.elapsed()));
        }
        if (now.largest > worst.largest) worst = std::move(now);
      }
    }
    result.search.rounds = round;
    if (round == 1) {
      result.largestDisplacement = worst.largest;
      result.displaced = worst.displaced;
      result.motion = std::move(worst.motion);
      // worst < 0: no LP ran (no loads); that proves nothing.
      result.jammed = worst.largest >= 0.0 && worst.largest <= options.displacementLimit;
      result.outcome = worst.largest < 0.0 ? JammingVerdict::NotTested
                       : result.jammed     ? JammingVerdict::Jammed
                                           : JammingVerdict::Unjammed;
    }
    const Index setAside = std::count(displacedNow.begin(), displacedNow.end(), 1);
    result.search.setAsidePerRound.push_back(setAside);
    if (setAside == 0) {
      result.search.subpacking = static_cast<Index>(loadedCount);
      result.search.subpackingJammed = true;
      break;
    }
    loose += setAside;
    for (std::size_t m = 0; m < problem.movable.size(); ++m) {
      if (displacedNow[m]) problem.loaded[m] = 0;
    }
  }
  result.search.loose = loose;
}

std::string singleVerdict(const LoadTestOptions& options, Index backboneTested, const SingleLoadResult& result) {
  const SubpackingSearch& search = result.search;
  std::string verdict;
  if (result.outcome == JammingVerdict::NotTested) {
    verdict = "not tested: no LP was solved";
  } else if (result.jammed) {
    verdict = fmt::format("jammed{}: no backbone sphere moves more than {:.1e} D under {} random loads",
                          options.strict ? " (strictly: lattice deformation allowed)" : "", options.displacementLimit,
                          2 * options.loads);
  } else {
    verdict = fmt::format("unjammed{}: a load moves {} backbone spheres by more than {:.1e} D (up to {:.3g} D)",
                          options.strict ? " (strict test, lattice deformation allowed)" : "", result.displaced,
                          options.displacementLimit, result.largestDisplacement);
  }
  if (options.strict) {
    verdict += fmt::format("; largest cell deformation {:.3g} D at the cell boundary (strain norm {:.3g})",
                           result.strainDisplacement, result.strain.norm());
  }
  if (!result.jammed && options.subpackingRounds > 1) {
    std::string perRound;
    for (Index k : search.setAsidePerRound) perRound += fmt::format("{}{}", perRound.empty() ? "" : ", ", k);
    verdict += search.subpackingJammed
                   ? fmt::format(
                         "; jammed subpacking of {} of {} backbone spheres ({:.2f}%) after {} rounds (displaced per "
                         "round: {})",
                         search.subpacking, backboneTested,
                         100.0 * static_cast<double>(search.subpacking) / static_cast<double>(backboneTested),
                         search.rounds, perRound)
                   : fmt::format(
                         "; no jammed subpacking found in {} rounds ({} of {} backbone spheres set aside; displaced "
                         "per round: {})",
                         search.rounds, search.loose, backboneTested, perRound);
  }
  return verdict;
}

}  // namespace

SingleLoadResult testSingleLoads(const SphereView& spheres, const Box& box, const ContactNetwork& network,
                                 const LoadTestOptions& options) {
  detail::requireLoads(options);
  detail::LoadProblem problem(spheres, box, network, options, LoadProtocol::SingleLp);
  SingleLoadResult result;
  if (!problem.prepare(result)) return result;
  loadRounds(problem, result);
  result.verdict = singleVerdict(options, static_cast<Index>(problem.backboneCount), result);
  result.solver = problem.solverName();
  result.seconds = problem.elapsed();
  return result;
}

}  // namespace polydem::jamming
