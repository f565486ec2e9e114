// Prints the Chung & Ooi oblique-impact curves as CSV (for scripts/chung_ooi_plots.py), each point one
// impact run through DemSimulation, for the Hertz-Mindlin and the Cundall-Strack (k_t / (K sqrt(R* d)) = 2/7)
// tangential laws over the same Hertz normal law:
//   chung_ooi_curves psi    # test 5: Psi2 against Psi1, with the no-slip and sliding limits
//   chung_ooi_curves angle  # test 4: tangential restitution, spin and rebound angle against incident angle
#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "tests/chung_ooi/impact.hpp"

using namespace polydem;
using namespace polydem::chung_ooi;

namespace {

const char* lawName(contact::TangentialModel law) {
  return law == contact::TangentialModel::HertzMindlin ? "hertz-mindlin" : "cundall-strack";
}

void psiCurve() {
  const double vn = 5.0, mu = 0.092, r = 0.0025;
  const double kappa = 3.0 * (1.0 - 0.23) / (2.0 - 0.23);
  const double noSlip = noSlipRatio(kappa);
  std::printf("law,psi1,psi2,psi2_no_slip,psi2_sliding\n");
  for (auto law : {contact::TangentialModel::HertzMindlin, contact::TangentialModel::CundallStrack}) {
    for (int k = 1; k <= 60; ++k) {
      const double psi1 = 0.2 * k;
      const double tanTheta = psi1 * 3.0 * mu / (2.0 * kappa);
      Impact s{.a = {kAluminiumOxide, r, Vec3(vn * tanTheta, 0, -vn)}, .friction = mu, .tangential = law};
      s.stepsPerContact = 400.0;
      const Angles a = normalisedAngles(s, run(s));
      fmt::print("{},{:.6g},{:.6g},{:.6g},{:.6g}\n", lawName(law), a.psi1, a.psi2, noSlip * psi1,
                 slidingPsi2(psi1, kappa, 1.0));
    }
  }
}

void angleCurve() {
  const double speed = 3.9, mu = 0.092, e = 0.98, r = 0.0025;
  std::printf("law,theta_deg,tangential_restitution,r_omega_over_v,rebound_angle_deg,et_sliding,rebound_sliding_deg\n");
  for (auto law : {contact::TangentialModel::HertzMindlin, contact::TangentialModel::CundallStrack}) {
    for (int deg = 2; deg <= 88; deg += 2) {
      const double th = deg * kPi / 180.0;
      const double vt = speed * std::sin(th), vn = speed * std::cos(th);
      Impact s{.a = {kAluminiumOxide, r, Vec3(vt, 0, -vn)}, .restitution = e, .friction = mu, .tangential = law};
      s.stepsPerContact = 400.0;
      const Outcome o = run(s);
      const Vec3 vc = contactVelocity(o.velocityA, o.spinA, r, Vec3::Zero(), Vec3::Zero(), 0.0);
      // Rigid-body theory: sliding throughout above tan(theta) = 7/2 mu (1 + e), rolling (e_t = 5/7) below.
      const bool sliding = std::tan(th) > 3.5 * mu * (1.0 + e);
      const double etRigid = sliding ? 1.0 - mu * (1.0 + e) * vn / vt : 5.0 / 7.0;
      const double vcRigid = sliding ? vt - 3.5 * mu * (1.0 + e) * vn : 0.0;
      fmt::print("{},{},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g}\n", lawName(law), deg, o.velocityA.x() / vt,
                 -o.spinA.y() * r / speed, std::atan2(vc.x(), o.velocityA.z()) * 180.0 / kPi, etRigid,
                 std::atan2(vcRigid, e * vn) * 180.0 / kPi);
    }
  }
}

/// One test-5 impact at Psi1 with f steps per contact, every number printed (for checking a point).
void point(double psi1, double f, contact::TangentialModel law) {
  const double vn = 5.0, mu = 0.092, r = 0.0025;
  const double kappa = 3.0 * (1.0 - 0.23) / (2.0 - 0.23);
  const double tanTheta = psi1 * 3.0 * mu / (2.0 * kappa);
  Impact s{.a = {kAluminiumOxide, r, Vec3(vn * tanTheta, 0, -vn)}, .friction = mu, .tangential = law};
  s.stepsPerContact = f;
  const Outcome o = run(s);
  const Angles a = normalisedAngles(s, o);
  fmt::print(
      "{} psi1 {} f {}: v_z' / v_n = {:.9f}, -dv_x / (2 mu v_n) = {:.6f}, r omega_y / (5 mu v_n) = {:.6f}, "
      "psi2 = {:.6f} (sliding {:.6f}, no-slip {:.6f}), t_c = {:.6g} s\n",
      lawName(law), psi1, f, o.velocityA.z() / vn, (vn * tanTheta - o.velocityA.x()) / (2.0 * mu * vn),
      o.spinA.y() * r / (5.0 * mu * vn), a.psi2, slidingPsi2(psi1, kappa, 1.0), noSlipRatio(kappa) * psi1,
      o.contactDuration);
}

}  // namespace

int main(int argc, char** argv) {
  const std::string what = argc > 1 ? argv[1] : "";
  if (what == "psi") {
    psiCurve();
  } else if (what == "point" && argc == 4) {
    point(std::stod(argv[2]), std::stod(argv[3]), contact::TangentialModel::HertzMindlin);
    point(std::stod(argv[2]), std::stod(argv[3]), contact::TangentialModel::CundallStrack);
  } else if (what == "angle") {
    angleCurve();
  } else {
    std::fprintf(stderr, "usage: chung_ooi_curves psi|angle\n");
    return 2;
  }
  return 0;
}
