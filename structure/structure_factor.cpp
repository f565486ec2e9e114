#include "structure/structure_factor.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/errors.hpp"
#include "core/types.hpp"
#include "structure/delaunay_neighbours.hpp"

namespace polydem::structure {

double sphereFormFactor(double k, double R) {
  const double x = k * R;
  if (std::abs(x) < 1e-2) {
    const double x2 = x * x;
    return 4.0 * kPi * R * R * R * (1.0 / 3.0 - x2 / 30.0 + x2 * x2 / 840.0);
  }
  return 4.0 * kPi * (std::sin(x) - x * std::cos(x)) / (k * k * k);
}

namespace {

void requirePeriodic(const Box& box, const char* what) {
  if (!box.fullyPeriodic()) {
    throw ConfigError(fmt::format(
        "{}: the structure factor needs a box periodic on every axis (allowed wave vectors k = 2 pi n / L); got "
        "{}",
        what, box.describe()));
  }
}

// Smallest stride s with at most maxVectors wave vectors on the lattice n = s m (0 = no cap): the half
// ball of radius kmax holds ~ (2/3) pi kmax^3 V / (2 pi)^3 allowed vectors.
int chooseStride(double kmax, double volume, std::int64_t maxVectors) {
  int stride = 1;
  if (maxVectors > 0) {
    const double estimate = 2.0 / 3.0 * kPi * std::pow(kmax, 3) * volume / std::pow(2.0 * kPi, 3);
    while (estimate / std::pow(double(stride), 3) > double(maxVectors)) ++stride;
  }
  return stride;
}

// A row of k_z at fixed (n_x, n_y): n_z = lo .. hi, stored from index `first` of the flat vector arrays.
struct Row {
  int nx, ny, lo, hi;
  std::int64_t first;
};

// The wave-vector lattice of the (stride-shrunk) box and its rows.
struct WaveVectors {
  Eigen::Vector3d L, dk;  // box lengths / stride, lattice spacing 2 pi / L
  int nmax[3];            // largest |n| per axis with |n dk| <= kmax
  std::vector<Row> rows;
};

// Rows of k_z at fixed (n_x, n_y) in the half space n > 0 (lexicographic), |k| <= kmax; returns the
// number of vectors.
std::int64_t halfSpaceRows(double kmax, WaveVectors& w) {
  const Eigen::Vector3d& dk = w.dk;
  const int* nmax = w.nmax;
  std::int64_t total = 0;
  for (int nx = 0; nx <= nmax[0]; ++nx) {
    for (int ny = nx == 0 ? 0 : -nmax[1]; ny <= nmax[1]; ++ny) {
      const double kx = nx * dk[0], ky = ny * dk[1];
      const double rest = kmax * kmax - kx * kx - ky * ky;
      if (rest < 0.0) continue;
      const int zmax = std::min(nmax[2], static_cast<int>(std::floor(std::sqrt(rest) / dk[2])));
      const int lo = (nx == 0 && ny == 0) ? 1 : -zmax;
      if (lo > zmax) continue;
      w.rows.push_back({nx, ny, lo, zmax, total});
      total += zmax - lo + 1;
    }
  }
  return total;
}

// |k| per vector.
std::vector<double> vectorNorms(const WaveVectors& w, std::size_t V) {
  std::vector<double> kNorm(V);
  for (const Row& r : w.rows) {
    for (int nz = r.lo; nz <= r.hi; ++nz) {
      const Eigen::Vector3d k(r.nx * w.dk[0], r.ny * w.dk[1], nz * w.dk[2]);
      kNorm[static_cast<std::size_t>(r.first + nz - r.lo)] = k.norm();
    }
  }
  return kNorm;
}

// Sums over the particles per wave vector: sum_j exp(-i k.r_j) (s) and, for unequal radii, the same
// weighted by m(k; R_j) (c, tabulated per distinct |k|: unique, uniqueOf).
struct FourierSums {
  std::vector<double> sRe, sIm, cRe, cIm;
  std::vector<double> unique;          // distinct |k| values, ascending
  std::vector<std::int32_t> uniqueOf;  // per vector: its index in unique
};

// The distinct |k| values (relative tolerance 1e-13) and each vector's index among them.
void distinctNorms(const std::vector<double>& kNorm, std::vector<double>& unique, std::vector<std::int32_t>& uniqueOf) {
  const std::size_t V = kNorm.size();
  std::vector<std::size_t> order(V);
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return kNorm[a] < kNorm[b]; });
  uniqueOf.resize(V);
  for (std::size_t idx : order) {
    if (unique.empty() || kNorm[idx] > unique.back() * (1.0 + 1e-13)) unique.push_back(kNorm[idx]);
    uniqueOf[idx] = static_cast<std::int32_t>(unique.size() - 1);
  }
}

