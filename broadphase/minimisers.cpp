// Nelder-Mead and BFGS; see minimisers.hpp for the references.
#include "broadphase/minimisers.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace polydem::broadphase {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

double nelderMead(const Objective& objective, std::vector<double>& x, double step, long maxEvaluations,
                  double tolerance) {
  long evaluations = 0;
  auto f = [&](const double* at) {
    ++evaluations;
    return objective(at);
  };
  const int n = static_cast<int>(x.size());
  const double alpha = 1.0, gamma = 1.0 + 2.0 / n, rho = 0.75 - 0.5 / n, sigma = 1.0 - 1.0 / n;
  std::vector<std::vector<double>> simplex(static_cast<std::size_t>(n + 1), x);
  std::vector<double> value(static_cast<std::size_t>(n + 1));
  for (int i = 0; i < n; ++i) simplex[i + 1][i] += step;
  for (int i = 0; i <= n; ++i) value[i] = f(simplex[i].data());
  std::vector<int> order(static_cast<std::size_t>(n + 1));
  std::vector<double> centroid(x.size()), trial(x.size()), trial2(x.size());
  auto point = [&](double t, std::vector<double>& out) {  // centroid + t (centroid - worst)
    const auto& worst = simplex[order[n]];
    for (int k = 0; k < n; ++k) out[k] = centroid[k] + t * (centroid[k] - worst[k]);
  };
  for (;;) {
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](int a, int b) { return value[a] < value[b]; });
    const double best = value[order[0]], worst = value[order[n]];
    if (worst - best <= tolerance * std::abs(best) || evaluations >= maxEvaluations) break;
    std::fill(centroid.begin(), centroid.end(), 0.0);
    for (int i = 0; i < n; ++i) {
      for (int k = 0; k < n; ++k) centroid[k] += simplex[order[i]][k] / n;
    }
    point(alpha, trial);
    const double fr = f(trial.data());
    const double secondWorst = value[order[n - 1]];
    if (fr < best) {
      point(alpha * gamma, trial2);
      const double fe = f(trial2.data());
      if (fe < fr) {
        simplex[order[n]] = trial2;
        value[order[n]] = fe;
      } else {
        simplex[order[n]] = trial;
        value[order[n]] = fr;
      }
      continue;
    }
    if (fr < secondWorst) {
      simplex[order[n]] = trial;
      value[order[n]] = fr;
      continue;
    }
    const bool outside = fr < worst;
    point(outside ? alpha * rho : -rho, trial2);
    const double fc = f(trial2.data());
    if (fc < (outside ? fr : worst)) {
      simplex[order[n]] = trial2;
      value[order[n]] = fc;
      continue;
    }
    // Shrink towards the best vertex.
    const auto& b = simplex[order[0]];
    for (int i = 1; i <= n; ++i) {
      auto& v = simplex[order[i]];
      for (int k = 0; k < n; ++k) v[k] = b[k] + sigma * (v[k] - b[k]);
      value[order[i]] = f(v.data());
    }
  }
  const int bestIndex = static_cast<int>(std::min_element(value.begin(), value.end()) - value.begin());
  x = simplex[bestIndex];
  return value[bestIndex];
}

double bfgs(const Objective& f, std::vector<double>& x, double fx, double h, int maxIterations, double minGain) {
  const int n = static_cast<int>(x.size());
  std::vector<double> g(x.size()), gNew(x.size()), p(x.size()), xNew(x.size()), s(x.size()), y(x.size()), Hy(x.size());
  std::vector<double> H(static_cast<std::size_t>(n) * n, 0.0);
  auto resetH = [&](double scale) {
    std::fill(H.begin(), H.end(), 0.0);
    for (int i = 0; i < n; ++i) H[i * n + i] = scale;
  };
  auto gradient = [&](std::vector<double>& at, std::vector<double>& out) {
    for (int i = 0; i < n; ++i) {
      const double keep = at[i];
      at[i] = keep + h;
      const double fp = f(at.data());
      at[i] = keep - h;
      const double fm = f(at.data());
      at[i] = keep;
      out[i] = (fp - fm) / (2.0 * h);
    }
  };
  resetH(1.0);
  gradient(x, g);
  for (int iter = 0; iter < maxIterations; ++iter) {
    for (int i = 0; i < n; ++i) {
      p[i] = 0.0;
      for (int j = 0; j < n; ++j) p[i] -= H[i * n + j] * g[j];
    }
    double slope = std::inner_product(p.begin(), p.end(), g.begin(), 0.0);
    if (!(slope < 0.0)) {
      resetH(1.0);
      for (int i = 0; i < n; ++i) p[i] = -g[i];
      slope = std::inner_product(p.begin(), p.end(), g.begin(), 0.0);
      if (!(slope < 0.0)) break;
    }
    // Cap the step: a weight change of 2 already changes a level's share by e^2.
    const double largest =
        std::abs(*std::max_element(p.begin(), p.end(), [](double a, double b) { return std::abs(a) < std::abs(b); }));
    double t = largest > 2.0 ? 2.0 / largest : 1.0;
    double fNew = kInf;
    for (; t > 1e-10; t *= 0.5) {
      for (int i = 0; i < n; ++i) xNew[i] = x[i] + t * p[i];
      fNew = f(xNew.data());
      if (fNew <= fx + 1e-4 * t * slope) break;
    }
    if (!(fNew < fx)) break;
    const double gain = fx - fNew;
    gradient(xNew, gNew);
    for (int i = 0; i < n; ++i) {
      s[i] = xNew[i] - x[i];
      y[i] = gNew[i] - g[i];
    }
    x.swap(xNew);
    g.swap(gNew);
    fx = fNew;
    const double sy = std::inner_product(s.begin(), s.end(), y.begin(), 0.0);
    if (sy > 1e-300) {
      if (iter == 0) resetH(sy / std::inner_product(y.begin(), y.end(), y.begin(), 0.0));
      // H <- (I - rho s y^T) H (I - rho y s^T) + rho s s^T
      const double rho = 1.0 / sy;
      for (int i = 0; i < n; ++i) {
        Hy[i] = 0.0;
        for (int j = 0; j < n; ++j) Hy[i] += H[i * n + j] * y[j];
      }
      const double yHy = std::inner_product(y.begin(), y.end(), Hy.begin(), 0.0);
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
          H[i * n + j] += -rho * (s[i] * Hy[j] + Hy[i] * s[j]) + (rho * rho * yHy + rho) * s[i] * s[j];
        }
      }
    }
    if (gain <= minGain * std::abs(fx)) break;
  }
  return fx;
}

}  // namespace polydem::broadphase
