#pragma once
// Spherical harmonics Y_lm (Condon-Shortley phase, orthonormal on the unit sphere) without trigonometry:
// Y_lm(u) = Q_lm(u_z) (u_x + i u_y)^m for m >= 0, where Q_lm = P~_lm / sin^m(theta) obeys the standard
// fully normalised associated Legendre recurrences (the sin^m factor cancels in them):
//   Q_00 = 1 / sqrt(4 pi),  Q_mm = -sqrt((2m + 1) / (2m)) Q_(m-1)(m-1),  Q_(m+1)m = sqrt(2m + 3) z Q_mm,
//   Q_lm = a_lm (z Q_(l-1)m - b_lm Q_(l-2)m),  a_lm = sqrt((4l^2 - 1) / (l^2 - m^2)),
//   b_lm = sqrt(((l - 1)^2 - m^2) / (4 (l - 1)^2 - 1)),
// and Y_l(-m) = (-1)^m conj(Y_lm). Stable for every direction (no division by sin theta at the poles).
// Used for the bond-orientational order q_lm of Ogarko's thesis eq. 3.56 (§3.3.3).
#include <Eigen/Core>
#include <complex>
#include <span>

namespace polydem::structure {

inline constexpr int kMaxDegree = 12;

/// Y_lm(u) for m = -l..l into out[m + l] (out.size() >= 2l + 1), for a unit vector u (not checked;
/// scale first). 0 <= l <= kMaxDegree. O(l^2) flops, no allocation.
void sphericalHarmonics(int l, const Eigen::Vector3d& u, std::span<std::complex<double>> out);

}  // namespace polydem::structure