// Entry t of re/im holds exp(-i 2 pi (nLow + t) x / L), t = 0 .. width - 1, built by repeated
// multiplication from n = 0.
void fillAxis(double x, double L, int nLow, int width, double* re, double* im) {
  const double angle = -2.0 * kPi * x / L;
  const double cr = std::cos(angle), ci = std::sin(angle);
  const int zero = -nLow;
  re[zero] = 1.0;
  im[zero] = 0.0;
  double pr = 1.0, pi = 0.0;
  for (int t = zero + 1; t < width; ++t) {
    const double nr = pr * cr - pi * ci, ni = pr * ci + pi * cr;
    pr = nr;
    pi = ni;
    re[t] = pr;
    im[t] = pi;
    const int mirror = 2 * zero - t;  // n -> -n is the complex conjugate
    if (mirror >= 0) {
      re[mirror] = pr;
      im[mirror] = -pi;
    }
  }
}

// The Fourier sums of every vector, by blocks of particles with per-particle phase tables per axis.
void accumulateSums(const SphereView& spheres, const WaveVectors& wv, bool polyChi, std::size_t V, FourierSums& sums) {
  const Index N = spheres.count();
  const int* nmax = wv.nmax;
  const Eigen::Vector3d& L = wv.L;
  const std::vector<double>& unique = sums.unique;
  const std::vector<std::int32_t>& uniqueOf = sums.uniqueOf;
  std::vector<double>&sRe = sums.sRe, &sIm = sums.sIm, &cRe = sums.cRe, &cIm = sums.cIm;
  sRe.assign(V, 0.0);
  sIm.assign(V, 0.0);
  if (polyChi) {
    cRe.assign(V, 0.0);
    cIm.assign(V, 0.0);
  }
  // Per-particle phase tables of one block: exp(-i 2 pi n x / L) for n = 0..nx (x), -ny..ny (y), -nz..nz (z).
  const int wx = nmax[0] + 1, wy = 2 * nmax[1] + 1, wz = 2 * nmax[2] + 1;
  const std::size_t U = unique.size();
  int block = 256;
  if (polyChi)
    block =
        static_cast<int>(std::clamp<std::size_t>((std::size_t{16} << 20) / (8 * std::max<std::size_t>(U, 1)), 8, 256));
  std::vector<double> exRe(static_cast<std::size_t>(block) * wx), exIm(exRe.size());
  std::vector<double> eyRe(static_cast<std::size_t>(block) * wy), eyIm(eyRe.size());
  std::vector<double> ezRe(static_cast<std::size_t>(block) * wz), ezIm(ezRe.size());
  std::vector<double> form(polyChi ? static_cast<std::size_t>(block) * U : 0);
  for (Index b0 = 0; b0 < N; b0 += block) {
    const int B = static_cast<int>(std::min<Index>(block, N - b0));
    for (int j = 0; j < B; ++j) {
      const auto x = spheres.centre.col(b0 + j);
      fillAxis(x[0], L[0], 0, wx, &exRe[j * wx], &exIm[j * wx]);
      fillAxis(x[1], L[1], -nmax[1], wy, &eyRe[j * wy], &eyIm[j * wy]);
      fillAxis(x[2], L[2], -nmax[2], wz, &ezRe[j * wz], &ezIm[j * wz]);
      if (polyChi) {
        const double R = spheres.radius[b0 + j];
        for (std::size_t u = 0; u < U; ++u) form[j * U + u] = sphereFormFactor(unique[u], R);
      }
    }
    for (const Row& r : wv.rows) {
      const int len = r.hi - r.lo + 1;
      double* accRe = &sRe[static_cast<std::size_t>(r.first)];
      double* accIm = &sIm[static_cast<std::size_t>(r.first)];
      for (int j = 0; j < B; ++j) {
        const double ar = exRe[j * wx + r.nx], ai = exIm[j * wx + r.nx];
        const double br = eyRe[j * wy + r.ny + nmax[1]], bi = eyIm[j * wy + r.ny + nmax[1]];
        const double pr = ar * br - ai * bi, pi = ar * bi + ai * br;
        const double* zr = &ezRe[j * wz + r.lo + nmax[2]];
        const double* zi = &ezIm[j * wz + r.lo + nmax[2]];
        // Independent accumulators per k_z: vectorises without reassociating sums.
        for (int t = 0; t < len; ++t) {
          accRe[t] += pr * zr[t] - pi * zi[t];
          accIm[t] += pr * zi[t] + pi * zr[t];
        }
        if (polyChi) {
          double* chRe = &cRe[static_cast<std::size_t>(r.first)];
          double* chIm = &cIm[static_cast<std::size_t>(r.first)];
          const std::int32_t* u = &uniqueOf[static_cast<std::size_t>(r.first)];
          const double* m = &form[static_cast<std::size_t>(j) * U];
          for (int t = 0; t < len; ++t) {
            const double w = m[u[t]];
            chRe[t] += w * (pr * zr[t] - pi * zi[t]);
            chIm[t] += w * (pr * zi[t] + pi * zr[t]);
          }
        }
      }
    }
  }
}

