#include "structure/spherical_harmonics.hpp"

#include <array>
#include <cmath>

#include "core/errors.hpp"
#include "core/types.hpp"

namespace polydem::structure {

void sphericalHarmonics(int l, const Eigen::Vector3d& u, std::span<std::complex<double>> out) {
  POLYDEM_ASSERT(l >= 0 && l <= kMaxDegree && out.size() >= static_cast<std::size_t>(2 * l + 1), "bad degree");
  const double z = u[2];
  const std::complex<double> w(u[0], u[1]);  // sin(theta) e^{i phi}
  std::complex<double> wm(1.0, 0.0);         // w^m
  double qmm = 1.0 / std::sqrt(4.0 * kPi);   // Q_mm
  for (int m = 0; m <= l; ++m) {
    if (m > 0) qmm *= -std::sqrt((2.0 * m + 1.0) / (2.0 * m));
    // Raise the degree from m to l at fixed order m.
    double q = qmm;
    if (l > m) {
      double prev = qmm;
      double cur = std::sqrt(2.0 * m + 3.0) * z * qmm;
      for (int ll = m + 2; ll <= l; ++ll) {
        const double a = std::sqrt((4.0 * ll * ll - 1.0) / (double(ll) * ll - double(m) * m));
        const double b = std::sqrt((double(ll - 1) * (ll - 1) - double(m) * m) / (4.0 * (ll - 1) * (ll - 1) - 1.0));
        const double next = a * (z * cur - b * prev);
        prev = cur;
        cur = next;
      }
      q = cur;
    }
    const std::complex<double> y = q * wm;
    out[static_cast<std::size_t>(l + m)] = y;
    if (m > 0) out[static_cast<std::size_t>(l - m)] = (m % 2 ? -1.0 : 1.0) * std::conj(y);
    wm *= w;
  }
}

}  // namespace polydem::structure
