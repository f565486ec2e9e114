// polydem jam: the checkpoint format (io::Checkpoint of kind "jam"), every value stored bit-exact so that a
// resumed run is the interrupted one.
#include <fmt/format.h>

#include <array>
#include <cmath>

#include "apps/polydem/jam.hpp"
#include "core/errors.hpp"

namespace polydem::app {

namespace {

std::vector<std::int64_t> countsVector(const edmd::EventCounts& c) {
  return {c.collisions, c.wallCollisions, c.checks, c.exits, c.rebuilds, c.relocatedLists, c.missed};
}

edmd::EventCounts countsFrom(const io::Checkpoint& c, const std::string& name) {
  const std::vector<std::int64_t>& v = c.integers(name);
  if (v.size() != 7)
    throw InputError(fmt::format("{}: checkpoint entry {}: expected 7 counts", c.source.string(), name));
  return {v[0], v[1], v[2], v[3], v[4], v[5], v[6]};
}

}  // namespace

void putSettings(io::Checkpoint& c, const JamOptions& o) {
  c.text["schedule"] = o.schedule;
  c.text["broad_phase"] = o.broadPhase;
  c.text["output"] = o.output;
  c.text["eos_csv"] = o.eosCsv;
  c.text["checkpoint"] = o.checkpoint;
  c.text["input"] = o.input;
  c.putScalar("target_pressure", o.targetPressure);
  c.putScalar("target_phi", o.targetPhi);
  c.putScalar("max_collisions", o.maxCollisions);
  c.putScalar("block", o.block);
  c.putScalar("neighbourhood_scale", o.neighbourhoodScale);
  c.putScalar("skin_cap", o.skinCap);
  c.putScalar("contact_gap", o.contactGap);
  c.putScalar("run_collisions", o.runCollisions);
  c.putScalar("progress_seconds", o.progressSeconds);
  c.putScalar("checkpoint_interval", o.checkpointInterval);
  c.putInteger("write_velocities", o.writeVelocities ? 1 : 0);
}

void getSettings(const io::Checkpoint& c, JamOptions& o) {
  o.schedule = c.string("schedule");
  o.broadPhase = c.string("broad_phase");
  o.output = c.string("output");
  o.eosCsv = c.string("eos_csv");
  o.checkpoint = c.string("checkpoint");
  o.input = c.string("input");
  o.targetPressure = c.scalar("target_pressure");
  o.targetPhi = c.scalar("target_phi");
  o.maxCollisions = c.scalar("max_collisions");
  o.block = c.scalar("block");
  o.neighbourhoodScale = c.scalar("neighbourhood_scale");
  o.skinCap = c.scalar("skin_cap");
  o.contactGap = c.scalar("contact_gap");
  o.runCollisions = c.scalar("run_collisions");
  o.progressSeconds = c.scalar("progress_seconds");
  o.checkpointInterval = c.scalar("checkpoint_interval");
  o.writeVelocities = c.integerScalar("write_velocities") != 0;
}

void putEngine(io::Checkpoint& c, const edmd::SystemState& s) {
  c.real["engine.position"] = s.position;
  c.real["engine.velocity"] = s.velocity;
  c.real["engine.radius"] = s.radius;
  c.real["engine.mass"] = s.mass;
  c.integer["engine.external"] = s.external;
  c.real["engine.hood_centre"] = s.hoodCentre;
  c.real["engine.hood_radius"] = s.hoodRadius;
  c.real["engine.hood_skin"] = s.hoodSkin;
  c.integer["engine.hood_begin"] = s.hoodBegin;
  c.integer["engine.hood_size"] = s.hoodSize;
  c.integer["engine.hood_capacity"] = s.hoodCapacity;
  c.integer["engine.neighbours"] = s.neighbours;
  c.real["engine.scalars"] = {s.growth,          s.elapsed,           s.skinFloor,     s.sizeRatio,
                              s.kinetic,         s.maxOverlap,        s.window.virial, s.window.kineticIntegral,
                              s.window.duration, s.lastCollision.time};
  c.integer["engine.counters"] = {s.collisionsAtSort, s.collisionsAtRebuild, s.exitsAtRebuild,  s.pairsAtRebuild,
                                  s.pairWork,         s.window.collisions,   s.lastCollision.i, s.lastCollision.j};
  c.integer["engine.total"] = countsVector(s.total);
  c.real["engine.class_skin_floor"] = s.classSkinFloor;
  c.integer["engine.class_counters"] = s.classCounters;
}

edmd::SystemState getEngine(const io::Checkpoint& c) {
  edmd::SystemState s;
  s.position = c.reals("engine.position");
  s.velocity = c.reals("engine.velocity");
  s.radius = c.reals("engine.radius");
  s.mass = c.reals("engine.mass");
  s.external = c.integers("engine.external");
  s.hoodCentre = c.reals("engine.hood_centre");
  s.hoodRadius = c.reals("engine.hood_radius");
  s.hoodSkin = c.reals("engine.hood_skin");
  s.hoodBegin = c.integers("engine.hood_begin");
  s.hoodSize = c.integers("engine.hood_size");
  s.hoodCapacity = c.integers("engine.hood_capacity");
  s.neighbours = c.integers("engine.neighbours");
  const std::vector<double>& r = c.reals("engine.scalars");
  const std::vector<std::int64_t>& k = c.integers("engine.counters");
  if (r.size() != 10 || k.size() != 8) {
    throw InputError(
        fmt::format("{}: checkpoint entries engine.scalars/engine.counters have the wrong length", c.source.string()));
  }
  s.growth = r[0];
  s.elapsed = r[1];
  s.skinFloor = r[2];
  s.sizeRatio = r[3];
  s.kinetic = r[4];
  s.maxOverlap = r[5];
  s.window.virial = r[6];
  s.window.kineticIntegral = r[7];
  s.window.duration = r[8];
  s.lastCollision.time = r[9];
  s.collisionsAtSort = k[0];
  s.collisionsAtRebuild = k[1];
  s.exitsAtRebuild = k[2];
  s.pairsAtRebuild = k[3];
  s.pairWork = k[4];
  s.window.collisions = k[5];
  s.lastCollision.i = static_cast<Index>(k[6]);
  s.lastCollision.j = static_cast<Index>(k[7]);
  s.total = countsFrom(c, "engine.total");
  // Size-class skins (issue 24): checkpoints written before them lack both entries.
  if (c.has("engine.class_skin_floor")) s.classSkinFloor = c.reals("engine.class_skin_floor");
  if (c.has("engine.class_counters")) s.classCounters = c.integers("engine.class_counters");
  return s;
}

void putStartRecord(io::Checkpoint& c, const io::ParticleData& start) {
  for (const auto& [key, value] : start.attributes) c.text["attribute." + key] = value;
  c.real["box_lengths"] = {start.box.length(0), start.box.length(1), start.box.length(2)};
  c.integer["box_boundaries"] = {start.box.periodic(0) ? 0 : 1, start.box.periodic(1) ? 0 : 1,
                                 start.box.periodic(2) ? 0 : 1};
  c.integer["ids"] = std::vector<std::int64_t>(start.id.begin(), start.id.end());
}

io::ParticleData getStartRecord(const io::Checkpoint& c) {
  io::ParticleData start;
  const std::vector<double>& lengths = c.reals("box_lengths");
  const std::vector<std::int64_t>& bounds = c.integers("box_boundaries");
  if (lengths.size() != 3 || bounds.size() != 3) {
    throw InputError(fmt::format("{}: checkpoint entries box_lengths/box_boundaries need 3 values", c.source.string()));
  }
  std::array<Boundary, 3> b{};
  for (int k = 0; k < 3; ++k)
    b[static_cast<std::size_t>(k)] = bounds[static_cast<std::size_t>(k)] ? Boundary::Wall : Boundary::Periodic;
  start.box = Box(Eigen::Vector3d(lengths[0], lengths[1], lengths[2]), b);
  const std::vector<std::int64_t>& ids = c.integers("ids");
  start.id.assign(ids.begin(), ids.end());
  for (const auto& [key, value] : c.text) {
    if (key.rfind("attribute.", 0) == 0) start.attributes[key.substr(10)] = value;
  }
  return start;
}

void putCompressionState(io::Checkpoint& c, const edmd::CompressionState& cs) {
  c.putInteger("stage", cs.stage);
  c.putInteger("blocks", cs.blocks);
  c.integer["initial_counts"] = countsVector(cs.initial);
  c.real["plateau"] = {cs.pressureLimit, cs.windowMax, cs.previousWindowMax};
  c.integer["plateau_blocks"] = {cs.windowBlocks, cs.windowStart};
}

void putSessionRecord(io::Checkpoint& c, const SessionRecord& record) {
  if (record.wallKnown) c.putScalar("wall_seconds_before", record.wallSeconds);
  c.putInteger("sessions_before", record.sessions);
}

SessionRecord getSessionRecord(const io::Checkpoint& c) {
  SessionRecord record;
  record.wallKnown = c.has("wall_seconds_before");
  if (record.wallKnown) {
    record.wallSeconds = c.scalar("wall_seconds_before");
    if (!std::isfinite(record.wallSeconds) || record.wallSeconds < 0.0) {
      throw InputError(fmt::format("{}: checkpoint entry wall_seconds_before is {}: must be finite and >= 0",
                                   c.source.string(), record.wallSeconds));
    }
  }
  // Checkpoints before the record: at least the session that wrote them.
  record.sessions = c.has("sessions_before") ? c.integerScalar("sessions_before") : 1;
  if (record.sessions < 1) {
    throw InputError(
        fmt::format("{}: checkpoint entry sessions_before is {}: must be >= 1", c.source.string(), record.sessions));
  }
  return record;
}

edmd::CompressionState getCompressionState(const io::Checkpoint& c) {
  edmd::CompressionState cs;
  cs.begun = true;
  cs.stage = c.integerScalar("stage");
  cs.blocks = c.integerScalar("blocks");
  cs.initial = countsFrom(c, "initial_counts");
  const std::vector<double>& plateau = c.reals("plateau");
  if (plateau.size() != 3)
    throw InputError(fmt::format("{}: checkpoint entry plateau needs 3 values", c.source.string()));
  cs.pressureLimit = plateau[0];
  cs.windowMax = plateau[1];
  cs.previousWindowMax = plateau[2];
  const std::vector<std::int64_t>& window = c.integers("plateau_blocks");
  if (window.size() != 2)
    throw InputError(fmt::format("{}: checkpoint entry plateau_blocks needs 2 values", c.source.string()));
  cs.windowBlocks = window[0];
  cs.windowStart = window[1];
  return cs;
}

}  // namespace polydem::app
