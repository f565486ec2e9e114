// polydem relax: checkpoints. A checkpoint (io::Checkpoint, kind "relax") holds the DemState of the run
// (or of its soft compression, with the CompressionProgress) and the scene as given, so that
// `relax --resume FILE.h5` parses the same scene and continues bit-identically.
#include <fmt/format.h>

#include <cstring>
#include <sstream>

#include "apps/polydem/relax.hpp"
#include "core/errors.hpp"

namespace polydem::app {

namespace {

std::vector<std::int64_t> asInt64(const std::vector<std::uint64_t>& keys) {
  // Bit pattern kept. An empty vector may hold a null data(), which memcpy may not be given (UBSan).
  std::vector<std::int64_t> out(keys.size());
  if (!keys.empty()) std::memcpy(out.data(), keys.data(), keys.size() * sizeof(std::uint64_t));
  return out;
}
std::vector<std::uint64_t> asUint64(const std::vector<std::int64_t>& keys) {
  std::vector<std::uint64_t> out(keys.size());
  if (!keys.empty()) std::memcpy(out.data(), keys.data(), keys.size() * sizeof(std::uint64_t));
  return out;
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (!line.empty()) out.push_back(line);
  }
  return out;
}

}  // namespace

io::Checkpoint makeCheckpoint(const integrators::DemSimulation& sim, const RunContext& run,
                              const integrators::CompressionProgress* compression) {
  const integrators::DemState st = sim.state();
  io::Checkpoint c;
  c.kind = kCheckpointKind;
  c.text["phase"] = compression ? "compression" : "run";
  if (compression) {
    const integrators::CompressionProgress& p = *compression;
    c.integer["compression_progress"] = {static_cast<std::int64_t>(p.phase), p.steps, p.growthSteps, p.relaxSteps,
                                         p.packed ? 1 : 0};
    c.real["compression_values"] = {p.overlap, p.contactDuration, p.viscousDamping};
  }
  c.text["scene"] = run.sceneText;
  c.text["scene_source"] = run.sceneSource;
  std::string overrides, attributes;
  for (const std::string& o : run.overrides) overrides += o + "\n";
  for (const auto& [k, v] : run.attributes) attributes += k + "\t" + v + "\n";
  c.text["overrides"] = overrides;
  c.text["attributes"] = attributes;
  c.text["origin"] = run.origin;
  c.putMatrix("position", st.position);
  c.putMatrix("velocity", st.velocity);
  c.putMatrix("force", st.force);
  c.putVector("radius", st.radius);
  c.putVector("inverse_mass", st.inverseMass);
  c.putInteger("rotation", st.rotation ? 1 : 0);
  if (st.rotation) {
    c.putMatrix("angular_velocity", st.angularVelocity);
    c.putMatrix("torque", st.torque);
    c.putVector("inverse_inertia", st.inverseInertia);
  }
  c.integer["id"] = std::vector<std::int64_t>(st.id.begin(), st.id.end());
  c.putMatrix("reference_position", st.referencePosition);
  c.putVector("reference_radius", st.referenceRadius);
  c.integer["pair_keys"] = asInt64(st.pairKeys);
  c.integer["wall_keys"] = asInt64(st.wallKeys);
  c.real["pair_values"] = st.pairValues;
  c.real["wall_values"] = st.wallValues;
  c.real["box_lengths"] = {st.box.length(0), st.box.length(1), st.box.length(2)};
  c.integer["box_periodic"] = {st.box.periodic(0), st.box.periodic(1), st.box.periodic(2)};
  c.putInteger("step", st.step);
  c.putScalar("time_origin", st.timeOrigin);
  c.putInteger("builds", st.builds);
  c.putScalar("skin", st.skin);
  c.putScalar("initial_energy", st.initialEnergy);
  c.putScalar("growth_since_build", st.growthSinceBuild);
  const integrators::TimeStepChoice& t = st.timeStep;
  c.real["time_step"] = {t.dt, t.contactDuration, t.stepsPerContact, t.radiusA, t.radiusB};
  c.integer["time_step_pair"] = {t.slotA, t.slotB, t.idA, t.idB};
  return c;
}

