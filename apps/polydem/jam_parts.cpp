// polydem jam: the parts of a run that print nothing (start, system, checkpoint, contact analysis, output
// record), shared by jam.cpp and the Python module's jam() so both make the same start, checkpoint and file.
#include <fmt/format.h>

#include <cmath>

#include "apps/polydem/common.hpp"
#include "apps/polydem/equivalent_option.hpp"
#include "apps/polydem/jam.hpp"
#include "core/errors.hpp"
#include "core/initial_configuration.hpp"
#include "core/io/attributes.hpp"
#include "core/io/particle_file.hpp"

namespace polydem::app {

edmd::CompressionOptions compressionOptions(const JamOptions& opt) {
  edmd::CompressionOptions copt;
  copt.schedule = edmd::parseSchedule(opt.schedule);
  copt.targetPressure = opt.targetPressure;
  copt.targetPackingFraction = opt.targetPhi;
  copt.maxCollisionsPerParticle = opt.maxCollisions;
  copt.blockCollisionsPerParticle = opt.block;
  return copt;
}

edmd::SystemOptions systemOptions(const JamOptions& opt) {
  edmd::SystemOptions sopt;
  sopt.broadPhase = opt.broadPhase;
  sopt.neighbourhoodScale = opt.neighbourhoodScale;
  sopt.skinCap = opt.skinCap;
  return sopt;
}

std::string reopenStart(io::ParticleData& start, double pressure, const std::string& input) {
  // edmd::reopenRadiusFactor holds for packings jammed well beyond the pressure reopened to.
  const std::optional<double> p = io::numericAttribute(start, "reduced_pressure", input);
  if (p && !(*p > edmd::kReopenMargin * pressure)) {
    throw ConfigError(
        fmt::format("--reopen {}: the input {} has reduced pressure {:g}, not well above it", pressure, input, *p));
  }
  const double factor = edmd::reopenRadiusFactor(pressure);
  start.radius *= factor;
  return fmt::format(", radii x {:.12g} (reopened to p ~ {:g})", factor, pressure);
}

io::ParticleData sampledStart(const SizeDistribution& distribution, const JamOptions& opt, std::string& origin) {
  if (opt.count < 2) {
    throw ConfigError(
        fmt::format("--count {}: a compression needs at least 2 spheres (a lone sphere has no "
                    "binary collisions, so neither a pressure nor a collision budget ends its run)",
                    opt.count));
  }
  std::string equivalentDescription;
  StartPackingRequest request;
  request.count = opt.count;
  request.sampling = opt.sampling == "random" ? Sampling::Random : Sampling::Systematic;
  if (opt.equivalent != "none")
    request.radii = equivalentRadii(distribution, opt.equivalent, opt.count, equivalentDescription);
  request.packingFraction = opt.initialPhi;
  request.boundaries = parseBoundaries(opt.boundaries);
  request.seed = opt.seed;
  StartPacking packing = makeStartPacking(distribution, request);
  io::ParticleData start;
  start.box = packing.configuration.box;
  start.position = std::move(packing.configuration.position);
  start.radius = std::move(packing.configuration.radius);
  start.id = std::move(packing.id);
  start.attributes["distribution"] = packing.distribution;
  if (opt.equivalent != "none") start.attributes["equivalent_mixture"] = equivalentDescription;
  origin = fmt::format("random sequential addition of {} spheres ({}) at phi {}", opt.count,
                       opt.equivalent == "none" ? distribution.describe() : equivalentDescription, opt.initialPhi);
  return start;
}

std::unique_ptr<edmd::HardSphereSystem> startedSystem(const JamOptions& opt, const edmd::CompressionOptions& copt,
                                                      io::ParticleData& start, const std::string& input) {
  const Index count = start.count();
  if (count < 2) {
    throw ConfigError(
        fmt::format("{}: {} sphere{}; a compression needs at least 2 (a lone sphere has no binary "
                    "collisions, so neither a pressure nor a collision budget ends its run)",
                    input, count, count == 1 ? "" : "s"));
  }
  if (start.id.size() != static_cast<std::size_t>(count)) {
    start.id.resize(static_cast<std::size_t>(count));
    for (Index i = 0; i < count; ++i) start.id[static_cast<std::size_t>(i)] = i;
  }
  auto system = std::make_unique<edmd::HardSphereSystem>(start.box, start.position, start.radius,
                                                         edmd::maxwellBoltzmannVelocities(start.radius, opt.seed),
                                                         systemOptions(opt));
  // The same checks compress() makes, before the run.
  edmd::validateCompression(*system, copt);
  return system;
}

std::unique_ptr<edmd::HardSphereSystem> restoreSystem(const io::Checkpoint& saved, const std::string& file,
                                                      const JamOptions& opt, const io::ParticleData& start) {
  const edmd::SystemState engine = getEngine(saved);
  const Index n = static_cast<Index>(engine.radius.size());
  if (static_cast<Index>(start.id.size()) != n) {
    throw InputError(fmt::format("{}: checkpoint has {} ids for {} particles", file, start.id.size(), n));
  }
  const std::size_t un = static_cast<std::size_t>(n);
  if (n < 2 || engine.position.size() != 3 * un || engine.velocity.size() != 3 * un || engine.external.size() != un) {
    throw InputError(fmt::format("{}: checkpoint engine arrays disagree in size ({} radii)", file, n));
  }
  // Construct in the caller's numbering (the constructor checks the state), then restore the engine's own.
  Eigen::Matrix3Xd x = Eigen::Matrix3Xd::Zero(3, n), v = Eigen::Matrix3Xd::Zero(3, n);
  Eigen::VectorXd r = Eigen::VectorXd::Ones(n);
  for (Index i = 0; i < n; ++i) {
    const Index e = static_cast<Index>(engine.external[static_cast<std::size_t>(i)]);
    if (e < 0 || e >= n) throw InputError(fmt::format("{}: checkpoint numbering out of range", file));
    for (int k = 0; k < 3; ++k) {
      x(k, e) = engine.position[3 * static_cast<std::size_t>(i) + static_cast<std::size_t>(k)];
      v(k, e) = engine.velocity[3 * static_cast<std::size_t>(i) + static_cast<std::size_t>(k)];
    }
    r[e] = engine.radius[static_cast<std::size_t>(i)];
  }
  auto system = std::make_unique<edmd::HardSphereSystem>(start.box, x, r, v, systemOptions(opt));
  system->restoreState(engine);
  return system;
}

io::Checkpoint jamCheckpoint(const JamOptions& opt, const std::string& origin, const io::ParticleData& start,
                             edmd::HardSphereSystem& system, const edmd::CompressionState& cs, std::int64_t eosOffset) {
  io::Checkpoint c;
  c.kind = "jam";
  c.putInteger("format", kJamCheckpointFormat);
  putSettings(c, opt);
  c.text["origin"] = origin;
  putStartRecord(c, start);
  putCompressionState(c, cs);
  c.putInteger("eos_offset", eosOffset);
  putEngine(c, system.saveState());
  return c;
}

void analysePacking(const JamOptions& opt, const edmd::HardSphereSystem& system, JamSummary& summary) {
  summary.x = system.positions();
  summary.r = system.radii();
  summary.contactOptions.relativeGap =
      opt.contactGap > 0.0 ? opt.contactGap : jamming::defaultContactGap(summary.pressure);
  summary.contactOptions.broadPhase = opt.broadPhase;
  summary.net = jamming::analyseContacts(SphereView{summary.x, summary.r}, system.box(), summary.contactOptions);
  summary.phi = system.packingFraction();
  summary.phiJ = edmd::jammingDensityEstimate(summary.phi, summary.pressure);
}

io::ParticleData packingRecord(const JamOptions& opt, const edmd::CompressionOptions& copt,
                               const io::ParticleData& start, const edmd::HardSphereSystem& system, const JamSummary& s,
                               std::int64_t collisions) {
  io::ParticleData out;
  out.box = system.box();
  out.position = s.x;
  out.radius = s.r;
  // Hard spheres end a run with velocities: HDF5 and LAMMPS outputs always carry them; the text format
  // only with --velocities, so its four columns (which analyze, scripts and the determinism reference read) stay.
  if (opt.writeVelocities || !io::isTextPath(opt.output)) out.velocity = system.velocities();
  out.id = start.id;
  out.time = system.time();
  out.attributes = start.attributes;
  out.attributes["generator"] = "polydem jam";
  out.attributes["schedule"] = edmd::formatSchedule(copt.schedule);
  out.attributes["target"] =
      opt.targetPhi > 0 ? fmt::format("phi {:.17g}", opt.targetPhi) : fmt::format("p {:.17g}", opt.targetPressure);
  out.attributes["target_reached"] = s.targetReached ? "yes" : "no";
  out.attributes["stop_reason"] = s.stopReason;
  out.attributes["packing_fraction"] = fmt::format("{:.17g}", s.phi);
  out.attributes["reduced_pressure"] = fmt::format("{:.17g}", s.pressure);
  if (std::isfinite(s.phiJ)) out.attributes["phi_j_estimate"] = fmt::format("{:.17g}", s.phiJ);
  out.attributes["contacts"] = std::to_string(s.net.contacts.size());
  out.attributes["contact_gap"] = fmt::format("{:.3g}", s.contactOptions.relativeGap);
  out.attributes["z"] = fmt::format("{:.6f}", s.net.meanCoordination());
  if (s.net.backbone > 0) out.attributes["z_backbone"] = fmt::format("{:.6f}", s.net.backboneCoordination());
  out.attributes["rattler_fraction"] = fmt::format("{:.6f}", s.net.rattlerFraction());
  out.attributes["collisions"] = std::to_string(collisions);
  return out;
}

}  // namespace polydem::app
