#pragma once
// Contact laws for soft spheres: normal spring-dashpot (linear or Hertz) and an optional Cundall-Strack
// tangential spring with Coulomb friction.
//
// Sign conventions (used by every kernel): for a pair (i, j), n = (x_i - x_j) / |x_i - x_j| points from
// j to i, overlap = r_i + r_j - |x_i - x_j| > 0 in contact, rate = d(overlap)/dt = -(v_i - v_j) . n.
// The normal force on i is +F_n n (F_n > 0 repulsive), on j it is -F_n n. Walls are the box's
// non-periodic faces; a particle-wall contact uses the same law with m_eff = m_i and R_eff = r_i.
//
// Damping is set per pair from the restitution coefficient e and the pair's reduced mass, so that
// every pair, whatever its sizes, rebounds head-on with exactly e:
//   linear:  F_n = k d + c d',          c = 2 zeta sqrt(m_eff k),
//            zeta = -ln e / sqrt(pi^2 + ln^2 e)   (e = exp(-pi zeta / sqrt(1 - zeta^2)), inverted),
//            contact duration t_c = pi / (omega_0 sqrt(1 - zeta^2)), omega_0 = sqrt(k / m_eff);
//            see eqs. 8-12 of Schwager & Poeschel, Granular Matter 9, 465 (2007).
//   Hertz:   F_n = K sqrt(R_eff) d^(3/2) + eta d^(1/4) d',   eta = alpha sqrt(m_eff K sqrt(R_eff)),
//            with K = 4/3 E* (Pa). The damping form is Tsuji et al., Powder Technol. 71, 239 (1992),
//            eq. 10: e depends on alpha only (not on the impact speed), so alpha(e) is found once by
//            integrating the dimensionless equation x'' = -x^(3/2) - alpha x^(1/4) x' (hertzAlpha()).
// Damping `mass-velocity` (LAMMPS pair_style gran/hooke, after Silbert et al., Phys. Rev. E 64, 051302
// (2001)): linear only, F_n = k d + gamma_n m_eff d' with one rate gamma_n (1/s) for every pair, so the
// restitution depends on the pair: zeta = gamma_n / (2 omega_0), e = exp(-pi zeta / sqrt(1 - zeta^2)).
// Forces are not clipped at zero: the contact ends when the overlap returns to zero, as in the
// analytic solutions above (the dashpot pulls slightly at the very end). Clipping would change e.
//
// Stiffness: linear `constant` uses k for every pair (N/m); linear `radius` uses k_ij = k R_eff (k in
// N/m^2), which keeps the relative overlap of an impact independent of size: with size ratios of 100
// one constant k either squashes the large particles or forces a tiny time step on the small ones.
//
// Tangential (Cundall & Strack, Geotechnique 29, 47 (1979)): spring displacement xi per contact,
// rotated onto the current tangent plane each step, F_t = -k_t xi - c_t v_t, capped at mu F_n
// (xi is then reset to the capped force, as in LAMMPS gran/hooke/history). k_t = ratio * (k_n for
// linear, K sqrt(R_eff d) for Hertz, i.e. LAMMPS's "polyhertz" scaling), c_t = ratio_c * c_n.
// Lever arms are r_i - d/2 and r_j - d/2 (they sum to the centre distance, so angular momentum is
// conserved exactly); for walls r_i - d.
#include <cmath>
#include <optional>
#include <string>

#include "core/types.hpp"

