#pragma once
// Structure factor and spectral density of a periodic sphere configuration (Ogarko's thesis §3.3.4, eqs.
// 3.58-3.60, §3.3.4; Donev 2006 ch. 10, §10.2):
//   S(k)   = |sum_j exp(-i k.r_j)|^2 / N                         (k != 0)
//   chi(k) = |sum_j exp(-i k.r_j) m(k; R_j)|^2 / V,   m(k; R) = 4 pi (sin kR - kR cos kR) / k^3
// on the wave vectors allowed by the box, k = 2 pi (n_x / L_x, n_y / L_y, n_z / L_z), averaged over
// spherical shells of thickness dk = 2 pi / min L (shell s holds (s - 1/2) dk <= |k| < (s + 1/2) dk), with k
// reported as K = k D, D = 2 <r>. Only half of k-space is summed (S(-k) = S(k) for real densities).
//
// Cost: N x (number of wave vectors, ~ (2/3) pi (K_max L / (2 pi D))^3) complex multiply-adds. No
// trigonometry per (k, particle): per block of particles, exp(-i 2 pi n x / L) comes from powers of
// exp(-i 2 pi x / L) per axis, and the phase of a row of k_z values is one product per entry. m(k; R_j)
// depends on |k| only, so it is tabulated once per distinct |k| (a cubic box has <= 3 n_max^2 of them).
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/box.hpp"
#include "core/particle_store.hpp"

namespace polydem::structure {

struct StructureFactorOptions {
  double kMax = 20.0;           ///< largest K = k D (D = 2 <r>)
  bool spectralDensity = true;  ///< also compute chi(k)
  /// Cap on the wave vectors (0 = none): above it only every s-th allowed vector per axis is used,
  /// n = s m, with the smallest stride s that fits (shell width s 2 pi / min L). Large or dilute boxes
  /// have ~ (K_max L / D)^3 / 8 pi^2 vectors, far more than a shell average needs.
  std::int64_t maxVectors = 0;
};

struct StructureFactor {
  std::vector<double> k;              ///< mean K = |k| D over the shell's vectors
  std::vector<double> s;              ///< shell mean of S(k)
  std::vector<double> chi;            ///< shell mean of chi(k) (m^3); empty unless requested
  std::vector<std::int64_t> vectors;  ///< wave vectors per shell (half space)
  double diameter = 0.0;              ///< D = 2 <r> (m)
  double shellWidth = 0.0;            ///< dk (1/m)
  int stride = 1;                     ///< wave vectors used: n = stride m (see maxVectors)
  std::int64_t totalVectors = 0;
};

/// Shell-averaged S(k) and chi(k) up to options.kMax (see top). Throws ConfigError unless every axis is
/// periodic, for kMax <= 0, invalid spheres, or more than 2e8 wave vectors (lower kMax).
StructureFactor structureFactor(const SphereView& spheres, const Box& box, const StructureFactorOptions& options = {});

/// S and chi at one wave vector k = 2 pi n / L (component-wise), by direct summation with sin/cos:
/// the reference for tests. n != 0.
struct StructureFactorValue {
  double s = 0.0, chi = 0.0;
};
StructureFactorValue structureFactorAt(const SphereView& spheres, const Box& box, const Eigen::Vector3i& n);

/// Fourier transform of the unit ball of radius R at wave number k: 4 pi (sin kR - kR cos kR) / k^3
/// (series near k R = 0, where it tends to 4 pi R^3 / 3).
double sphereFormFactor(double k, double R);

}  // namespace polydem::structure
