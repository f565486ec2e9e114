#include "apps/polydem/relax_scene.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <toml++/toml.h>

#include <cmath>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>

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
  EXPECT_EQ(s.dem.broadPhase, "auto");  // issue 15: the cost model is the default (was linked-cell)
  EXPECT_EQ(s.initialVelocities, "impact");
  EXPECT_EQ(s.steps, 10);
  EXPECT_FALSE(s.compression.has_value());
}

TEST(RelaxScene, OverridesAreTypedTomlValuesOrPlainWords) {
  const RelaxScene s =
      parseRelaxScene(kMinimal, {"run.steps=2000", "contact.restitution=0.5", "run.broadphase=brute",
                                 "run.gravity=[0, 0, -9.81]", "compression.packing_fraction=0.6", "run.dt_factor=100"});
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
  EXPECT_THAT(configError(std::string(kMinimal) + "[outptu]\nfinal = \"x\"\n"),
              HasSubstr("unknown section or key 'outptu'"));
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

/// "section.key" -> the default a scene text states for it: `key = value` or `# key = value` lines,
/// a "# default = X" comment overriding the value, "# required..." marking keys without a default.
struct Documented {
  std::string value;
  bool required = false;
};
std::map<std::string, Documented> documentedDefaults(const std::string& text) {
  std::map<std::string, Documented> out;
  std::stringstream in(text);
  std::string section;
  const std::regex keyLine(R"(^([a-z_]+)\s*=\s*(.*)$)");
  auto trim = [](std::string t) {
    const auto a = t.find_first_not_of(" \t");
    const auto b = t.find_last_not_of(" \t");
    return a == std::string::npos ? std::string() : t.substr(a, b - a + 1);
  };
  for (std::string line; std::getline(in, line);) {
    std::string body = trim(line);
    if (body.starts_with("#")) body = trim(body.substr(1));
    if (body.starts_with("[")) {
      section = body.substr(1, body.find(']') - 1);
      continue;
    }
    std::smatch m;
    if (section.empty() || !std::regex_match(body, m, keyLine)) continue;
    const std::string rest = m[2];
    std::size_t hash = std::string::npos;
    bool quoted = false;
    for (std::size_t k = 0; k < rest.size(); ++k) {
      if (rest[k] == '"') quoted = !quoted;
      if (rest[k] == '#' && !quoted) {
        hash = k;
        break;
      }
    }
    Documented d;
    d.value = trim(rest.substr(0, hash));
    const std::string comment = hash == std::string::npos ? "" : trim(rest.substr(hash + 1));
    if (comment.starts_with("default = ")) d.value = trim(comment.substr(10, comment.find(';') - 10));
    d.required = comment.starts_with("required");
    const std::string key = section + "." + std::string(m[1]);
    EXPECT_FALSE(out.count(key)) << key << " is listed twice";
    out[key] = d;
  }
  return out;
}

/// Two TOML values equal as values (1000 == 1000.0 == 1e3).
bool sameValue(const std::string& a, const std::string& b) {
  const toml::table ta = toml::parse("v = " + a), tb = toml::parse("v = " + b);
  const toml::node& x = *ta.get("v");
  const toml::node& y = *tb.get("v");
  auto number = [](const toml::node& n) -> std::optional<double> {
    if (auto f = n.as_floating_point()) return f->get();
    if (auto i = n.as_integer()) return static_cast<double>(i->get());
    return std::nullopt;
  };
  if (x.is_array() && y.is_array()) {
    const toml::array& p = *x.as_array();
    const toml::array& q = *y.as_array();
    if (p.size() != q.size()) return false;
    for (std::size_t k = 0; k < p.size(); ++k) {
      if (number(*p.get(k)) != number(*q.get(k)) || !number(*p.get(k))) return false;
    }
    return true;
  }
  if (number(x) && number(y)) return *number(x) == *number(y);
  if (x.is_string() && y.is_string()) return x.as_string()->get() == y.as_string()->get();
  if (x.is_boolean() && y.is_boolean()) return x.as_boolean()->get() == y.as_boolean()->get();
  return false;
}

TEST(RelaxScene, PrintedDefaultsAreAValidSceneWithTheReadersDefaults) {
  const RelaxScene printed = parseRelaxScene(defaultSceneToml());
  const RelaxScene minimal =
      parseRelaxScene("[particles]\ncount = 1000\n[contact]\nstiffness = 1000.0\n[run]\nsteps = 1000\n");
  EXPECT_EQ(printed.dem.broadPhase, "auto");
  EXPECT_EQ(printed.dem.broadPhase, minimal.dem.broadPhase);
  EXPECT_EQ(printed.dem.skin, minimal.dem.skin);
  EXPECT_EQ(printed.dem.stepsPerContact, minimal.dem.stepsPerContact);
  EXPECT_EQ(printed.dem.contact.tangentialStiffnessRatio, minimal.dem.contact.tangentialStiffnessRatio);
  EXPECT_EQ(printed.dem.contact.restitution, minimal.dem.contact.restitution);
  EXPECT_EQ(printed.dem.stability.checkInterval, minimal.dem.stability.checkInterval);
  EXPECT_EQ(printed.dem.allowUnstableDt, minimal.dem.allowUnstableDt);
  EXPECT_EQ(printed.snapshotInterval, minimal.snapshotInterval);
  EXPECT_EQ(printed.checkpointSeconds, minimal.checkpointSeconds);
  EXPECT_EQ(printed.initialVelocities, minimal.initialVelocities);
  EXPECT_EQ(printed.distribution.kind, minimal.distribution.kind);
  EXPECT_EQ(printed.progressInterval, minimal.progressInterval);
  EXPECT_EQ(printed.timeseriesInterval, minimal.timeseriesInterval);
  EXPECT_FALSE(printed.compression.has_value());
}

TEST(RelaxScene, ExampleSceneStatesTheCodesDefaults) {
  std::ifstream in(POLYDEM_SOURCE_DIR "/examples/relax_uv10.toml");
  std::stringstream example;
  example << in.rdbuf();
  const auto code = documentedDefaults(defaultSceneToml());
  const auto documented = documentedDefaults(example.str());
  EXPECT_GE(code.size(), 50u);
  for (const auto& [key, d] : code) {
    SCOPED_TRACE(key);
    const auto it = documented.find(key);
    if (it == documented.end()) {
      ADD_FAILURE() << key << " is missing from examples/relax_uv10.toml";
      continue;
    }
    EXPECT_EQ(it->second.required, d.required);
    if (!d.required) {
      EXPECT_TRUE(sameValue(it->second.value, d.value)) << it->second.value << " vs code " << d.value;
    }
  }
  for (const auto& [key, d] : documented) EXPECT_TRUE(code.count(key)) << key << " is not a scene key";
}

TEST(RelaxScene, NonFiniteAndNegativeNumbersAreNamed) {
  EXPECT_THAT(configError(kMinimal, {"run.dt=nan"}), HasSubstr("run.dt (from --set) must be a finite number"));
  EXPECT_THAT(configError(kMinimal, {"contact.restitution=inf"}), HasSubstr("contact.restitution"));
  EXPECT_THAT(configError(kMinimal, {"run.gravity=[0, 0, nan]"}), HasSubstr("run.gravity"));
  EXPECT_THAT(configError(kMinimal, {"particles.seed=-1"}), HasSubstr("particles.seed must be >= 0"));
  EXPECT_THAT(configError(kMinimal, {"run.steps=-5"}), HasSubstr("run.steps must be >= 0"));
  EXPECT_THAT(configError(kMinimal, {"output.checkpoint_interval=-1"}), HasSubstr("output.checkpoint_interval"));
  EXPECT_THAT(configError(kMinimal, {"output.checkpoint_seconds=-1"}), HasSubstr("output.checkpoint_seconds"));
  EXPECT_THAT(configError(kMinimal, {"run.progress_interval=-1"}), HasSubstr("run.progress_interval"));
  EXPECT_THAT(configError(kMinimal, {"output.checkpoint=\"state.txt\""}), HasSubstr("name it *.h5"));
  EXPECT_THAT(configError(kMinimal, {"run.skin=\"wide\""}), HasSubstr("run.skin"));
  EXPECT_EQ(parseRelaxScene(kMinimal, {"run.skin=\"auto\""}).dem.skin, -1.0);
  EXPECT_TRUE(parseRelaxScene(kMinimal, {"run.allow_unstable_dt=true"}).dem.allowUnstableDt);
  EXPECT_TRUE(parseRelaxScene(kMinimal, {"box.boundaries=\"walls\""}).boundariesGiven);
  EXPECT_FALSE(parseRelaxScene(kMinimal).boundariesGiven);
}

// output.contacts and the arrays rattler, size_class (issue 21).
TEST(RelaxScene, ContactFilesAreOffUnlessAskedForAndNeedASnapshot) {
  EXPECT_FALSE(parseRelaxScene(kMinimal).contacts);
  const RelaxScene on = parseRelaxScene(kMinimal, {"output.snapshot=\"s_{step}.h5\"", "output.contacts=true"});
  EXPECT_TRUE(on.contacts);
  EXPECT_TRUE(parseRelaxScene(kMinimal, {"output.snapshot=\"s_{step}.txt\"", "output.contacts=true"}).contacts);
  EXPECT_THAT(configError(kMinimal, {"output.contacts=true"}),
              HasSubstr("output.contacts = true writes one contact file beside every snapshot, but output.snapshot "
                        "is not set"));
  EXPECT_THAT(configError(kMinimal, {"output.snapshot=\"s_{step}.h5\"", "output.contacts=\"yes\""}),
              HasSubstr("output.contacts (from --set) must be true or false"));
  EXPECT_THAT(configError(kMinimal, {"output.snapshot=\"s_{step}.h5\"", "output.contacts=1"}),
              HasSubstr("output.contacts"));
}

TEST(RelaxScene, RattlerAndSizeClassAreKnownArrays) {
  const RelaxScene s =
      parseRelaxScene(kMinimal, {"output.snapshot=\"s_{step}.h5\"", "output.arrays=[\"rattler\", \"size_class\"]"});
  EXPECT_EQ(s.snapshotArrays, (std::vector<std::string>{"rattler", "size_class"}));
  EXPECT_THAT(configError(kMinimal, {"output.snapshot=\"s_{step}.h5\"", "output.arrays=[\"rattlers\"]"}),
              HasSubstr("unknown array \"rattlers\"; known: force, torque, angular_velocity, contact_count, "
                        "max_overlap, kinetic_energy, rattler, size_class"));
  EXPECT_EQ(parseRelaxScene(kMinimal, {"output.snapshot=\"s_{step}.txt\"", "output.arrays=[\"size_class\"]"})
                .snapshotArrays.size(),
            1u)
      << "text snapshots hold arrays as columns";
  EXPECT_THAT(configError(kMinimal, {"output.snapshot=\"s_{step}.data\"", "output.arrays=[\"size_class\"]"}),
              HasSubstr("is a LAMMPS data file, which has no columns for them"));
  EXPECT_THAT(configError(kMinimal, {"output.arrays=[\"size_class\"]"}), HasSubstr("output.arrays needs"));
}

}  // namespace
}  // namespace polydem::app
