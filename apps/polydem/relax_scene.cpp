#include "apps/polydem/relax_scene.hpp"

#include <fstream>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "core/errors.hpp"

namespace polydem::app {

namespace {

std::string typeName(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::table: return "a table";
    case toml::node_type::array: return "an array";
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a number";
    case toml::node_type::boolean: return "a boolean";
    default: return "a date or time";
  }
}

/// One [section] of the scene: typed getters that remember which keys were read, so finish() can
/// reject the rest as unknown.
class Section {
 public:
  Section(const toml::table* table, std::string name) : table_(table), name_(std::move(name)) {}

  bool present() const { return table_ != nullptr; }
  bool has(std::string_view key) const { return table_ && table_->get(key) != nullptr; }

  double number(std::string_view key, double fallback) {
    const toml::node* n = get(key);
    if (!n) return fallback;
    if (auto v = n->as_floating_point()) return v->get();
    if (auto v = n->as_integer()) return static_cast<double>(v->get());
    throw wrongType(key, *n, "a number");
  }
  double requiredNumber(std::string_view key) {
    require(key);
    return number(key, 0.0);
  }
  std::int64_t integer(std::string_view key, std::int64_t fallback) {
    const toml::node* n = get(key);
    if (!n) return fallback;
    if (auto v = n->as_integer()) return v->get();
    if (auto v = n->as_floating_point()) {  // 1e5 is a float in TOML; accept whole values
      const double d = v->get();
      if (d == std::floor(d) && std::abs(d) < 9e15) return static_cast<std::int64_t>(d);
    }
    throw wrongType(key, *n, "an integer");
  }
  std::string string(std::string_view key, const std::string& fallback) {
    const toml::node* n = get(key);
    if (!n) return fallback;
    if (auto v = n->as_string()) return v->get();
    throw wrongType(key, *n, "a string");
  }
  bool boolean(std::string_view key, bool fallback) {
    const toml::node* n = get(key);
    if (!n) return fallback;
    if (auto v = n->as_boolean()) return v->get();
    throw wrongType(key, *n, "true or false");
  }
  Eigen::Vector3d vector3(std::string_view key, const Eigen::Vector3d& fallback) {
    const toml::node* n = get(key);
    if (!n) return fallback;
    const toml::array* a = n->as_array();
    if (!a || a->size() != 3) throw wrongType(key, *n, "an array of 3 numbers");
    Eigen::Vector3d out;
    for (std::size_t k = 0; k < 3; ++k) {
      const toml::node& e = *a->get(k);
      if (auto f = e.as_floating_point()) {
        out[static_cast<int>(k)] = f->get();
      } else if (auto i = e.as_integer()) {
        out[static_cast<int>(k)] = static_cast<double>(i->get());
      } else {
        throw wrongType(key, *n, "an array of 3 numbers");
      }
    }
    return out;
  }
  /// A string, or an array of strings joined by commas (boundaries).
  std::string words(std::string_view key, const std::string& fallback) {
    const toml::node* n = get(key);
    if (!n) return fallback;
    if (auto s = n->as_string()) return s->get();
    if (const toml::array* a = n->as_array()) {
      std::string joined;
      for (const toml::node& e : *a) {
        if (!e.as_string()) throw wrongType(key, *n, "a string or an array of strings");
        joined += (joined.empty() ? "" : ",") + e.as_string()->get();
      }
      return joined;
    }
    throw wrongType(key, *n, "a string or an array of strings");
  }
  std::string choice(std::string_view key, const std::string& fallback, std::initializer_list<std::string_view> valid) {
    const std::string value = string(key, fallback);
    std::string list;
    for (std::string_view v : valid) {
      if (v == value) return value;
      list += (list.empty() ? "" : ", ") + std::string(v);
    }
    throw ConfigError(fmt::format("{} = \"{}\" is not valid; expected one of: {}", path(key), value, list));
  }

  void require(std::string_view key) const {
    if (!has(key)) throw ConfigError(fmt::format("missing required key {}", path(key)));
  }
  std::string path(std::string_view key) const { return fmt::format("{}.{}", name_, key); }

  /// Unknown keys are errors (typos must not silently fall back to defaults).
  void finish() const {
    if (!table_) return;
    for (auto&& [key, node] : *table_) {
      if (!used_.count(std::string(key.str()))) {
        std::string valid;
        for (const std::string& k : used_) valid += (valid.empty() ? "" : ", ") + k;
        throw ConfigError(fmt::format("unknown key {} ({}); keys read in [{}]: {}", path(key.str()),
                                      where(node), name_, valid));
      }
    }
  }

