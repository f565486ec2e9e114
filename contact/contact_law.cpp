#include "contact/contact_law.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/errors.hpp"

namespace polydem::contact {

namespace {

void requireFinite(std::string_view key, double value) {
  if (!std::isfinite(value)) throw ConfigError(fmt::format("{} must be a finite number, got {}", key, value));
}

}  // namespace

void ContactParameters::validate() const {
  requireFinite("contact.stiffness", stiffness);
  if (!(stiffness > 0.0)) throw ConfigError(fmt::format("contact.stiffness must be > 0, got {}", stiffness));
  requireFinite("contact.restitution", restitution);
  if (restitution < 0.0 || restitution > 1.0) {
    throw ConfigError(fmt::format("contact.restitution must be in [0, 1], got {}", restitution));
  }
  requireFinite("contact.friction", friction);
  if (friction < 0.0) throw ConfigError(fmt::format("contact.friction must be >= 0, got {}", friction));
  requireFinite("contact.tangential_stiffness_ratio", tangentialStiffnessRatio);
  if (!(tangentialStiffnessRatio > 0.0)) {
    throw ConfigError(fmt::format("contact.tangential_stiffness_ratio must be > 0, got {}", tangentialStiffnessRatio));
  }
  requireFinite("contact.tangential_damping_ratio", tangentialDampingRatio);
  if (tangentialDampingRatio < 0.0) {
    throw ConfigError(fmt::format("contact.tangential_damping_ratio must be >= 0, got {}", tangentialDampingRatio));
  }
  requireFinite("contact.reference_velocity", referenceVelocity);
  if (referenceVelocity < 0.0) {
    throw ConfigError(fmt::format("contact.reference_velocity must be >= 0, got {}", referenceVelocity));
  }
  if (normal == NormalModel::Hertz && scaling == StiffnessScaling::Radius) {
    throw ConfigError(
        "contact.stiffness_scaling = \"radius\" applies to the linear law only: the Hertz law already scales "
        "with sqrt(R_eff)");
  }
  requireFinite("contact.gamma_n", dampingRate);
  if (dampingRate < 0.0) throw ConfigError(fmt::format("contact.gamma_n must be >= 0 (1/s), got {}", dampingRate));
  if (damping == DampingModel::MassVelocity) {
    if (normal != NormalModel::Linear) {
      throw ConfigError(
          "contact.damping = \"mass-velocity\" applies to the linear law only (LAMMPS gran/hooke); the Hertz law "
          "uses contact.damping = \"restitution\"");
    }
    if (restitution != 1.0) {
      throw ConfigError(fmt::format(
          "contact.restitution = {} and contact.damping = \"mass-velocity\" exclude each other: the dashpot is "
          "set by contact.gamma_n",
          restitution));
    }
  } else if (dampingRate != 0.0) {
    throw ConfigError(fmt::format(
        "contact.gamma_n = {} applies to contact.damping = \"mass-velocity\" only (the restitution dashpot is set "
        "by contact.restitution)",
        dampingRate));
  }
  if (tangential == TangentialModel::LammpsHistory && normal != NormalModel::Linear) {
    throw ConfigError(
        "contact.tangential = \"lammps-history\" applies to the linear law only (LAMMPS gran/hooke/history)");
  }
  validateTangential();
  if (normal == NormalModel::Hertz && restitution < 1e-3) {
    throw ConfigError(
        fmt::format("contact.restitution = {} is below 0.001, which the Hertz (Tsuji) dashpot cannot reach; use the "
                    "linear law for nearly plastic contacts",
                    restitution));
  }
}

void ContactParameters::validateTangential() const {
  requireFinite("contact.shear_modulus", shearModulus);
  if (shearModulus < 0.0) throw ConfigError(fmt::format("contact.shear_modulus must be > 0, got {}", shearModulus));
  if (poissonRatio) {
    requireFinite("contact.poisson_ratio", *poissonRatio);
    // Above 0.5 is not an isotropic solid; below 0 (auxetic) the Hertz-Mindlin ratio is untested here.
    if (*poissonRatio < 0.0 || *poissonRatio > 0.5) {
      throw ConfigError(fmt::format("contact.poisson_ratio must be in [0, 0.5], got {}", *poissonRatio));
    }
  }
  if (tangential != TangentialModel::HertzMindlin) {
    if (shearModulus > 0.0 || poissonRatio) {
      throw ConfigError(fmt::format("contact.{} applies to contact.tangential = \"hertz-mindlin\" only",
                                    shearModulus > 0.0 ? "shear_modulus" : "poisson_ratio"));
    }
    return;
  }
  if (normal != NormalModel::Hertz) {
    throw ConfigError(
        "contact.tangential = \"hertz-mindlin\" needs contact.law = \"hertz\" (the Mindlin stiffness 8 G* sqrt(R* d) "
        "belongs to a Hertz contact)");
  }
  if ((shearModulus > 0.0) == poissonRatio.has_value()) {
    throw ConfigError(
        "contact.tangential = \"hertz-mindlin\" needs exactly one of contact.shear_modulus (the pair's effective G*, "
        "Pa) "
        "and contact.poisson_ratio (one material: G* = E* (1 - nu) / (2 (2 - nu)))");
  }
}

std::string ContactParameters::describe() const {
  std::string text;
  if (normal == NormalModel::Linear) {
    text = scaling == StiffnessScaling::Constant ? fmt::format("linear k = {:g} N/m", stiffness)
                                                 : fmt::format("linear k = {:g} R_eff N/m", stiffness);
  } else {
    text = fmt::format("hertz K = {:g} Pa", stiffness);
  }
  if (damping == DampingModel::MassVelocity) {
    text += fmt::format(", mass-velocity gamma_n = {:g} 1/s", dampingRate);
  } else {
    text += fmt::format(", e = {:g}", restitution);
  }
  if (friction > 0.0 && tangential == TangentialModel::HertzMindlin) {
    const double gStar =
        shearModulus > 0.0 ? shearModulus : 0.75 * stiffness * (1.0 - *poissonRatio) / (2.0 * (2.0 - *poissonRatio));
    text +=
        fmt::format(", mu = {:g}, hertz-mindlin G* = {:g} Pa, c_t/c_n = {:g}", friction, gStar, tangentialDampingRatio);
  } else if (friction > 0.0) {
    text += fmt::format(", mu = {:g}, k_t/k_n = {:g}, c_t/c_n = {:g}", friction, tangentialStiffnessRatio,
                        tangentialDampingRatio);
    if (tangential == TangentialModel::LammpsHistory) text += " (lammps-history)";
  } else {
    text += ", frictionless";
  }
  return text;
}

double linearDampingRatio(double restitution) {
  if (restitution <= 0.0) return 1.0;
  const double l = std::log(restitution);
  return -l / std::sqrt(kPi * kPi + l * l);
}

HertzCollision integrateHertzCollision(double alpha) {
  // Adaptive RK4: the step follows x / |v| so the singular x^(1/4) at both ends of the contact is
  // resolved (steps shrink geometrically towards x = 0), with at most 1e-3 in the middle.
  auto accel = [alpha](double x, double v) {
    if (x <= 0.0) return 0.0;
    const double root = std::sqrt(x);
    return -x * root - alpha * std::sqrt(root) * v;
  };
  double x = 0.0, v = 1.0, t = 0.0;
  for (int iter = 0; iter < 10'000'000; ++iter) {
    const double h = std::clamp(0.02 * x / std::max(std::abs(v), 1e-300), 1e-10, 1e-3);
    const double k1x = v, k1v = accel(x, v);
    const double k2x = v + 0.5 * h * k1v, k2v = accel(x + 0.5 * h * k1x, v + 0.5 * h * k1v);
    const double k3x = v + 0.5 * h * k2v, k3v = accel(x + 0.5 * h * k2x, v + 0.5 * h * k2v);
    const double k4x = v + h * k3v, k4v = accel(x + h * k3x, v + h * k3v);
    const double xn = x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
    const double vn = v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
    if (xn <= 0.0 && t > 0.0) {
      const double s = x / (x - xn);  // linear interpolation of the crossing inside this (tiny) step
      return {-(v + s * (vn - v)), t + s * h};
    }
    x = xn;
    v = vn;
    t += h;
  }
  return {0.0, t};  // never returned: fully plastic within the iteration budget
}

HertzDamping hertzDamping(double restitution) {
  if (restitution >= 1.0) return {0.0, integrateHertzCollision(0.0).tau};
  // e(alpha) decreases monotonically from 1 at alpha = 0: bracket, then bisect.
  double lo = 0.0, hi = 0.5;
  HertzCollision c = integrateHertzCollision(hi);
  while (c.restitution > restitution) {
    lo = hi;
    hi *= 2.0;
    if (hi > 1e4) {
      throw ConfigError(fmt::format("contact.restitution = {} is not reachable with the Hertz dashpot", restitution));
    }
    c = integrateHertzCollision(hi);
  }
  for (int iter = 0; iter < 60 && hi - lo > 1e-12 * hi; ++iter) {
    const double mid = 0.5 * (lo + hi);
    if (integrateHertzCollision(mid).restitution > restitution) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  const double alpha = 0.5 * (lo + hi);
  return {alpha, integrateHertzCollision(alpha).tau};
}

ContactModel::ContactModel(const ContactParameters& parameters) : parameters_(parameters) {
  parameters_.validate();
  zeta_ = linearDampingRatio(parameters_.restitution);
  if (parameters_.normal == NormalModel::Hertz) hertz_ = hertzDamping(parameters_.restitution);
}

double ContactModel::contactDuration(double meff, double reff, double speed) const {
  if (parameters_.normal == NormalModel::Linear) {
    const double k = LinearNormal::pairStiffness(linearParams(), reff);
    const double omega0 = std::sqrt(k / meff);
    if (parameters_.damping == DampingModel::MassVelocity) {
      const double zeta = parameters_.dampingRate / (2.0 * omega0);
      return zeta < 1.0 ? kPi / (omega0 * std::sqrt(1.0 - zeta * zeta)) : kPi / omega0;
    }
    return zeta_ < 1.0 ? kPi / (omega0 * std::sqrt(1.0 - zeta_ * zeta_)) : kPi / omega0;
  }
  const double kij = parameters_.stiffness * std::sqrt(reff);
  return hertz_.tau * std::pow(meff / kij, 0.4) * std::pow(speed, -0.2);
}

double ContactModel::normalEnergy(double overlap, double reff) const {
  return parameters_.normal == NormalModel::Linear ? LinearNormal::energy(linearParams(), overlap, reff)
                                                   : HertzNormal::energy(hertzParams(), overlap, reff);
}

double ContactModel::speedForOverlap(double overlap, double meff, double reff) const {
  return std::sqrt(2.0 * normalEnergy(overlap, reff) / meff);
}

double ContactModel::stiffnessForOverlap(double overlap, double meff, double reff, double speed) const {
  const double energy = 0.5 * meff * speed * speed;
  if (parameters_.normal == NormalModel::Linear) {
    const double k = 2.0 * energy / (overlap * overlap);
    return parameters_.scaling == StiffnessScaling::Radius ? k / reff : k;
  }
  return energy / (0.4 * std::sqrt(reff) * overlap * overlap * std::sqrt(overlap));
}

}  // namespace polydem::contact
