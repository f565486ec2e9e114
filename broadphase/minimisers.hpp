#pragma once
// Generic unconstrained minimisers of f: R^n -> R without analytic gradients, used by the HGrid optimiser
// (hgrid_optimiser.cpp) to minimise the cost model over cell sizes. Small n (up to a few tens), f cheap
// but not smooth everywhere (a sample's cost is a fine staircase).
//   nelderMead  the simplex method of Nelder & Mead, Comput. J. 7 (1965) 308, with the adaptive
//               coefficients of Gao & Han, Comput. Optim. Appl. 51 (2012) 259 (alpha = 1,
//               gamma = 1 + 2/n, rho = 3/4 - 1/(2n), sigma = 1 - 1/n), robust for n up to ~30;
//   bfgs        quasi-Newton BFGS (Nocedal & Wright, Numerical Optimization, 2nd ed. 2006, Algorithm 6.1)
//               with central-difference gradients and Armijo backtracking.
// Both are deterministic: the same f and start give the same result bit for bit.
#include <functional>
#include <vector>

namespace polydem::broadphase {

/// The function to minimise, called with a pointer to n doubles.
using Objective = std::function<double(const double* x)>;

/// Nelder-Mead from x (n >= 1) with an initial simplex of edge `step` along each axis. Stops when
/// (worst - best) <= tolerance |best| over the simplex or after about maxEvaluations calls of f.
/// Minimises in place (x = best vertex); returns f(x).
double nelderMead(const Objective& f, std::vector<double>& x, double step, long maxEvaluations, double tolerance);

/// BFGS from x with f(x) = fx, central-difference gradients of step h, steps capped at 2 in the largest
/// component. Stops after maxIterations, when no descent step is found, or when an iteration gains less
/// than minGain |f| (relative). Minimises in place; returns f(x).
double bfgs(const Objective& f, std::vector<double>& x, double fx, double h, int maxIterations, double minGain);

}  // namespace polydem::broadphase
