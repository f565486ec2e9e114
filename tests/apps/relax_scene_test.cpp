#include "apps/polydem/relax_scene.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/errors.hpp"

namespace polydem::app {
namespace {

using ::testing::HasSubstr;

const char* kMinimal = R"(
[particles]
count = 100
distribution = "uniform-volume"
omega = 4
[contact]
stiffness = 1e4
[run]
steps = 10
)";

std::string configError(const std::string& text, const std::vector<std::string>& overrides = {}) {
  try {
    parseRelaxScene(text, overrides);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

TEST(RelaxScene, MinimalSceneGetsTheDefaults) {
  const RelaxScene s = parseRelaxScene(kMinimal);
  EXPECT_EQ(s.count, 100);
  EXPECT_EQ(s.distribution.kind, "uniform-volume");
  EXPECT_EQ(s.distribution.omega, 4.0);
  EXPECT_EQ(s.dem.contact.stiffness, 1e4);
  EXPECT_EQ(s.dem.contact.restitution, 1.0);
  EXPECT_EQ(s.dem.stepsPerContact, 50.0);
  EXPECT_EQ(s.dem.broadPhase, "linked-cell");
  EXPECT_EQ(s.initialVelocities, "impact");
  EXPECT_EQ(s.steps, 10);
  EXPECT_FALSE(s.compression.has_value());
}

TEST(RelaxScene, OverridesAreTypedTomlValuesOrPlainWords) {
  const RelaxScene s = parseRelaxScene(
      kMinimal, {"run.steps=2000", "contact.restitution=0.5", "run.broadphase=brute", "run.gravity=[0, 0, -9.81]",
                 "compression.packing_fraction=0.6", "run.dt_factor=100"});
  EXPECT_EQ(s.steps, 2000);
  EXPECT_EQ(s.dem.contact.restitution, 0.5);
  EXPECT_EQ(s.dem.broadPhase, "brute");
  EXPECT_EQ(s.dem.gravity[2], -9.81);
  ASSERT_TRUE(s.compression.has_value());
  EXPECT_EQ(s.compression->targetPacking, 0.6);
  EXPECT_EQ(s.dem.stepsPerContact, 100.0);
  EXPECT_EQ(parseRelaxScene(kMinimal).dem.threads, 1);
  EXPECT_EQ(parseRelaxScene(kMinimal, {"run.threads=2"}).dem.threads, 2);
}

TEST(RelaxScene, UnknownAndMissingKeysAreNamed) {
  EXPECT_THAT(configError(kMinimal, {"run.stpes=5"}), HasSubstr("unknown key run.stpes"));
  EXPECT_THAT(configError(std::string(kMinimal) + "[outptu]\nfinal = \"x\"\n"), HasSubstr("unknown section or key 'outptu'"));
  EXPECT_THAT(configError("[particles]\ncount = 10\n[run]\nsteps = 1\n"), HasSubstr("missing section [contact]"));
  EXPECT_THAT(configError("[particles]\ncount = 10\n[contact]\nrestitution = 0.5\n[run]\nsteps = 1\n"),
              HasSubstr("missing required key contact.stiffness"));
  EXPECT_THAT(configError("[particles]\ncount = 10\n[contact]\nstiffness = 1.0\n[run]\n"),
              HasSubstr("missing required key run.steps"));
  EXPECT_THAT(configError("[particles]\ndensity = 2.0\n[contact]\nstiffness = 1.0\n[run]\nsteps = 1\n"),
              HasSubstr("particles.file or particles.count"));
}

TEST(RelaxScene, OutOfRangeValuesAreNamed) {
  EXPECT_THAT(configError(kMinimal, {"contact.restitution=1.5"}), HasSubstr("contact.restitution must be in [0, 1]"));
  EXPECT_THAT(configError(kMinimal, {"contact.restitution=-0.1"}), HasSubstr("contact.restitution"));
  EXPECT_THAT(configError(kMinimal, {"contact.friction=-1"}), HasSubstr("contact.friction must be >= 0"));
  EXPECT_THAT(configError(kMinimal, {"contact.stiffness=0"}), HasSubstr("contact.stiffness must be > 0"));
  EXPECT_THAT(configError(kMinimal, {"run.dt_factor=4"}), HasSubstr("run.dt_factor"));
  EXPECT_THAT(configError(kMinimal, {"run.threads=0"}), HasSubstr("run.threads must be in [1, 1024]"));
  EXPECT_THAT(configError(kMinimal, {"contact.law=\"hooke\""}), HasSubstr("contact.law = \"hooke\" is not valid"));
  EXPECT_THAT(configError(kMinimal, {"run.steps=\"many\""}), HasSubstr("run.steps (from --set) must be an integer"));
  EXPECT_THAT(configError(kMinimal, {"box.boundaries=\"sticky\""}), HasSubstr("box.boundaries"));
  EXPECT_THAT(configError(kMinimal, {"particles.omega=0.5"}), HasSubstr("[particles]"));
  EXPECT_THAT(configError(kMinimal, {"compression.growth_rate=0.5"}), HasSubstr("compression.packing_fraction"));
  EXPECT_THAT(configError(kMinimal, {"output.snapshot=\"snap.h5\"", "output.snapshot_interval=10"}),
              HasSubstr("{step}"));
}

TEST(RelaxScene, TomlSyntaxErrorsCarryTheLine) {
  try {
    parseRelaxScene("[run]\nsteps = = 3\n");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("scene.toml:2:"));
  }
}

TEST(RelaxScene, ExampleSceneParses) {
  const RelaxScene s = loadRelaxScene(POLYDEM_SOURCE_DIR "/examples/relax_uv10.toml");
  EXPECT_EQ(s.count, 50000);
  EXPECT_EQ(s.distribution.omega, 10.0);
  EXPECT_EQ(s.dem.contact.restitution, 0.9);
  EXPECT_EQ(s.dem.threads, 1);
}

}  // namespace
}  // namespace polydem::app
