// Pressure-controlled jamming (integrators/pressure_jamming.hpp): phi_J and z of monodisperse packings, the
// scaling laws of harmonic spheres above jamming (O'Hern et al., PRE 68, 011306 (2003)).
#include "integrators/pressure_jamming.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "tests/integrators/minimise_scenes.hpp"

namespace polydem::integrators {
namespace {

using test::harmonicSettings;
using test::randomSoftStart;

TEST(PressureJamming, MonodisperseReachesPhiJAndIsostaticity) {
  auto start = randomSoftStart(512, 0.60, 7);
  FireMinimiser m(std::move(start.particles), start.box, harmonicSettings());
  PressureJammingSettings js;
  js.targetPressure = 1e-5;
  m.fireSettings().referenceForce = m.contactForceAtPressure(js.targetPressure);
  const PressureJammingResult r = jamToPressure(m, js, [](const JammingStep& st) {
    if (std::getenv("POLYDEM_TEST_VERBOSE")) {
      std::printf("step %d %s phi %.10f p %.4g fire %lld %s residual %.3g\n", st.step, st.action.c_str(),
                  st.packingFraction, st.reducedPressure, static_cast<long long>(st.fire.iterations),
                  st.fire.stopReason.c_str(), st.fire.last.residual);
    }
  });
  ASSERT_TRUE(r.reached) << r.stopReason;
  EXPECT_NEAR(r.reducedPressure, 1e-5, 0.05e-5);
  // Monodisperse random packings jam near 0.64 (O'Hern 2003: 0.639 for N -> inf); small N spreads by ~0.01.
  EXPECT_GT(r.packingFraction, 0.62);
  EXPECT_LT(r.packingFraction, 0.66);
  const jamming::ContactNetwork net = softContactNetwork(m, "linked-cell");
  ASSERT_GT(net.backbone, 400);
  // z of the non-rattlers -> 6 as p -> 0; at p/k = 1e-5, z - 6 ~ 4 sqrt(p/k) ... plus 2/N' finite size.
  EXPECT_GT(net.backboneCoordination(), 6.0);
  EXPECT_LT(net.backboneCoordination(), 6.15);
  EXPECT_GE(net.isostaticExcess(), 0);  // a jammed backbone has at least the isostatic count
}

}  // namespace
}  // namespace polydem::integrators
