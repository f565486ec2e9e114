#include "apps/polydem/relax_scene.hpp"

#include <fmt/format.h>
#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "core/errors.hpp"

namespace polydem::app {

namespace {

std::string typeName(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::table:
      return "a table";
    case toml::node_type::array:
      return "an array";
    case toml::node_type::string:
      return "a string";
    case toml::node_type::integer:
      return "an integer";
    case toml::node_type::floating_point:
      return "a number";
    case toml::node_type::boolean:
      return "a boolean";
    default:
      return "a date or time";
  }
}

/// One [section] of the scene: typed getters that remember which keys were read, so finish() can
/// reject the rest as unknown.
class Section {
 public:
  Section(const toml::table* table, std::string name) : table_(table), name_(std::move(name)) {}

  bool present() const { return table_ != nullptr; }
  bool has(std::string_view key) const { return table_ && table_->get(key) != nullptr; }
  bool isString(std::string_view key) const { return has(key) && table_->get(key)->is_string(); }

  double number(std::string_view key, double fallback) {
    const toml::node* n = get(key);
    if (!n) return fallback;
    if (auto v = n->as_floating_point()) {
      // TOML has nan and inf literals; no key of a scene means anything by them.
      if (!std::isfinite(v->get())) {
        throw ConfigError(fmt::format("{} ({}) must be a finite number, got {}", path(key), where(*n),
                                      std::isnan(v->get()) ? "not-a-number" : "infinity"));
      }
      return v->get();
    }
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
        if (!std::isfinite(f->get())) throw wrongType(key, *n, "an array of 3 finite numbers");
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
  /// A count or seed: an integer >= `lo`.
  std::int64_t integerAtLeast(std::string_view key, std::int64_t fallback, std::int64_t lo) {
    const std::int64_t v = integer(key, fallback);
    if (v < lo) throw ConfigError(fmt::format("{} must be >= {}, got {}", path(key), lo, v));
    return v;
  }

  /// Unknown keys are errors (typos must not silently fall back to defaults).
  void finish() const {
    if (!table_) return;
    for (auto&& [key, node] : *table_) {
      if (!used_.count(std::string(key.str()))) {
        std::string valid;
        for (const std::string& k : used_) valid += (valid.empty() ? "" : ", ") + k;
        throw ConfigError(
            fmt::format("unknown key {} ({}); keys read in [{}]: {}", path(key.str()), where(node), name_, valid));
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
    throw InputError(
        fmt::format("{}:{}:{}: {}", source, e.source().begin.line, e.source().begin.column, e.description()));
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

/// [particles]: a file to read, or a size distribution to generate; the density. Returns whether the particles are
/// generated.
bool readParticles(Section particles, RelaxScene& s) {
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
    d.kind = particles.string("distribution", d.kind);
    d.rmin = particles.number("rmin", d.rmin);
    d.omega = particles.number("omega", d.omega);
    d.alpha = particles.number("alpha", d.alpha);
    d.sigma = particles.number("sigma", d.sigma);
    d.median = particles.number("median", d.median);
    d.largeFraction = particles.number("large_fraction", d.largeFraction);
    d.fractionKind = particles.choice("fraction_kind", "volume", {"volume", "number"}) == "number"
                         ? FractionKind::Number
                         : FractionKind::Volume;
    s.sampling = particles.choice("sampling", "systematic", {"systematic", "random"});
    s.packingFraction = particles.number("packing_fraction", s.packingFraction);
    if (!(s.packingFraction > 0.0 && s.packingFraction < 1.0)) {
      throw ConfigError(fmt::format("particles.packing_fraction must be in (0, 1), got {}", s.packingFraction));
    }
    s.seed = static_cast<std::uint64_t>(particles.integerAtLeast("seed", 1, 0));
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
  return generate;
}

/// [box]: boundaries and (generated particles only) the aspect ratio.
void readBox(Section box, RelaxScene& s, bool generate) {
  s.boundariesGiven = box.has("boundaries");
  const std::string boundaries = box.words("boundaries", "periodic");
  s.boundaries = boundariesFrom(boundaries);
  s.aspect = box.vector3("aspect", s.aspect);
  if (!(s.aspect.minCoeff() > 0.0)) throw ConfigError("box.aspect entries must be > 0");
  if (!generate && box.has("aspect")) {
    throw ConfigError("box.aspect only applies when generating particles (the file gives the box)");
  }
  box.finish();
}

/// [contact]: the contact law.
void readContact(Section contact, RelaxScene& s) {
  if (!contact.present()) throw ConfigError("missing section [contact] (at least contact.stiffness)");
  contact::ContactParameters& c = s.dem.contact;
  c.normal = contact.choice("law", "linear", {"linear", "hertz"}) == "hertz" ? contact::NormalModel::Hertz
                                                                             : contact::NormalModel::Linear;
  c.stiffness = contact.requiredNumber("stiffness");
  c.scaling = contact.choice("stiffness_scaling", "constant", {"constant", "radius"}) == "radius"
                  ? contact::StiffnessScaling::Radius
                  : contact::StiffnessScaling::Constant;
  c.damping = contact.choice("damping", "restitution", {"restitution", "mass-velocity"}) == "mass-velocity"
                  ? contact::DampingModel::MassVelocity
                  : contact::DampingModel::Restitution;
  if (c.damping == contact::DampingModel::MassVelocity) {
    if (!contact.has("gamma_n")) {
      throw ConfigError(
          "missing required key contact.gamma_n (1/s): contact.damping = \"mass-velocity\" sets the normal "
          "dashpot F = -gamma_n m_eff v_n (LAMMPS gran/hooke); e.g. contact.gamma_n = 5000.0");
    }
    if (contact.has("restitution")) {
      throw ConfigError(
          "contact.restitution and contact.damping = \"mass-velocity\" exclude each other: the dashpot is set by "
          "contact.gamma_n (remove contact.restitution)");
    }
  } else if (contact.has("gamma_n")) {
    throw ConfigError(
        "contact.gamma_n applies to contact.damping = \"mass-velocity\" only; with the default damping = "
        "\"restitution\" the dashpot is set by contact.restitution");
  }
  c.dampingRate = contact.number("gamma_n", c.dampingRate);
  c.restitution = contact.number("restitution", c.restitution);
  c.friction = contact.number("friction", c.friction);
  // Tangential law: Cundall-Strack (default), LAMMPS gran/hooke/history's variant, or Hertz-Mindlin with the
  // pair's G* (or one Poisson ratio).
  const std::string tangential =
      contact.choice("tangential", "cundall-strack", {"cundall-strack", "lammps-history", "hertz-mindlin"});
  c.tangential = tangential == "lammps-history"  ? contact::TangentialModel::LammpsHistory
                 : tangential == "hertz-mindlin" ? contact::TangentialModel::HertzMindlin
                                                 : contact::TangentialModel::CundallStrack;
  c.tangentialStiffnessRatio = contact.number("tangential_stiffness_ratio", c.tangentialStiffnessRatio);
  c.tangentialDampingRatio = contact.number("tangential_damping_ratio", c.tangentialDampingRatio);
  c.referenceVelocity = contact.number("reference_velocity", c.referenceVelocity);
  if (c.tangential == contact::TangentialModel::HertzMindlin) {
    if (contact.has("tangential_stiffness_ratio")) {
      throw ConfigError(
          "contact.tangential_stiffness_ratio applies to contact.tangential = \"cundall-strack\" only (Hertz-Mindlin "
          "takes k_t = 8 G* sqrt(R* d) from contact.shear_modulus or contact.poisson_ratio)");
    }
  }
  c.shearModulus = contact.number("shear_modulus", c.shearModulus);
  if (contact.has("shear_modulus") && !(c.shearModulus > 0.0)) {
    throw ConfigError(fmt::format("contact.shear_modulus must be > 0, got {}", c.shearModulus));
  }
  if (contact.has("poisson_ratio")) c.poissonRatio = contact.number("poisson_ratio", 0.0);
  contact.finish();
  c.validate();
}

/// [velocities]: the initial velocities.
void readVelocities(Section velocities, RelaxScene& s, bool generate) {
  s.initialVelocities = velocities.choice("initial", generate ? "impact" : "file", {"impact", "file", "zero"});
  if (generate && s.initialVelocities == "file") {
    throw ConfigError("velocities.initial = \"file\" needs particles.file");
  }
  s.impactOverlap = velocities.number("overlap", s.impactOverlap);
  if (!(s.impactOverlap > 0.0 && s.impactOverlap < 1.0)) {
    throw ConfigError(fmt::format("velocities.overlap must be in (0, 1), got {}", s.impactOverlap));
  }
  s.velocitySeed = static_cast<std::uint64_t>(velocities.integerAtLeast("seed", 1, 0));
  velocities.finish();
}

/// [compression] (optional): the soft compression.
void readCompression(Section compression, RelaxScene& s) {
  if (compression.present()) {
    integrators::CompressionSettings cs;
    cs.targetPacking = compression.requiredNumber("packing_fraction");
    cs.growthRate = compression.number("growth_rate", cs.growthRate);
    cs.damping = compression.number("damping", cs.damping);
    cs.relaxedOverlap = compression.number("max_overlap", cs.relaxedOverlap);
    cs.maxSteps = compression.integerAtLeast("max_steps", cs.maxSteps, 1);
    compression.finish();
    cs.validate();
    s.compression = cs;
  }
}

/// [run]: steps, time step, broad phase, body forces, checks, kernel and threads.
void readRun(Section run, RelaxScene& s) {
  if (!run.present()) throw ConfigError("missing section [run] (at least run.steps)");
  run.require("steps");
  s.steps = run.integerAtLeast("steps", 0, 0);
  integrators::DemSettings& dem = s.dem;
  dem.stepsPerContact = run.number("dt_factor", dem.stepsPerContact);
  if (!(dem.stepsPerContact >= integrators::kMinStepsPerContact)) {
    throw ConfigError(fmt::format("run.dt_factor (steps per contact) must be >= {:g}, got {}",
                                  integrators::kMinStepsPerContact, dem.stepsPerContact));
  }
  dem.timeStep = run.number("dt", dem.timeStep);
  if (!(dem.timeStep >= 0.0))
    throw ConfigError(fmt::format("run.dt must be >= 0 (0 = automatic), got {}", dem.timeStep));
  dem.allowUnstableDt = run.boolean("allow_unstable_dt", dem.allowUnstableDt);
  if (run.isString("skin")) {
    if (run.string("skin", "") != "auto") {
      throw ConfigError(fmt::format("run.skin = \"{}\": give a number (m) or \"auto\"", run.string("skin", "")));
    }
    dem.skin = -1.0;
  } else {
    dem.skin = run.number("skin", -1.0);
    if (run.has("skin") && !(dem.skin >= 0.0)) {
      throw ConfigError(fmt::format("run.skin must be >= 0 (or \"auto\" = 0.2 r_min), got {}", dem.skin));
    }
  }
  dem.broadPhase = run.string("broadphase", kDefaultBroadPhase);
  dem.gravity = run.vector3("gravity", dem.gravity);
  dem.viscousDamping = run.number("viscous_damping", dem.viscousDamping);
  dem.dashpotVelocity = run.choice("dashpot_velocity", "predicted", {"predicted", "half-step"}) == "half-step"
                            ? integrators::DashpotVelocity::HalfStep
                            : integrators::DashpotVelocity::Predicted;
  dem.stability.checkInterval = run.integer("check_interval", dem.stability.checkInterval);
  dem.stability.maxOverlapFraction = run.number("max_overlap_fraction", dem.stability.maxOverlapFraction);
  dem.stability.energyTolerance = run.number("energy_tolerance", dem.stability.energyTolerance);
  const std::string kernel = run.choice("kernel", "specialised", {"specialised", "specialized", "general"});
  dem.generalKernel = kernel == "general";
  dem.spatialSort = run.boolean("spatial_sort", dem.spatialSort);
  const std::int64_t threads = run.integer("threads", dem.threads);
  if (threads < 1 || threads > 1024)
    throw ConfigError(fmt::format("run.threads must be in [1, 1024], got {}", threads));
  dem.threads = static_cast<int>(threads);
  s.progressInterval = run.number("progress_interval", s.progressInterval);
  if (s.progressInterval < 0.0) {
    throw ConfigError(fmt::format("run.progress_interval must be >= 0 (0 = none), got {}", s.progressInterval));
  }
  run.finish();
  dem.stability.validate();
  if (!(dem.viscousDamping >= 0.0)) {
    throw ConfigError(fmt::format("run.viscous_damping must be >= 0, got {}", dem.viscousDamping));
  }
}

/// [output]: files and their intervals.
void readOutput(Section output, RelaxScene& s) {
  s.snapshot = output.string("snapshot", "");
  s.snapshotInterval = output.integerAtLeast("snapshot_interval", s.snapshotInterval, 0);
  s.timeseries = output.string("timeseries", "");
  s.timeseriesInterval = output.integerAtLeast("timeseries_interval", s.timeseriesInterval, 1);
  s.finalState = output.string("final", "");
  {
    // Optional per-particle arrays of the snapshots; computed only when listed.
    static const std::set<std::string> kArrays = {"force",       "torque",         "angular_velocity", "contact_count",
                                                  "max_overlap", "kinetic_energy", "rattler",          "size_class"};
    const std::string list = output.words("arrays", "");
    std::size_t begin = 0;
    while (!list.empty() && begin <= list.size()) {
      const std::size_t end = std::min(list.find(',', begin), list.size());
      const std::string name = list.substr(begin, end - begin);
      if (kArrays.count(name) == 0) {
        throw ConfigError(
            fmt::format("output.arrays: unknown array \"{}\"; known: force, torque, angular_velocity, "
                        "contact_count, max_overlap, kinetic_energy, rattler, size_class",
                        name));
      }
      if (std::find(s.snapshotArrays.begin(), s.snapshotArrays.end(), name) != s.snapshotArrays.end()) {
        throw ConfigError(fmt::format("output.arrays: \"{}\" is listed twice", name));
      }
      s.snapshotArrays.push_back(name);
      begin = end + 1;
    }
  }
  s.contacts = output.boolean("contacts", s.contacts);
  s.checkpoint = output.string("checkpoint", "");
  s.checkpointInterval = output.integerAtLeast("checkpoint_interval", s.checkpointInterval, 0);
  s.checkpointSeconds = output.number("checkpoint_seconds", s.checkpointSeconds);
  output.finish();
  if (s.checkpointSeconds < 0.0) {
    throw ConfigError(fmt::format("output.checkpoint_seconds must be >= 0 (0 = none), got {}", s.checkpointSeconds));
  }
  if (!s.checkpoint.empty() && !(s.checkpoint.ends_with(".h5") || s.checkpoint.ends_with(".hdf5"))) {
    throw ConfigError(
        fmt::format("output.checkpoint = \"{}\": checkpoints are HDF5 files, name it *.h5", s.checkpoint));
  }
  if (!s.snapshotArrays.empty()) {
    const std::string& f = s.snapshot;
    // Every snapshot format holds them (HDF5 datasets, dump and text columns) but LAMMPS data files.
    const std::string name = std::filesystem::path(f).filename().string();
    const bool lammpsData = f.ends_with(".data") || f.ends_with(".lmp") || name.starts_with("data.");
    if (f.empty() || lammpsData) {
      throw ConfigError(
          fmt::format("output.arrays needs HDF5 (.h5), LAMMPS dump (.dump) or text snapshots; output.snapshot = "
                      "\"{}\" {}",
                      f, f.empty() ? "is not set" : "is a LAMMPS data file, which has no columns for them"));
    }
  }
  if (s.contacts && s.snapshot.empty()) {
    throw ConfigError(
        "output.contacts = true writes one contact file beside every snapshot, but output.snapshot is not set: "
        "give output.snapshot (e.g. \"relax_{step}.h5\"; text snapshots get CSV contact files)");
  }
  if (!s.snapshot.empty() && s.snapshotInterval > 0 && s.snapshot.find("{step}") == std::string::npos) {
    throw ConfigError(
        fmt::format("output.snapshot = \"{}\" needs a {{step}} placeholder when "
                    "output.snapshot_interval > 0",
                    s.snapshot));
  }
}

RelaxScene interpret(const toml::table& root, const std::filesystem::path& source) {
  static const std::set<std::string> kSections = {"particles",   "box", "contact", "velocities",
                                                  "compression", "run", "output"};
  for (auto&& [key, node] : root) {
    const std::string name(key.str());
    if (!kSections.count(name)) {
      throw ConfigError(
          fmt::format("unknown section or key '{}' (line {}); sections: particles, box, contact, "
                      "velocities, compression, run, output",
                      name, node.source().begin.line));
    }
    if (!node.is_table()) throw ConfigError(fmt::format("'{}' must be a [section]", name));
  }
  auto section = [&](const char* name) { return Section(root.get_as<toml::table>(name), name); };
  RelaxScene s;
  s.source = source;

  const bool generate = readParticles(section("particles"), s);
  readBox(section("box"), s, generate);
  readContact(section("contact"), s);
  readVelocities(section("velocities"), s, generate);
  readCompression(section("compression"), s);
  readRun(section("run"), s);
  readOutput(section("output"), s);
  return s;
}

}  // namespace

std::string defaultSceneToml() {
  // Every value below comes from the structs and constants the reader falls back on, so this text
  // cannot drift from the code (tests/apps/relax_scene_test.cpp also parses it back).
  const RelaxScene s;
  const DistributionSpec d;
  const contact::ContactParameters c;
  const integrators::DemSettings dem;
  const integrators::CompressionSettings cs;
  auto num = [](double v) {
    std::string t = fmt::format("{}", v);                        // shortest text that reads back to the same double
    if (t.find_first_of(".en") == std::string::npos) t += ".0";  // a TOML float, not an integer
    return t;
  };
  auto boolean = [](bool b) { return b ? "true" : "false"; };
  std::string t;
  t += "# polydem relax --print-defaults: every scene key with its default. Keys marked \"required\" have no\n";
  t += "# default (the value shown is an example); particles.file and particles.count exclude each other.\n\n";
  t += "[particles]\n";
  t += "# file = \"packing.txt\"  # required unless count is given: a particle file (text or .h5)\n";
  t += "count = 1000  # required unless file is given: generate this many spheres\n";
  t +=
      fmt::format("distribution = \"{}\"  # mono, bi, uniform-radius, uniform-volume, power-law, log-normal\n", d.kind);
  t += fmt::format("rmin = {}  # m\n", num(d.rmin));
  t += fmt::format("omega = {}  # rmax / rmin\n", num(d.omega));
  t += fmt::format("alpha = {}  # power-law exponent\n", num(d.alpha));
  t += fmt::format("sigma = {}  # log-normal width\n", num(d.sigma));
  t += fmt::format("median = {}  # log-normal a0\n", num(d.median));
  t += fmt::format("large_fraction = {}  # bi\n", num(d.largeFraction));
  t += fmt::format("fraction_kind = \"{}\"  # volume or number\n",
                   d.fractionKind == FractionKind::Number ? "number" : "volume");
  t += fmt::format("sampling = \"{}\"  # systematic or random\n", s.sampling);
  t += fmt::format("packing_fraction = {}\n", num(s.packingFraction));
  t += fmt::format("seed = {}\n", s.seed);
  t += fmt::format("density = {}  # kg/m^3\n\n", num(s.density));
  t += "[box]\n";
  t += "boundaries = \"periodic\"  # periodic, walls, or per axis [\"periodic\", \"periodic\", \"wall\"]\n";
  t += fmt::format("aspect = [{}, {}, {}]\n\n", num(s.aspect[0]), num(s.aspect[1]), num(s.aspect[2]));
  t += "[contact]\n";
  t += fmt::format("law = \"{}\"  # linear or hertz\n", c.normal == contact::NormalModel::Hertz ? "hertz" : "linear");
  t += "stiffness = 1000.0  # required: N/m (linear), N/m^2 (radius-scaled), Pa (hertz: 4/3 E*)\n";
  t += fmt::format("stiffness_scaling = \"{}\"  # constant or radius\n",
                   c.scaling == contact::StiffnessScaling::Radius ? "radius" : "constant");
  t += fmt::format("damping = \"{}\"  # restitution (per-pair dashpot from e) or mass-velocity (LAMMPS gran/hooke)\n",
                   c.damping == contact::DampingModel::MassVelocity ? "mass-velocity" : "restitution");
  t += fmt::format("restitution = {}\n", num(c.restitution));
  t += "# gamma_n = 5000.0  # required with damping = \"mass-velocity\": 1/s, F_n += gamma_n m_eff d'\n";
  t += fmt::format("friction = {}\n", num(c.friction));
  t += fmt::format(
      "tangential = \"{}\"  # cundall-strack, lammps-history (LAMMPS gran/hooke/history) or hertz-mindlin (hertz "
      "law only)\n",
      c.tangential == contact::TangentialModel::LammpsHistory  ? "lammps-history"
      : c.tangential == contact::TangentialModel::HertzMindlin ? "hertz-mindlin"
                                                               : "cundall-strack");
  t += fmt::format("tangential_stiffness_ratio = {}\n", num(c.tangentialStiffnessRatio));
  t += fmt::format("tangential_damping_ratio = {}\n", num(c.tangentialDampingRatio));
  t += "# shear_modulus = 1e10  # hertz-mindlin, example value: the pair's G* (Pa), 1/G* = (2-nu1)/G1 + (2-nu2)/G2\n";
  t += "# poisson_ratio = 0.3  # hertz-mindlin, instead: one material, G* = E* (1-nu) / (2 (2-nu))\n";
  t += fmt::format("reference_velocity = {}  # m/s, hertz only; 0 = twice the fastest particle\n\n",
                   num(c.referenceVelocity));
  t += "[velocities]\n";
  t += fmt::format("initial = \"{}\"  # impact, file, zero (\"file\" when particles.file is given)\n",
                   s.initialVelocities);
  t += fmt::format("overlap = {}\n", num(s.impactOverlap));
  t += fmt::format("seed = {}\n\n", s.velocitySeed);
  t += "# [compression]  # optional; absent = no compression\n";
  t += "# packing_fraction = 0.64  # required in [compression]\n";
  t += fmt::format("# growth_rate = {}\n", num(cs.growthRate));
  t += fmt::format("# damping = {}\n", num(cs.damping));
  t += fmt::format("# max_overlap = {}\n", num(cs.relaxedOverlap));
  t += fmt::format("# max_steps = {}\n\n", cs.maxSteps);
  t += "[run]\n";
  t += "steps = 1000  # required\n";
  t += fmt::format("dt_factor = {}  # steps per shortest contact, >= {:g}\n", num(dem.stepsPerContact),
                   integrators::kMinStepsPerContact);
  t += fmt::format("dt = {}  # s; > 0 overrides dt_factor\n", num(dem.timeStep));
  t += fmt::format("allow_unstable_dt = {}  # run a dt above t_c,min / 5 anyway\n", boolean(dem.allowUnstableDt));
  t += "skin = \"auto\"  # m, or auto = 0.2 r_min\n";
  t += fmt::format("broadphase = \"{}\"\n", kDefaultBroadPhase);
  t += fmt::format("gravity = [{}, {}, {}]  # m/s^2\n", num(dem.gravity[0]), num(dem.gravity[1]), num(dem.gravity[2]));
  t += fmt::format("viscous_damping = {}  # 1/s\n", num(dem.viscousDamping));
  t += fmt::format("dashpot_velocity = \"{}\"  # predicted v(t+dt) or half-step v(t+dt/2) (LAMMPS)\n",
                   dem.dashpotVelocity == integrators::DashpotVelocity::HalfStep ? "half-step" : "predicted");
  t += fmt::format("check_interval = {}  # 0 = only at the end\n", dem.stability.checkInterval);
  t += fmt::format("max_overlap_fraction = {}\n", num(dem.stability.maxOverlapFraction));
  t += fmt::format("energy_tolerance = {}\n", num(dem.stability.energyTolerance));
  t += fmt::format("kernel = \"{}\"  # specialised or general\n", dem.generalKernel ? "general" : "specialised");
  t += fmt::format("spatial_sort = {}\n", boolean(dem.spatialSort));
  t += fmt::format("threads = {}\n", dem.threads);
  t += fmt::format("progress_interval = {}  # s; 0 = none\n\n", num(s.progressInterval));
  t += "[output]\n";
  t += "snapshot = \"\"  # e.g. \"relax_{step}.h5\"; empty = none\n";
  t += fmt::format("snapshot_interval = {}  # steps; 0 = only at the end\n", s.snapshotInterval);
  t += "timeseries = \"\"  # CSV; empty = none\n";
  t += fmt::format("timeseries_interval = {}\n", s.timeseriesInterval);
  t += "final = \"\"  # particle file; empty = none\n";
  t += "arrays = []  # optional snapshot arrays: force, torque, angular_velocity, contact_count, max_overlap, "
       "kinetic_energy, rattler, size_class\n";
  t += fmt::format("contacts = {}  # a contact file per snapshot (HDF5 + .xmf beside .h5 snapshots, else CSV)\n",
                   boolean(s.contacts));
  t += "checkpoint = \"\"  # HDF5 file for relax --resume; empty = none\n";
  t += fmt::format("checkpoint_interval = {}  # steps; 0 = none by steps\n", s.checkpointInterval);
  t += fmt::format("checkpoint_seconds = {}  # wall-clock s; 0 = none by time\n", num(s.checkpointSeconds));
  return t;
}

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