namespace polydem::contact {

enum class NormalModel { Linear, Hertz };
enum class StiffnessScaling { Constant, Radius };
/// How the normal dashpot is set: from e per pair (exact restitution), or one mass-velocity rate gamma_n.
enum class DampingModel { Restitution, MassVelocity };
/// The tangential law when friction > 0: polydem's Cundall-Strack spring (default); LAMMPS
/// gran/hooke/history's variant of it (lever arms r_i, r_j; spring projected after the increment; Coulomb
/// cap mu |F_n|), for reproducing LAMMPS; or Hertz-Mindlin (contact/hertz_mindlin.hpp).
enum class TangentialModel { CundallStrack, LammpsHistory, HertzMindlin };

/// What a scene asks for. Keys in messages are the scene-file keys (`contact.restitution`, ...).
struct ContactParameters {
  NormalModel normal = NormalModel::Linear;
  /// Linear constant: k (N/m). Linear radius-scaled: k_ij = stiffness * R_eff (N/m^2). Hertz: K = 4/3 E* (Pa).
  double stiffness = 0.0;
  StiffnessScaling scaling = StiffnessScaling::Constant;  ///< linear only
  double restitution = 1.0;                               ///< normal coefficient of restitution e in [0, 1]
  double friction = 0.0;                             ///< Coulomb mu >= 0; 0 = frictionless (no rotation, no history)
  double tangentialStiffnessRatio = 2.0 / 7.0;       ///< k_t / k_n (2/7: tangential and normal periods agree)
  double tangentialDampingRatio = 0.0;               ///< c_t / c_n
  double referenceVelocity = 0.0;                    ///< Hertz: impact speed (m/s) for the contact duration; 0 = unset
  DampingModel damping = DampingModel::Restitution;  ///< contact.damping
  double dampingRate = 0.0;                          ///< gamma_n (1/s), mass-velocity only: F_n += gamma_n m_eff d'
  TangentialModel tangential = TangentialModel::CundallStrack;  ///< contact.tangential (with friction)
  // Hertz-Mindlin tangential law (contact.tangential = "hertz-mindlin"; Hertz normal law only). Exactly
  // one of shearModulus and poissonRatio gives G*; tangential_stiffness_ratio does not apply.
  double shearModulus = 0.0;           ///< effective G* (Pa) of the pair; 0 = from poissonRatio
  std::optional<double> poissonRatio;  ///< nu of one material (or a sphere on a rigid plane): G* = E* (1-nu)/(2(2-nu))

  bool usesFriction() const { return friction > 0.0; }
  /// The normal dashpot is on (e < 1, or gamma_n > 0).
  bool normalDamped() const { return damping == DampingModel::Restitution ? restitution < 1.0 : dampingRate > 0.0; }
  bool elastic() const { return !normalDamped() && friction == 0.0; }
  /// Throws ConfigError naming the key: stiffness <= 0, e outside [0, 1], mu < 0, ratios < 0, ...
  void validate() const;
  /// The tangential-law part of validate(): contact.tangential, contact.shear_modulus, contact.poisson_ratio.
  void validateTangential() const;
  std::string describe() const;
};

/// Linear damping ratio zeta(e) = -ln e / sqrt(pi^2 + ln^2 e); 1 (critical) at e = 0, 0 at e = 1.
double linearDampingRatio(double restitution);

/// Hertz damping: alpha(e) for the Tsuji dashpot and the dimensionless contact duration tau_c(alpha)
/// (t_c = tau_c (m_eff / K_ij)^(2/5) v^(-1/5), K_ij = K sqrt(R_eff)). Solved once per e by bisection on
/// an adaptive RK4 integration; about 1 ms.
struct HertzDamping {
  double alpha = 0.0;
  double tau = 0.0;
};
HertzDamping hertzDamping(double restitution);
/// Head-on collision of the dimensionless Tsuji-damped Hertz contact x'' = -x^(3/2) - alpha x^(1/4) x',
/// x(0) = 0, x'(0) = 1: restitution -x'(tau) and duration tau at which x returns to 0.
struct HertzCollision {
  double restitution = 1.0;
  double tau = 0.0;
};
HertzCollision integrateHertzCollision(double alpha);

// ---------------------------------------------------------------------------------------------------
// Laws as used by the kernels: plain structs of constants and inline static functions, no virtuals.

/// Result of a normal law: force (N, > 0 repulsive) and the stiffness/damping a tangential law scales.
struct NormalForce {
  double force;
  double stiffness;  ///< N/m
  double damping;    ///< N s/m
};

struct LinearNormal {
  struct Params {
    double stiffness;  ///< N/m, or N/m^2 when radiusScaled
    double twoZeta;    ///< 2 zeta(e)
    bool radiusScaled;
  };
  static constexpr bool kUsesRotation = false;
  static constexpr int kHistorySize = 0;
  static constexpr const char* kName = "linear";