 private:
  const toml::node* get(std::string_view key) {
    used_.insert(std::string(key));
    return table_ ? table_->get(key) : nullptr;
  }
  ConfigError wrongType(std::string_view key, const toml::node& n, std::string_view expected) const {
    return ConfigError(fmt::format("{} ({}) must be {}, got {}", path(key), where(n), expected, typeName(n)));
  }
  static std::string where(const toml::node& n) {
    return n.source().begin.line > 0 ? fmt::format("line {}", n.source().begin.line) : "from --set";
  }

  const toml::table* table_;
  std::string name_;
  std::set<std::string> used_;
};

/// "periodic", "walls", or three comma-separated entries of periodic|wall (as `polydem generate`).
std::array<Boundary, 3> boundariesFrom(const std::string& text) {
  auto one = [&](const std::string& word) {
    if (word == "periodic") return Boundary::Periodic;
    if (word == "wall" || word == "walls") return Boundary::Wall;
    throw ConfigError(fmt::format("box.boundaries: '{}' in '{}' is not periodic or wall", word, text));
  };
  std::vector<std::string> words;
  std::stringstream in(text);
  for (std::string word; std::getline(in, word, ',');) words.push_back(word);
  if (words.size() == 1) return {one(words[0]), one(words[0]), one(words[0])};
  if (words.size() != 3) throw ConfigError(fmt::format("box.boundaries = '{}': give one value or three", text));
  return {one(words[0]), one(words[1]), one(words[2])};
}

toml::table parseToml(const std::string& text, const std::string& source) {
  try {
    return toml::parse(text, source);
  } catch (const toml::parse_error& e) {
    throw InputError(fmt::format("{}:{}:{}: {}", source, e.source().begin.line, e.source().begin.column,
                                 e.description()));
  }
}

/// "section.key=value": value parsed as a TOML value, or taken as a plain string if it is not one.
void applyOverride(toml::table& root, const std::string& assignment) {
  const std::size_t eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) {
    throw ConfigError(fmt::format("--set '{}': expected section.key=value", assignment));
  }
  const std::string path = assignment.substr(0, eq);
  const std::string value = assignment.substr(eq + 1);
  const std::size_t dot = path.find('.');
  if (dot == std::string::npos || dot == 0 || dot + 1 == path.size() || path.find('.', dot + 1) != std::string::npos) {
    throw ConfigError(fmt::format("--set '{}': the key must be section.key, e.g. run.steps", assignment));
  }
  const std::string section = path.substr(0, dot), key = path.substr(dot + 1);
  toml::table parsed;
  try {
    parsed = toml::parse("v = " + value);
  } catch (const toml::parse_error&) {
    parsed = toml::table{{"v", value}};
  }
  if (!root.get(section)) root.insert(section, toml::table{});
  toml::table* target = root.get(section)->as_table();
  if (!target) throw ConfigError(fmt::format("--set '{}': {} is not a section", assignment, section));
  parsed.get("v")->visit([&](auto&& node) { target->insert_or_assign(key, node); });
}

