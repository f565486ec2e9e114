#pragma once
// Hertz-Mindlin tangential law (no-slip Mindlin stiffness with a Coulomb limit), the tangential law
// assumed by the DEM verification benchmark of Chung & Ooi, Granular Matter 13, 643 (2011).
//
// Mindlin, J. Appl. Mech. 16, 259 (1949): the tangential stiffness of a Hertz contact of radius
// a = sqrt(R* d) before any micro-slip is k_t = 8 G* a, with 1/G* = (2 - nu1)/G1 + (2 - nu2)/G2 and
// G = E / (2 (1 + nu)). It is applied incrementally, dF_t = -k_t(d) v_t dt (Di Renzo & Di Maio, Chem.
// Eng. Sci. 59, 525 (2004), "no-slip" model; Thornton et al., Powder Technol. 210, 189 (2011)): the
// history holds the tangential spring force itself (N, world frame, 3 doubles), not a displacement, so
// a force built at a large contact radius is not rescaled when the contact shrinks. Each step the
// stored force is rotated onto the current tangent plane keeping its length (as Cundall-Strack does with
// its displacement), incremented, then capped at mu F_n; when capped, the stored force is reset to the
// limit (sliding). An optional dashpot c_t = ratio * c_n acts on the tangential contact-point velocity.
//
// In the kernel, the Hertz normal law hands over nf.stiffness = K sqrt(R* d) (K = 4/3 E*), so
// k_t = (8 G* / K) nf.stiffness: the law needs one constant, stiffnessRatio = 8 G* / K. For two bodies of
// one material, or a sphere on a rigid plane, G* / E* = (1 - nu) / (2 (2 - nu)) and the ratio is
// 3 (1 - nu) / (2 - nu) (0.78 at nu = 0.3; Cundall-Strack's usual 2/7 is another ratio of another
// stiffness).
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <optional>

#include "contact/contact_law.hpp"

namespace polydem::contact {

struct HertzMindlin {
  struct Params {
    double friction;        ///< mu
    double stiffnessRatio;  ///< 8 G* / K: k_t = stiffnessRatio * K sqrt(R* d)
    double dampingRatio;    ///< c_t / c_n
  };
  static constexpr bool kUsesRotation = true;
  static constexpr int kHistorySize = 3;  ///< tangential spring force (N), world frame
  static constexpr const char* kName = "hertz-mindlin";
};

using HertzMindlinLaw = ContactLaw<HertzNormal, HertzMindlin>;

/// Isotropic elastic solid: Young's modulus E (Pa; +inf for a rigid body) and Poisson ratio nu.
struct ElasticMaterial {
  double youngModulus;
  double poissonRatio;
  /// Shear modulus G = E / (2 (1 + nu)) (Pa).
  double shearModulus() const { return youngModulus / (2.0 * (1.0 + poissonRatio)); }
};

/// Hertz effective modulus E* (Pa): 1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2; a rigid body adds nothing.
inline double effectiveYoungModulus(const ElasticMaterial& a, const ElasticMaterial& b) {
  auto compliance = [](const ElasticMaterial& m) {
    return std::isinf(m.youngModulus) ? 0.0 : (1.0 - m.poissonRatio * m.poissonRatio) / m.youngModulus;
  };
  return 1.0 / (compliance(a) + compliance(b));
}

/// Mindlin effective shear modulus G* (Pa): 1/G* = (2 - nu1)/G1 + (2 - nu2)/G2; a rigid body adds nothing.
inline double effectiveShearModulus(const ElasticMaterial& a, const ElasticMaterial& b) {
  auto compliance = [](const ElasticMaterial& m) {
    return std::isinf(m.youngModulus) ? 0.0 : (2.0 - m.poissonRatio) / m.shearModulus();
  };
  return 1.0 / (compliance(a) + compliance(b));
}

/// G* / E* for two bodies of one material, or one body on a rigid plane: (1 - nu) / (2 (2 - nu)).
inline double shearToYoungRatio(double poissonRatio) { return (1.0 - poissonRatio) / (2.0 * (2.0 - poissonRatio)); }

/// 8 G* / K of validated Hertz-Mindlin parameters: from contact.shear_modulus (G*) when given, else from
/// contact.poisson_ratio (one material, or a sphere on a rigid plane): 3 (1 - nu) / (2 - nu).
inline double mindlinStiffnessRatio(const ContactParameters& c) {
  if (c.shearModulus > 0.0) return 8.0 * c.shearModulus / c.stiffness;
  const double nu = c.poissonRatio.value_or(0.0);
  return 3.0 * (1.0 - nu) / (2.0 - nu);
}

/// Kernel constants of a model whose contact.tangential is "hertz-mindlin".
inline HertzMindlin::Params hertzMindlinParams(const ContactModel& model) {
  const ContactParameters& c = model.parameters();
  return {c.friction, mindlinStiffnessRatio(c), c.tangentialDampingRatio};
}

namespace detail {

/// Hertz-Mindlin tangential force on i for one contact (see the file comment). `vt` is the tangential
/// contact-point velocity for the dashpot (predicted v(t + dt)), `vtHalf` the one for the increment
/// (v(t + dt/2)); `spring` holds the spring force (3 doubles), updated in place.
inline Eigen::Vector3d tangentialForce(const HertzMindlin::Params& p, const NormalForce& nf, const Eigen::Vector3d& n,
                                       const Eigen::Vector3d& vt, const Eigen::Vector3d& vtHalf, double dt,
                                       double* spring) {
  Eigen::Vector3d s(spring[0], spring[1], spring[2]);
  const double along = s.dot(n);
  if (along != 0.0) {
    const double before = s.squaredNorm();
    s -= along * n;
    const double after = s.squaredNorm();
    if (after > 0.0) s *= std::sqrt(before / after);
  }
  const double kt = p.stiffnessRatio * nf.stiffness;
  s -= (kt * dt) * vtHalf;
  const double ct = p.dampingRatio * nf.damping;
  Eigen::Vector3d ft = s - ct * vt;
  const double limit = p.friction * std::max(nf.force, 0.0);
  const double ftSq = ft.squaredNorm();
  if (ftSq > limit * limit) {
    // Sliding: the force is the Coulomb limit along its current direction; the spring keeps what the
    // dashpot does not carry, so that it restarts from the limit when sliding stops.
    ft *= limit / std::sqrt(ftSq);
    s = ft + ct * vt;
  }
  spring[0] = s[0];
  spring[1] = s[1];
  spring[2] = s[2];
  return ft;
}

}  // namespace detail

}  // namespace polydem::contact