  static double pairStiffness(const Params& p, double reff) {
    return p.radiusScaled ? p.stiffness * reff : p.stiffness;
  }
  static NormalForce force(const Params& p, double overlap, double rate, double meff, double reff) {
    const double k = pairStiffness(p, reff);
    const double c = p.twoZeta * std::sqrt(meff * k);
    return {k * overlap + c * rate, k, c};
  }
  /// Elastic energy stored at this overlap (J).
  static double energy(const Params& p, double overlap, double reff) {
    return 0.5 * pairStiffness(p, reff) * overlap * overlap;
  }
};

/// Linear spring with the mass-velocity dashpot of LAMMPS gran/hooke: F_n = k d + gamma_n m_eff d'.
struct LinearMassVelocityNormal {
  struct Params {
    double stiffness;  ///< N/m, or N/m^2 when radiusScaled
    double rate;       ///< gamma_n, 1/s
    bool radiusScaled;
  };
  static constexpr bool kUsesRotation = false;
  static constexpr int kHistorySize = 0;
  static constexpr const char* kName = "linear(mass-velocity)";

  static double pairStiffness(const Params& p, double reff) {
    return p.radiusScaled ? p.stiffness * reff : p.stiffness;
  }
  static NormalForce force(const Params& p, double overlap, double rate, double meff, double reff) {
    const double k = pairStiffness(p, reff);
    const double c = p.rate * meff;
    return {k * overlap + c * rate, k, c};
  }
};

struct HertzNormal {
  struct Params {
    double stiffness;  ///< K = 4/3 E*, Pa
    double alpha;      ///< Tsuji damping constant for e
  };
  static constexpr bool kUsesRotation = false;
  static constexpr int kHistorySize = 0;
  static constexpr const char* kName = "hertz";