// Shell averages of S and chi into out (k, s, chi, vectors).
// Shells are centred on multiples of dk, so the axis vectors |n| = 1, 2, ... of a cubic box sit in the
// middle of a shell instead of on an edge where rounding would decide their shell.
void shellAverages(const std::vector<double>& kNorm, const FourierSums& sums, bool polyChi, bool spectralDensity,
                   Index N, double boxVolume, double rMax, double kmax, StructureFactor& out) {
  const std::vector<double>&sRe = sums.sRe, &sIm = sums.sIm, &cRe = sums.cRe, &cIm = sums.cIm;
  const std::size_t V = kNorm.size();
  const int shells = static_cast<int>(std::floor(kmax / out.shellWidth + 0.5)) + 1;
  std::vector<double> kSum(static_cast<std::size_t>(shells), 0.0), sSum(kSum.size(), 0.0), cSum(kSum.size(), 0.0);
  std::vector<std::int64_t> count(kSum.size(), 0);
  for (std::size_t v = 0; v < V; ++v) {
    const int s = std::min(shells - 1, static_cast<int>(std::floor(kNorm[v] / out.shellWidth + 0.5)));
    const double S = (sRe[v] * sRe[v] + sIm[v] * sIm[v]) / N;
    kSum[s] += kNorm[v];
    sSum[s] += S;
    if (spectralDensity) {
      if (polyChi) {
        cSum[s] += (cRe[v] * cRe[v] + cIm[v] * cIm[v]) / boxVolume;
      } else {
        const double m = sphereFormFactor(kNorm[v], rMax);
        cSum[s] += m * m * S * N / boxVolume;  // equal radii: m factors out of the sum
      }
    }
    ++count[s];
  }
  for (int s = 0; s < shells; ++s) {
    if (count[s] == 0) continue;
    out.k.push_back(kSum[s] / count[s] * out.diameter);
    out.s.push_back(sSum[s] / count[s]);
    if (spectralDensity) out.chi.push_back(cSum[s] / count[s]);
    out.vectors.push_back(count[s]);
  }
}

}  // namespace

StructureFactorValue structureFactorAt(const SphereView& spheres, const Box& box, const Eigen::Vector3i& n) {
  requirePeriodic(box, "structureFactorAt");
  requireValidSpheres(spheres, "structureFactorAt");
  if (n.isZero()) throw ConfigError("structureFactorAt: the wave vector n must not be zero");
  const Eigen::Vector3d k = 2.0 * kPi * n.cast<double>().cwiseQuotient(box.lengths());
  const double kn = k.norm();
  double re = 0.0, im = 0.0, cre = 0.0, cim = 0.0;
  for (Index j = 0; j < spheres.count(); ++j) {
    const double phase = -k.dot(spheres.centre.col(j));
    const double c = std::cos(phase), s = std::sin(phase), m = sphereFormFactor(kn, spheres.radius[j]);
    re += c;
    im += s;
    cre += m * c;
    cim += m * s;
  }
  const double N = spheres.count();
  return {(re * re + im * im) / N, (cre * cre + cim * cim) / box.volume()};
}

StructureFactor structureFactor(const SphereView& spheres, const Box& box, const StructureFactorOptions& options) {
  requirePeriodic(box, "structureFactor");
  requireValidSpheres(spheres, "structureFactor");
  if (!(options.kMax > 0.0) || !std::isfinite(options.kMax)) {
    throw ConfigError(fmt::format("structureFactor: kMax (K = k D) must be finite and > 0, got {}", options.kMax));
  }
  const Index N = spheres.count();
  if (N == 0) throw ConfigError("structureFactor: no particles");
  StructureFactor out;
  out.diameter = 2.0 * spheres.radius.mean();
  const double kmax = options.kMax / out.diameter;
  if (options.maxVectors < 0) {
    throw ConfigError(fmt::format("structureFactor: maxVectors must be >= 0, got {}", options.maxVectors));
  }
  const int stride = chooseStride(kmax, box.volume(), options.maxVectors);
  out.stride = stride;
  // With a stride, the sums use the lattice n = stride m: the same code on a box shrunk by the stride.
  WaveVectors w;
  w.L = box.lengths() / double(stride);
  w.dk = (2.0 * kPi) * w.L.cwiseInverse();
  out.shellWidth = 2.0 * kPi / w.L.minCoeff();
  for (int a = 0; a < 3; ++a) w.nmax[a] = static_cast<int>(std::floor(kmax / w.dk[a]));
  const std::int64_t total = halfSpaceRows(kmax, w);
  if (total > 200'000'000) {
    throw ConfigError(fmt::format("structureFactor: {} wave vectors up to K = {}: lower kMax", total, options.kMax));
  }
  out.totalVectors = total;
  const std::size_t V = static_cast<std::size_t>(total);
  const std::vector<double> kNorm = vectorNorms(w, V);

  const double rMin = spheres.radius.minCoeff(), rMax = spheres.radius.maxCoeff();
  const bool equalRadii = rMax - rMin <= 1e-12 * rMax;
  const bool polyChi = options.spectralDensity && !equalRadii;
  FourierSums sums;
  if (polyChi) distinctNorms(kNorm, sums.unique, sums.uniqueOf);
  accumulateSums(spheres, w, polyChi, V, sums);
  shellAverages(kNorm, sums, polyChi, options.spectralDensity, N, box.volume(), rMax, kmax, out);
  return out;
}

}  // namespace polydem::structure