integrators::DemState stateFrom(const io::Checkpoint& c) {
  integrators::DemState st;
  const std::int64_t n = static_cast<std::int64_t>(c.vector("radius").size());
  st.radius = c.vector("radius");
  st.position = c.matrix("position", n);
  st.velocity = c.matrix("velocity", n);
  st.force = c.matrix("force", n);
  st.inverseMass = c.vector("inverse_mass");
  st.rotation = c.integerScalar("rotation") != 0;
  if (st.rotation) {
    st.angularVelocity = c.matrix("angular_velocity", n);
    st.torque = c.matrix("torque", n);
    st.inverseInertia = c.vector("inverse_inertia");
  }
  const auto& id = c.integers("id");
  st.id.assign(id.begin(), id.end());
  st.referencePosition = c.matrix("reference_position", n);
  st.referenceRadius = c.vector("reference_radius");
  st.pairKeys = asUint64(c.integers("pair_keys"));
  st.wallKeys = asUint64(c.integers("wall_keys"));
  st.pairValues = c.reals("pair_values");
  st.wallValues = c.reals("wall_values");
  const auto& L = c.reals("box_lengths");
  const auto& periodic = c.integers("box_periodic");
  if (L.size() != 3 || periodic.size() != 3) {
    throw InputError(
        fmt::format("{}: checkpoint entry box_lengths / box_periodic: expected 3 values", c.source.string()));
  }
  std::array<Boundary, 3> b{};
  for (std::size_t k = 0; k < 3; ++k) b[k] = periodic[k] ? Boundary::Periodic : Boundary::Wall;
  st.box = Box(Eigen::Vector3d(L[0], L[1], L[2]), b);
  st.step = c.integerScalar("step");
  st.timeOrigin = c.has("time_origin") ? c.scalar("time_origin") : 0.0;
  st.builds = c.integerScalar("builds");
  st.skin = c.scalar("skin");
  st.initialEnergy = c.scalar("initial_energy");
  st.growthSinceBuild = c.scalar("growth_since_build");
  const auto& t = c.reals("time_step");
  const auto& pair = c.integers("time_step_pair");
  if (t.size() != 5 || pair.size() != 4) {
    throw InputError(fmt::format("{}: checkpoint entry time_step: wrong length", c.source.string()));
  }
  st.timeStep.dt = t[0];
  st.timeStep.contactDuration = t[1];
  st.timeStep.stepsPerContact = t[2];
  st.timeStep.radiusA = t[3];
  st.timeStep.radiusB = t[4];
  st.timeStep.slotA = static_cast<Index>(pair[0]);
  st.timeStep.slotB = static_cast<Index>(pair[1]);
  st.timeStep.idA = static_cast<Index>(pair[2]);
  st.timeStep.idB = static_cast<Index>(pair[3]);
  return st;
}

integrators::CompressionProgress compressionFrom(const io::Checkpoint& c) {
  const auto& i = c.integers("compression_progress");
  const auto& r = c.reals("compression_values");
  if (i.size() != 5 || r.size() != 3 || i[0] < 0 || i[0] > 2) {
    throw InputError(
        fmt::format("{}: checkpoint entry compression_progress / compression_values: malformed", c.source.string()));
  }
  integrators::CompressionProgress p;
  p.phase = static_cast<integrators::CompressionProgress::Phase>(i[0]);
  p.steps = i[1];
  p.growthSteps = i[2];
  p.relaxSteps = i[3];
  p.packed = i[4] != 0;
  p.overlap = r[0];
  p.contactDuration = r[1];
  p.viscousDamping = r[2];
  return p;
}

RunContext contextFrom(const io::Checkpoint& c, const std::vector<std::string>& overrides) {
  RunContext context;
  context.sceneText = c.string("scene");
  context.sceneSource = c.string("scene_source");
  context.overrides = lines(c.string("overrides"));
  context.origin = c.string("origin");
  for (const std::string& line : lines(c.string("attributes"))) {
    const std::size_t tab = line.find('\t');
    if (tab != std::string::npos) context.attributes[line.substr(0, tab)] = line.substr(tab + 1);
  }
  // Later overrides win: the saved ones first, then this command line's.
  context.overrides.insert(context.overrides.end(), overrides.begin(), overrides.end());
  return context;
}

bool resumableKey(const std::string& assignment) {
  const std::string key = assignment.substr(0, assignment.find('='));
  return key == "run.steps" || key == "run.threads" || key == "run.progress_interval" || key.starts_with("output.");
}

}  // namespace polydem::app