  static NormalForce force(const Params& p, double overlap, double rate, double meff, double reff) {
    const double kij = p.stiffness * std::sqrt(reff);  // K_ij, N/m^1.5
    const double root = std::sqrt(overlap);
    const double eta = p.alpha * std::sqrt(meff * kij);
    const double kTangent = kij * root;      // d F / d overlap without the 3/2
    const double c = eta * std::sqrt(root);  // eta overlap^(1/4)
    return {kTangent * overlap + c * rate, kTangent, c};
  }
  static double energy(const Params& p, double overlap, double reff) {
    return 0.4 * p.stiffness * std::sqrt(reff) * overlap * overlap * std::sqrt(overlap);
  }
};

struct NoTangential {
  struct Params {};
  static constexpr bool kUsesRotation = false;
  static constexpr int kHistorySize = 0;
  static constexpr const char* kName = "frictionless";
};

struct CundallStrack {
  struct Params {
    double friction;        ///< mu
    double stiffnessRatio;  ///< k_t / k_n
    double dampingRatio;    ///< c_t / c_n
  };
  static constexpr bool kUsesRotation = true;
  static constexpr int kHistorySize = 3;  ///< spring displacement xi (m), world frame
  static constexpr const char* kName = "cundall-strack";
};

/// LAMMPS gran/hooke/history's tangential spring (Silbert et al., Phys. Rev. E 64, 051302 (2001)): the
/// spring xi grows by v_t dt, is then projected onto the tangent plane (which shortens it), F_t = -k_t xi -
/// c_t v_t is capped at mu |F_n| (xi reset to the capped force); the contact-point velocity and the torques
/// use the radii r_i, r_j as lever arms (polydem's Cundall-Strack: r_i - d/2, r_j - d/2). Same constants as
/// CundallStrack: k_t = ratio k_n (LAMMPS Kt / Kn), c_t = ratio_c c_n (with mass-velocity damping
/// c_n = gamma_n m_eff, so ratio_c = LAMMPS gamma_t / gamma_n).
struct LammpsHistory {
  using Params = CundallStrack::Params;
  static constexpr bool kUsesRotation = true;
  static constexpr int kHistorySize = 3;  ///< spring displacement xi (m), world frame
  static constexpr bool kFullRadiusArms = true;
  static constexpr const char* kName = "lammps-history";
};

template <class Normal, class Tangential = NoTangential>
struct ContactLaw {
  using NormalLaw = Normal;
  using TangentialLaw = Tangential;
  struct Params {
    typename Normal::Params normal;
    typename Tangential::Params tangential;
  };
  static constexpr bool kUsesRotation = Normal::kUsesRotation || Tangential::kUsesRotation;
  static constexpr int kHistorySize = Normal::kHistorySize + Tangential::kHistorySize;
};

using LinearLaw = ContactLaw<LinearNormal>;
using HertzLaw = ContactLaw<HertzNormal>;
using LinearFrictionLaw = ContactLaw<LinearNormal, CundallStrack>;
using HertzFrictionLaw = ContactLaw<HertzNormal, CundallStrack>;
using LinearMassVelocityLaw = ContactLaw<LinearMassVelocityNormal>;
using LinearMassVelocityFrictionLaw = ContactLaw<LinearMassVelocityNormal, CundallStrack>;
using LinearLammpsLaw = ContactLaw<LinearNormal, LammpsHistory>;
using LinearMassVelocityLammpsLaw = ContactLaw<LinearMassVelocityNormal, LammpsHistory>;

/// Validated parameters plus the constants derived from them (zeta or alpha). Cheap to copy.
class ContactModel {
 public:
  ContactModel() = default;
  /// Validates (ConfigError naming the key) and solves for the damping constant.
  explicit ContactModel(const ContactParameters& parameters);

  const ContactParameters& parameters() const { return parameters_; }
  double zeta() const { return zeta_; }
  const HertzDamping& hertz() const { return hertz_; }

  LinearNormal::Params linearParams() const {
    return {parameters_.stiffness, 2.0 * zeta_, parameters_.scaling == StiffnessScaling::Radius};
  }
  LinearMassVelocityNormal::Params massVelocityParams() const {
    return {parameters_.stiffness, parameters_.dampingRate, parameters_.scaling == StiffnessScaling::Radius};
  }
  HertzNormal::Params hertzParams() const { return {parameters_.stiffness, hertz_.alpha}; }
  CundallStrack::Params tangentialParams() const {
    return {parameters_.friction, parameters_.tangentialStiffnessRatio, parameters_.tangentialDampingRatio};
  }

  /// Duration (s) of a head-on contact of a pair with reduced mass m_eff (kg) and effective radius
  /// R_eff (m) at impact speed v (m/s; Hertz only, linear ignores it). For e = 0 (linear) the undamped
  /// half period pi sqrt(m_eff / k), since the critically damped contact never ends; the same for a
  /// mass-velocity pair at or above critical damping (gamma_n >= 2 omega_0).
  double contactDuration(double meff, double reff, double speed) const;
  /// Elastic energy (J) of a normal overlap (m).
  double normalEnergy(double overlap, double reff) const;
  /// Head-on approach speed (m/s) at which an undamped pair reaches `overlap` (m).
  double speedForOverlap(double overlap, double meff, double reff) const;
  /// Normal stiffness that limits the overlap of a head-on impact at `speed` to `overlap` (for hints).
  double stiffnessForOverlap(double overlap, double meff, double reff, double speed) const;

 private:
  ContactParameters parameters_;
  double zeta_ = 0.0;
  HertzDamping hertz_;
};

}  // namespace polydem::contact