RelaxScene interpret(const toml::table& root, const std::filesystem::path& source) {
  static const std::set<std::string> kSections = {"particles", "box", "contact", "velocities",
                                                  "compression", "run", "output"};
  for (auto&& [key, node] : root) {
    const std::string name(key.str());
    if (!kSections.count(name)) {
      throw ConfigError(fmt::format("unknown section or key '{}' (line {}); sections: particles, box, contact, "
                                    "velocities, compression, run, output",
                                    name, node.source().begin.line));
    }
    if (!node.is_table()) throw ConfigError(fmt::format("'{}' must be a [section]", name));
  }
  auto section = [&](const char* name) { return Section(root.get_as<toml::table>(name), name); };
  RelaxScene s;
  s.source = source;

  Section particles = section("particles");
  if (!particles.present()) throw ConfigError("missing section [particles]: give particles.file or particles.count");
  s.particleFile = particles.string("file", "");
  const bool generate = particles.has("count");
  if (s.particleFile.empty() == !generate) {
    throw ConfigError(s.particleFile.empty()
                          ? "missing required key particles.file or particles.count (a file to read, or a size "
                            "distribution to generate)"
                          : "particles.file and particles.count exclude each other: read a file or generate");
  }
  if (generate) {
    const std::int64_t count = particles.integer("count", 0);
    if (count < 1 || count > 2'000'000'000) {
      throw ConfigError(fmt::format("particles.count must be in [1, 2e9], got {}", count));
    }
    s.count = static_cast<Index>(count);
    DistributionSpec& d = s.distribution;
    d.kind = particles.string("distribution", "mono");
    d.rmin = particles.number("rmin", d.rmin);
    d.omega = particles.number("omega", d.omega);
    d.alpha = particles.number("alpha", d.alpha);
    d.sigma = particles.number("sigma", d.sigma);
    d.median = particles.number("median", d.median);
    d.largeFraction = particles.number("large_fraction", d.largeFraction);
    d.fractionKind =
        particles.choice("fraction_kind", "volume", {"volume", "number"}) == "number" ? FractionKind::Number
                                                                                      : FractionKind::Volume;
    s.sampling = particles.choice("sampling", "systematic", {"systematic", "random"});
    s.packingFraction = particles.number("packing_fraction", s.packingFraction);
    if (!(s.packingFraction > 0.0 && s.packingFraction < 1.0)) {
      throw ConfigError(fmt::format("particles.packing_fraction must be in (0, 1), got {}", s.packingFraction));
    }
    s.seed = static_cast<std::uint64_t>(particles.integer("seed", 1));
    try {
      makeDistribution(d);
    } catch (const ConfigError& e) {
      throw ConfigError(fmt::format("[particles]: {}", e.what()));
    }
  }
  s.density = particles.number("density", s.density);
  if (!(s.density > 0.0 && std::isfinite(s.density))) {
    throw ConfigError(fmt::format("particles.density must be > 0, got {}", s.density));
  }
  particles.finish();

  Section box = section("box");
  const std::string boundaries = box.words("boundaries", "periodic");
  s.boundaries = boundariesFrom(boundaries);
  s.aspect = box.vector3("aspect", s.aspect);
  if (!(s.aspect.minCoeff() > 0.0)) throw ConfigError("box.aspect entries must be > 0");
  if (!generate && box.has("aspect")) {
    throw ConfigError("box.aspect only applies when generating particles (the file gives the box)");
  }
  box.finish();

  Section contact = section("contact");
  if (!contact.present()) throw ConfigError("missing section [contact] (at least contact.stiffness)");
  contact::ContactParameters& c = s.dem.contact;
  c.normal = contact.choice("law", "linear", {"linear", "hertz"}) == "hertz" ? contact::NormalModel::Hertz
                                                                            : contact::NormalModel::Linear;
  c.stiffness = contact.requiredNumber("stiffness");
  c.scaling = contact.choice("stiffness_scaling", "constant", {"constant", "radius"}) == "radius"
                  ? contact::StiffnessScaling::Radius
                  : contact::StiffnessScaling::Constant;
  c.restitution = contact.number("restitution", c.restitution);
  c.friction = contact.number("friction", c.friction);
  c.tangentialStiffnessRatio = contact.number("tangential_stiffness_ratio", c.tangentialStiffnessRatio);
  c.tangentialDampingRatio = contact.number("tangential_damping_ratio", c.tangentialDampingRatio);
  c.referenceVelocity = contact.number("reference_velocity", c.referenceVelocity);
  contact.finish();
  c.validate();

  Section velocities = section("velocities");
  s.initialVelocities = velocities.choice("initial", generate ? "impact" : "file", {"impact", "file", "zero"});
  if (generate && s.initialVelocities == "file") {
    throw ConfigError("velocities.initial = \"file\" needs particles.file");
  }
  s.impactOverlap = velocities.number("overlap", s.impactOverlap);
  if (!(s.impactOverlap > 0.0 && s.impactOverlap < 1.0)) {
    throw ConfigError(fmt::format("velocities.overlap must be in (0, 1), got {}", s.impactOverlap));
  }
  s.velocitySeed = static_cast<std::uint64_t>(velocities.integer("seed", 1));
  velocities.finish();

  Section compression = section("compression");
  if (compression.present()) {
    integrators::CompressionSettings cs;
    cs.targetPacking = compression.requiredNumber("packing_fraction");
    cs.growthRate = compression.number("growth_rate", cs.growthRate);
    cs.damping = compression.number("damping", cs.damping);
    cs.relaxedOverlap = compression.number("max_overlap", cs.relaxedOverlap);
    cs.maxSteps = compression.integer("max_steps", cs.maxSteps);
    compression.finish();
    cs.validate();
    s.compression = cs;
  }

  Section run = section("run");
  if (!run.present()) throw ConfigError("missing section [run] (at least run.steps)");
  s.steps = run.integer("steps", 0);
  run.require("steps");
  if (s.steps < 0) throw ConfigError(fmt::format("run.steps must be >= 0, got {}", s.steps));
  integrators::DemSettings& dem = s.dem;
  dem.stepsPerContact = run.number("dt_factor", dem.stepsPerContact);
  if (!(dem.stepsPerContact >= integrators::kMinStepsPerContact)) {
    throw ConfigError(fmt::format("run.dt_factor (steps per contact) must be >= {:g}, got {}",
                                  integrators::kMinStepsPerContact, dem.stepsPerContact));
  }
  dem.timeStep = run.number("dt", 0.0);
  if (!(dem.timeStep >= 0.0)) throw ConfigError(fmt::format("run.dt must be >= 0 (0 = automatic), got {}", dem.timeStep));
  dem.skin = run.number("skin", -1.0);
  if (run.has("skin") && !(dem.skin >= 0.0)) throw ConfigError(fmt::format("run.skin must be >= 0, got {}", dem.skin));
  dem.broadPhase = run.string("broadphase", dem.broadPhase);
  dem.gravity = run.vector3("gravity", dem.gravity);
  dem.viscousDamping = run.number("viscous_damping", dem.viscousDamping);
  dem.stability.checkInterval = run.integer("check_interval", dem.stability.checkInterval);
  dem.stability.maxOverlapFraction = run.number("max_overlap_fraction", dem.stability.maxOverlapFraction);
  dem.stability.energyTolerance = run.number("energy_tolerance", dem.stability.energyTolerance);
  const std::string kernel = run.choice("kernel", "specialised", {"specialised", "specialized", "general"});
  dem.generalKernel = kernel == "general";
  dem.spatialSort = run.boolean("spatial_sort", dem.spatialSort);
  const std::int64_t threads = run.integer("threads", dem.threads);
  if (threads < 1 || threads > 1024) throw ConfigError(fmt::format("run.threads must be in [1, 1024], got {}", threads));
  dem.threads = static_cast<int>(threads);
  s.progressInterval = run.number("progress_interval", s.progressInterval);
  run.finish();
  dem.stability.validate();
  if (!(dem.viscousDamping >= 0.0)) {
    throw ConfigError(fmt::format("run.viscous_damping must be >= 0, got {}", dem.viscousDamping));
  }

  Section output = section("output");
  s.snapshot = output.string("snapshot", "");
  s.snapshotInterval = output.integer("snapshot_interval", s.snapshot.empty() ? 0 : 1000);
  s.timeseries = output.string("timeseries", "");
  s.timeseriesInterval = output.integer("timeseries_interval", s.timeseriesInterval);
  s.finalState = output.string("final", "");
  output.finish();
  if (s.snapshotInterval < 0) throw ConfigError("output.snapshot_interval must be >= 0");
  if (s.timeseriesInterval < 1) throw ConfigError("output.timeseries_interval must be >= 1");
  if (!s.snapshot.empty() && s.snapshotInterval > 0 && s.snapshot.find("{step}") == std::string::npos) {
    throw ConfigError(fmt::format("output.snapshot = \"{}\" needs a {{step}} placeholder when "
                                  "output.snapshot_interval > 0",
                                  s.snapshot));
  }
  return s;
}

}  // namespace

std::filesystem::path RelaxScene::resolve(const std::string& path) const {
  const std::filesystem::path p(path);
  if (p.is_absolute()) return p;
  return source.parent_path() / p;
}

RelaxScene parseRelaxScene(const std::string& text, const std::vector<std::string>& overrides,
                           const std::filesystem::path& source) {
  toml::table root = parseToml(text, source.string());
  for (const std::string& o : overrides) applyOverride(root, o);
  return interpret(root, source);
}

RelaxScene loadRelaxScene(const std::filesystem::path& file, const std::vector<std::string>& overrides) {
  std::ifstream in(file);
  if (!in) throw InputError(fmt::format("{}: cannot open scene file", file.string()));
  std::stringstream text;
  text << in.rdbuf();
  return parseRelaxScene(text.str(), overrides, file);
}

}  // namespace polydem::app
