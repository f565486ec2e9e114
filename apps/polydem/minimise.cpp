// polydem minimise: FIRE energy minimisation of frictionless soft spheres to mechanical equilibrium, and with
// --target-pressure the pressure-controlled jamming protocol (O'Hern et al., PRE 68, 011306 (2003)): grow or
// shrink the radii with a minimisation after each change until the reduced pressure p/k is the target.
// The start is a particle file (-i, e.g. a `polydem jam` packing) or a sampled distribution placed by random
// sequential addition or at independent random centres. The output carries the attributes `polydem jam`
// writes, so `polydem analyze` reads it (see writeOutput() for reduced_pressure).
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>
#include <vector>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/common.hpp"
#include "apps/polydem/exit_codes.hpp"
#include "apps/polydem/minimise_mpi.hpp"
#include "apps/polydem/minimise_scene.hpp"
#include "apps/polydem/validators.hpp"
#include "broadphase/registry.hpp"
#include "core/errors.hpp"
#include "core/initial_configuration.hpp"
#include "core/interrupt.hpp"
#include "core/io/attributes.hpp"
#include "core/io/contacts.hpp"
#include "core/io/particle_file.hpp"
#include "core/io/safe_output.hpp"
#include "integrators/pressure_jamming.hpp"
#include "jamming/contact_network.hpp"

namespace polydem::app {

namespace {

struct MinimiseOptions {
  std::string scene;  ///< TOML file with a [minimise] table (apps/polydem/minimise_scene.hpp)
  // start
  std::string input;
  DistributionSpec dist;
  std::string fractionKind = "volume";
  double count = 0;
  double initialPhi = 0.6;
  std::string placement = "random";
  std::string sampling = "systematic";
  std::string boundaries = "periodic";
  std::uint64_t seed = 1;
  // contact law
  std::string law = "linear";
  std::string scaling = "radius";
  double stiffness = 1.0;
  // the minimiser
  std::string method = "fire";
  double forceTolerance = 1e-9;
  double maxIterations = 1e7;
  double dt = 0.1;
  double dtMaxFactor = 10.0;
  std::string broadPhase = "auto";
  double skin = -1.0;
  double outerSkin = -1.0;
  int threads = 1;
  // pressure protocol
  double targetPressure = 0.0;
  double deltaPhi = 0.0;
  double pressureTolerance = 0.05;
  double initialStep = 1e-3;
  double maxStep = 0.02;
  int maxSteps = 300;
  // output
  std::string output;
  bool contacts = false;  ///< --contacts: the contact file beside --output
  double progressSeconds = 5.0;
  int sizeClasses = 5;
};

void addOptions(CLI::App* cmd, MinimiseOptions* o) {
  cmd->add_option("scene", o->scene,
                  "TOML scene with a [minimise] table: keys are the long options with _ for - (e.g. "
                  "target_pressure = 1e-6); options on the command line override it");
  cmd->add_option("-i,--input", o->input, "start from this particle file (e.g. a `polydem jam` packing)");
  addDistributionOptions(*cmd, o->dist, o->fractionKind);
  cmd->add_option("-n,--count", o->count, "number of spheres of a sampled start (at least 2)")
      ->check(finiteIn(0.0, 1e9));
  cmd->add_option("--phi0", o->initialPhi, "packing fraction of a sampled start, in (0, 1)")
      ->check(finiteOpen(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--placement", o->placement,
                  "sampled start: random (independent centres, overlaps allowed: any phi0) or rsa (random sequential "
                  "addition, no overlaps: phi0 up to ~0.35 for equal spheres)")
      ->check(CLI::IsMember({"random", "rsa"}))
      ->capture_default_str();
  cmd->add_option("--sampling", o->sampling, "systematic or random radii")
      ->check(CLI::IsMember({"systematic", "random"}))
      ->capture_default_str();
  cmd->add_option("--boundary", o->boundaries, "periodic, walls, or per axis e.g. periodic,periodic,wall")
      ->check(boundaryNames())
      ->capture_default_str();
  cmd->add_option("--seed", o->seed, "random seed of a sampled start")->capture_default_str();
  cmd->add_option("--law", o->law, "normal contact law: linear (harmonic) or hertz")
      ->check(CLI::IsMember({"linear", "hertz"}))
      ->capture_default_str();
  cmd->add_option("--stiffness-scaling", o->scaling,
                  "linear law: radius (k_ij = k R_eff, the reduced pressure is p/k) or constant (k_ij = k)")
      ->check(CLI::IsMember({"radius", "constant"}))
      ->capture_default_str();
  cmd->add_option("--stiffness", o->stiffness, "k (radius: N/m^2, constant: N/m) or Hertz K = 4/3 E* (Pa)")
      ->check(finitePositive())
      ->capture_default_str();
  cmd->add_option("--force-tolerance", o->forceTolerance,
                  "converged when max |F_i| <= this x the mean contact force (with --target-pressure: at least the "
                  "mean contact force at the target)")
      ->check(finiteIn(1e-15, 0.1))
      ->capture_default_str();
  cmd->add_option("--method", o->method,
                  "descent on the forces: fire (FIRE 2.0) or cg (preconditioned Polak-Ribiere conjugate gradients "
                  "with a secant line search; same forces, stopping rule and results to the tolerance)")
      ->check(CLI::IsMember({"fire", "cg"}))
      ->capture_default_str();
  cmd->add_option("--max-iterations", o->maxIterations,
                  "force evaluations per minimisation: FIRE steps, or 2 per CG iteration (exit 4 when spent)")
      ->check(finiteIn(1.0, 1e12))
      ->capture_default_str();
  cmd->add_option("--dt", o->dt, "initial FIRE step in preconditioned units (omega ~ 1); dt_max = dt-max-factor x dt")
      ->check(finiteIn(1e-6, 1.0))
      ->capture_default_str();
  cmd->add_option("--dt-max-factor", o->dtMaxFactor, "dt_max / dt (FIRE 2.0 default 10)")
      ->check(finiteIn(1.0, 100.0))
      ->capture_default_str();
  cmd->add_option("--broad-phase", o->broadPhase,
                  "broad phase of the neighbour list (auto, linked-cell, hgrid-td, ...)")
      ->capture_default_str();
  cmd->add_option("--skin", o->skin, "Verlet skin (length; default 0.2 r_min)")->check(finitePositive());
  cmd->add_option("--outer-skin", o->outerSkin,
                  "two-level Verlet list: the broad phase finds the pairs within this gap, and rebuilds cut the "
                  "list to the skin from them while they hold every contact (length, >= skin; default 5 x skin; "
                  "0 = one level)")
      ->check(finiteNonNegative());
  cmd->add_option("--threads", o->threads, "OpenMP threads of the force loop (bit-identical results)")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  cmd->add_option("--target-pressure", o->targetPressure,
                  "pressure-controlled jamming: grow/shrink the radii, minimising each time, to this reduced "
                  "pressure p/k in (0, 1) (e.g. 1e-6)")
      ->check(finiteOpen(0.0, 1.0));
  cmd->add_option("--delta-phi", o->deltaPhi,
                  "first change the packing fraction by this (grow or shrink every radius by a common factor), then "
                  "minimise: e.g. a jammed packing compressed by phi - phi_J")
      ->check(finiteIn(-0.5, 0.5));
  cmd->add_option("--pressure-tolerance", o->pressureTolerance, "relative tolerance on the target pressure")
      ->check(finiteOpen(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--initial-step", o->initialStep, "first relative change of phi of the protocol")
      ->check(finiteIn(1e-9, 0.5))
      ->capture_default_str();
  cmd->add_option("--max-step", o->maxStep, "largest relative change of phi per step before the target is bracketed")
      ->check(finiteIn(1e-9, 0.5))
      ->capture_default_str();
  cmd->add_option("--max-steps", o->maxSteps, "minimisations of the protocol in all (exit 4 when spent)")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  cmd->add_option("-o,--output", o->output, "write the minimised packing: .h5/.hdf5 for HDF5 (+ .xmf), else text");
  cmd->add_flag("--contacts", o->contacts,
                "with -o: also write the contact network beside it (NAME_contacts.h5 + .xmf for HDF5, else "
                "NAME_contacts.csv): pairs, normal forces, overlaps, branch vectors (docs/files.md)");
  cmd->add_option("--progress", o->progressSeconds, "seconds between progress lines (0 = none)")
      ->check(finiteNonNegative())
      ->capture_default_str();
  cmd->add_option("--size-classes", o->sizeClasses, "log-spaced radius classes of the rattler report")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
}

/// The start configuration and where it came from.
struct Start {
  io::ParticleData data;
  std::string origin;
};

Start makeStart(MinimiseOptions& o, const CLI::App& cmd) {
  Start s;
  if (!o.input.empty()) {
    const std::string given = firstGivenOption(cmd, distributionOptionNames());
    if (!given.empty() || cmd.count("--count") || cmd.count("--phi0") || cmd.count("--placement")) {
      throw ConfigError(fmt::format("{} describes a sampled start; it cannot be combined with --input",
                                    given.empty() ? std::string("--count/--phi0/--placement") : given));
    }
    const auto boundaries = cmd.count("--boundary") ? parseBoundaries(o.boundaries) : io::kAllPeriodic;
    s.data = io::readParticles(o.input, boundaries);
    if (s.data.count() < 2) {
      throw InputError(fmt::format("{}: {} sphere{}; a minimisation needs at least 2", o.input, s.data.count(),
                                   s.data.count() == 1 ? "" : "s"));
    }
    s.origin = fmt::format("file {}", o.input);
    return s;
  }
  if (o.count < 2) {
    throw ConfigError(fmt::format("--count {:g}: a minimisation needs at least 2 spheres (or give --input)", o.count));
  }
  finishDistributionSpec(o.dist, o.fractionKind);
  const auto dist = makeDistribution(o.dist);
  StartPackingRequest request;
  request.count = static_cast<Index>(o.count);
  request.sampling = o.sampling == "random" ? Sampling::Random : Sampling::Systematic;
  request.packingFraction = o.initialPhi;
  request.boundaries = parseBoundaries(o.boundaries);
  request.seed = o.seed;
  request.placement = o.placement == "rsa" ? Placement::RandomSequentialAddition : Placement::RandomOverlapping;
  StartPacking packing = makeStartPacking(*dist, request);
  s.data.box = packing.configuration.box;
  s.data.position = std::move(packing.configuration.position);
  s.data.radius = std::move(packing.configuration.radius);
  s.data.id = std::move(packing.id);
  s.data.attributes["distribution"] = packing.distribution;
  s.origin = fmt::format("{} of {} spheres ({}) at phi {}",
                         o.placement == "rsa" ? "random sequential addition" : "independent random centres",
                         request.count, dist->describe(), o.initialPhi);
  return s;
}

integrators::MinimiserSettings settingsFrom(const MinimiseOptions& o) {
  integrators::MinimiserSettings s;
  s.contact.normal = o.law == "hertz" ? contact::NormalModel::Hertz : contact::NormalModel::Linear;
  if (o.law == "hertz") {
    s.contact.scaling = contact::StiffnessScaling::Constant;  // Hertz scales with sqrt(R_eff) itself
  } else {
    s.contact.scaling =
        o.scaling == "constant" ? contact::StiffnessScaling::Constant : contact::StiffnessScaling::Radius;
  }
  s.contact.stiffness = o.stiffness;
  s.broadPhase = o.broadPhase;
  s.skin = o.skin;
  s.outerSkin = o.outerSkin;
  s.threads = o.threads;
  s.method = o.method == "cg" ? integrators::MinimiserMethod::ConjugateGradient : integrators::MinimiserMethod::Fire;
  s.fire.forceTolerance = o.forceTolerance;
  s.fire.maxIterations = static_cast<std::int64_t>(o.maxIterations);
  s.fire.dt = o.dt;
  s.fire.dtMaxFactor = o.dtMaxFactor;
  s.fire.progressInterval = o.progressSeconds > 0.0 ? 100 : 0;
  return s;
}

std::string lawName(const MinimiseOptions& o) {
  if (o.law == "hertz") return fmt::format("hertz K = {:g}", o.stiffness);
  return fmt::format("linear {} k = {:g}", o.scaling, o.stiffness);
}

/// The hard-sphere reduced pressure P whose default contact gap in `polydem analyze`
/// (jamming::defaultContactGap: max(100/P, sqrt(1e-3/P)), at most 1e-3) is `gap`; 0 if gap >= 1e-3.
double analyzePressureForGap(double gap) {
  if (!(gap < 1e-3)) return 0.0;
  return gap <= 1e-5 ? 1e-3 / (gap * gap) : 100.0 / gap;
}

struct Outcome {
  bool ok = false;
  bool interrupted = false;
  std::string stopReason;
  std::string fireStop;  ///< why the last minimisation stopped ("converged", "round-off floor", ...)
  std::int64_t iterations = 0;
  integrators::MinimiserReport last;
};

/// The contacts (overlap > 0) of the minimised packing `d` (slot order, wrapped) with the law's elastic normal
/// force (FIRE runs have no dashpot and no friction), for --contacts. O(N) with a linked-cell pass.
io::ContactData minimisedContacts(const integrators::FireMinimiser& m, const io::ParticleData& d) {
  const contact::ContactModel model(m.settings().contact);
  const bool hertz = model.parameters().normal == contact::NormalModel::Hertz;
  const SphereView spheres{d.position, d.radius};
  std::vector<broadphase::Pair> pairs;
  if (d.count() > 1) {
    std::unique_ptr<broadphase::BroadPhase> bp = broadphase::makeBroadPhase("linked-cell");
    try {
      bp->build(spheres, d.box, 0.0);
    } catch (const ConfigError&) {  // a box too small for cells
      bp = broadphase::makeBroadPhase("brute");
      bp->build(spheres, d.box, 0.0);
    }
    bp->findPairs(spheres, pairs);
  }
  struct Row {
    Index idI, idJ;
    Index a, b;  // slots of id_i, id_j
  };
  std::vector<Row> rows;
  for (const broadphase::Pair& p : pairs) {
    const Eigen::Vector3d gap = d.box.minimumImage(d.position.col(p.j) - d.position.col(p.i));
    const double sumR = d.radius[p.i] + d.radius[p.j];
    if (gap.squaredNorm() >= sumR * sumR) continue;
    const Index idI = d.id[std::size_t(p.i)], idJ = d.id[std::size_t(p.j)];
    rows.push_back(idI < idJ ? Row{idI, idJ, p.i, p.j} : Row{idJ, idI, p.j, p.i});
  }
  std::sort(rows.begin(), rows.end(),
            [](const Row& x, const Row& y) { return x.idI != y.idI ? x.idI < y.idI : x.idJ < y.idJ; });
  io::ContactData c;
  c.box = d.box;
  c.time = d.time;
  c.attributes["contact"] = model.parameters().describe();
  const auto count = static_cast<Index>(rows.size());
  c.idI.resize(rows.size());
  c.idJ.resize(rows.size());
  c.centre.resize(3, count);
  c.branch.resize(3, count);
  c.overlap.resize(count);
  c.normalForce.resize(count);
  for (Index k = 0; k < count; ++k) {
    const Row& r = rows[std::size_t(k)];
    const Eigen::Vector3d branch = d.box.minimumImage(d.position.col(r.b) - d.position.col(r.a));
    const double overlap = d.radius[r.a] + d.radius[r.b] - branch.norm();
    const double reff = d.radius[r.a] * d.radius[r.b] / (d.radius[r.a] + d.radius[r.b]);
    c.idI[std::size_t(k)] = r.idI;
    c.idJ[std::size_t(k)] = r.idJ;
    c.centre.col(k) = d.position.col(r.a);
    c.branch.col(k) = branch;
    c.overlap[k] = overlap;
    c.normalForce[k] = hertz ? contact::HertzNormal::force(model.hertzParams(), overlap, 0.0, 1.0, reff).force
                             : contact::LinearNormal::force(model.linearParams(), overlap, 0.0, 1.0, reff).force;
  }
  return c;
}

/// The hard-sphere phi_J estimate of a `polydem jam` input (attribute phi_j_estimate), 0 for any other start.
/// A value that is not a packing fraction is an error naming the file and the attribute.
double jammingEstimateOf(const MinimiseOptions& o, const Start& start) {
  const auto gen = start.data.attributes.find("generator");
  if (o.input.empty() || gen == start.data.attributes.end() || gen->second != "polydem jam") return 0.0;
  const std::optional<double> v = io::numericAttribute(start.data, "phi_j_estimate", o.input);
  if (!v) return 0.0;
  if (!(*v > 0.0 && *v < 1.0)) {
    throw InputError(fmt::format("{}: attribute phi_j_estimate = '{}' is not a packing fraction in (0, 1)", o.input,
                                 start.data.attributes.at("phi_j_estimate")));
  }
  return *v;
}

void writeOutput(const MinimiseOptions& o, const Start& start, const integrators::FireMinimiser& m, const Outcome& out,
                 const jamming::ContactNetwork& net) {
  io::ParticleData d;
  d.box = m.box();
  d.position = m.wrappedPositions();
  d.radius = m.particles().radius();
  d.id = m.particles().id();
  d.attributes = start.data.attributes;
  d.attributes["generator"] = "polydem minimise";
  d.attributes["start"] = start.origin;
  d.attributes["contact_law"] = lawName(o);
  d.attributes["target"] = o.targetPressure > 0.0 ? fmt::format("p/k {:.17g}", o.targetPressure)
                                                  : fmt::format("force residual {:.3g}", o.forceTolerance);
  d.attributes["target_reached"] = out.ok ? "yes" : "no";
  d.attributes["stop_reason"] = out.stopReason;
  d.attributes["packing_fraction"] = fmt::format("{:.17g}", out.last.packingFraction);
  d.attributes["soft_reduced_pressure"] = fmt::format("{:.17g}", out.last.reducedPressure);
  d.attributes["energy"] = fmt::format("{:.17g}", out.last.energy);
  d.attributes["residual_force"] = fmt::format("{:.6g}", out.last.residual);
  d.attributes["fire_iterations"] = std::to_string(out.iterations);
  d.attributes["fire_stop_reason"] = out.fireStop;
  d.attributes["minimiser_method"] = o.method;
  if (o.targetPressure > 0.0 && out.ok)
    d.attributes["phi_j_estimate"] = fmt::format("{:.17g}", out.last.packingFraction);
  // `polydem analyze` treats the file as a hard-sphere packing whose contact gap follows from its reduced
  // pressure: write the pressure whose default gap is 1.1 x the largest overlap (relative to the smaller
  // radius, as analyze's validity check measures it), so that the overlaps pass and every overlapping pair
  // counts as a contact.
  const double gap = std::max(1.1 * out.last.maxOverlapRatio, 1e-12);
  d.attributes["contact_gap"] = fmt::format("{:.3g}", gap);
  const double pEq = analyzePressureForGap(gap);
  if (pEq > 0.0) {
    d.attributes["reduced_pressure"] = fmt::format("{:.17g}", pEq);
    d.attributes["reduced_pressure_meaning"] =
        "not a soft-sphere pressure (see soft_reduced_pressure): the hard-sphere reduced pressure whose default "
        "contact gap in polydem analyze is contact_gap, 1.1 x the largest overlap";
  }
  d.attributes["contacts"] = std::to_string(net.contacts.size());
  d.attributes["z"] = fmt::format("{:.6f}", net.meanCoordination());
  if (net.backbone > 0) d.attributes["z_backbone"] = fmt::format("{:.6f}", net.backboneCoordination());
  d.attributes["rattler_fraction"] = fmt::format("{:.6f}", net.rattlerFraction());
  io::writeParticles(o.output, d);
  fmt::print("wrote {}\n", o.output);
  if (o.contacts) {
    io::ContactData contacts = minimisedContacts(m, d);
    contacts.attributes["snapshot"] = std::filesystem::path(o.output).filename().string();
    const std::filesystem::path file = io::contactPathFor(o.output);
    io::writeContacts(file, contacts);
    fmt::print("wrote {} ({} contacts)\n", file.string(), contacts.count());
  }
}

void printState(const char* label, const integrators::MinimiserReport& r) {
  fmt::print("{:<24}energy {:.6g}  residual {:.3g}  contacts {}  p/k {:.6g}  phi {:.10f}\n", label, r.energy,
             r.residual, r.contacts + r.wallContacts, r.reducedPressure, r.packingFraction);
}

int runMinimise(MinimiseOptions& o, CLI::App& cmd) {
  if (!o.scene.empty()) applyMinimiseScene(o.scene, cmd, {"input", "output"});
  installInterruptHandlers();
  if (cmd.count("--max-step") && o.maxStep < o.initialStep) {
    throw ConfigError(fmt::format("--max-step {:g} is below --initial-step {:g}", o.maxStep, o.initialStep));
  }
  const bool protocol = o.targetPressure > 0.0;
  for (const char* name : {"--pressure-tolerance", "--initial-step", "--max-step", "--max-steps"}) {
    if (cmd.count(name) && !protocol) throw ConfigError(fmt::format("{} needs --target-pressure", name));
  }
  if (cmd.count("--delta-phi") && protocol) {
    throw ConfigError("--delta-phi cannot be combined with --target-pressure (the protocol sets phi itself)");
  }
  if (cmd.count("--stiffness-scaling") && o.law == "hertz") {
    throw ConfigError("--stiffness-scaling applies to --law linear only (Hertz scales with sqrt(R_eff) itself)");
  }
  if (o.contacts && o.output.empty()) {
    throw ConfigError("--contacts writes the contact file beside the packing: give -o FILE too");
  }
  if (!o.output.empty()) {
    std::vector<std::filesystem::path> inputs;
    if (!o.input.empty()) inputs.emplace_back(o.input);
    if (!o.scene.empty()) inputs.emplace_back(o.scene);
    io::checkOutputPath(o.output, "--output", inputs);
    if (o.contacts) io::checkOutputPath(io::contactPathFor(o.output), "--contacts (the contact file)", inputs);
  }
  const bool ranks = minimiseOnSeveralRanks();  // docs/parallel.md
  Start start = makeStart(o, cmd);
  // The input's hard-sphere phi_J estimate, read (and checked) before any work.
  const double jammingEstimate = protocol ? jammingEstimateOf(o, start) : 0.0;
  ParticleStore store(start.data.count(), Features{});
  store.position() = start.data.position;
  store.radius() = start.data.radius;
  store.id() = start.data.id;
  store.setMassesFromDensity(1.0);  // replaced by the minimiser's preconditioning masses
  integrators::FireMinimiser m(std::move(store), start.data.box, settingsFrom(o));
  fmt::print("start                   {}\n", start.origin);
  fmt::print("box                     {}\n", m.box().describe());
  fmt::print("contact law             {} ({}), reduced pressure p / {:.6g}\n", lawName(o), m.kernel().name,
             m.pressureUnit());
  fmt::print("broad phase             {} (skin {:.4g})\n", m.neighbours().backend().describe(), m.neighbours().skin());
  printState("initial", m.measure());

  if (o.deltaPhi != 0.0) {
    const double phi = m.packingFraction();
    if (!(phi + o.deltaPhi > 0.0 && phi + o.deltaPhi < 1.0)) {
      throw ConfigError(
          fmt::format("--delta-phi {:g}: phi {:.6f} + {:g} is outside (0, 1)", o.deltaPhi, phi, o.deltaPhi));
    }
    if (!ranks) {  // on ranks, minimiseOnRanks() scales on the distributed state
      m.scaleRadii(std::cbrt((phi + o.deltaPhi) / phi));
      fmt::print("delta phi               {:g}: phi {:.10f} -> {:.10f}\n", o.deltaPhi, phi, m.packingFraction());
    }
  }
  Stopwatch clock;
  double lastPrint = 0.0;
  // FIRE counts steps; CG counts force evaluations (2 per iteration), the same unit of cost.
  const bool cg = o.method == "cg";
  const char* name = cg ? "CG" : "FIRE";
  const char* unit = cg ? "force evaluations" : "steps";
  if (cg) {
    fmt::print("minimiser               cg (preconditioned conjugate gradients; counts are force evaluations)\n");
  }
  auto fireProgress = [&](const integrators::MinimiserReport& r) {
    if (clock.seconds() - lastPrint < o.progressSeconds) return;
    lastPrint = clock.seconds();
    fmt::print(
        "  {:<4} {:>9}  energy {:.6g}  residual {:.3g} (step {:.3g} ulp)  contacts {}  p/k {:.4g}  {} {:.3g}  {:.1f} "
        "s\n",
        name, r.iteration, r.energy, r.residual, r.stepUlps, r.contacts + r.wallContacts, r.reducedPressure,
        cg ? "line step" : "dt", r.dt, clock.seconds());
  };

  Outcome out;
  std::int64_t evaluations = 0;  // on ranks: the distributed run's count (m's own is then not the run's)
  if (protocol) {
    integrators::PressureJammingSettings js;
    js.targetPressure = o.targetPressure;
    js.pressureTolerance = o.pressureTolerance;
    js.initialStep = o.initialStep;
    js.maxStep = o.maxStep;
    js.maxSteps = o.maxSteps;
    js.jammingEstimate = jammingEstimate;
    js.validate();
    if (js.jammingEstimate > 0.0) {
      fmt::print("phi_J estimate          {:.10f} (the input's phi_j_estimate from polydem jam: the first secant)\n",
                 js.jammingEstimate);
    }
    m.fireSettings().referenceForce = m.contactForceAtPressure(o.targetPressure);
    auto onStep = [&](const integrators::JammingStep& s) {
      fmt::print("step {:>4} {:<10} phi {:.12f}  p/k {:.6g}  {} {} ({}, residual {:.3g})  contacts {}  {:.1f} s\n",
                 s.step, s.action, s.packingFraction, s.reducedPressure, name, s.fire.iterations, s.fire.stopReason,
                 s.fire.last.residual, s.fire.last.contacts + s.fire.last.wallContacts, clock.seconds());
    };
    const integrators::PressureJammingResult r = ranks ? jamOnRanks(m, js, onStep, fireProgress, evaluations)
                                                       : integrators::jamToPressure(m, js, onStep, fireProgress, true);
    out.ok = r.reached;
    out.interrupted = r.stopReason == "interrupted";
    out.stopReason = r.stopReason;
    out.iterations = r.fireIterations;
    out.last = r.lastFire.last;
    out.fireStop = r.lastFire.stopReason;
    fmt::print("minimisations           {} ({} {} {})\n", r.steps, r.fireIterations, name, unit);
  } else {
    const integrators::FireResult r =
        ranks ? minimiseOnRanks(m, o.deltaPhi, fireProgress, evaluations) : m.minimise(fireProgress, true);
    out.ok = r.converged;
    out.interrupted = r.stopReason == "interrupted";
    out.stopReason = r.converged ? r.stopReason
                                 : fmt::format("not converged: residual {:.3g} after {} iterations ({})",
                                               r.last.residual, r.iterations, r.stopReason);
    out.iterations = r.iterations;
    out.last = r.last;
    out.fireStop = r.stopReason;
    fmt::print("{:<23} {} ({} {}, {} neighbour-list builds, {} of them through the broad phase)\n",
               fmt::format("{} {}", name, cg ? "evaluations" : "steps"), r.iterations, r.uphillSteps,
               cg ? "restarts" : "uphill", r.rebuilds, r.broadPhaseBuilds);
    const double perStep = r.iterations > 0 ? 1e6 / (static_cast<double>(r.iterations) * m.particles().count()) : 0.0;
    fmt::print(
        "{:<23} {:.4f} us/particle/{} ({:.3f} s): broad phase {:.4f}, force {:.4f}, update {:.4f}, "
        "measurements {:.4f}\n",
        fmt::format("{} time", name), r.seconds.total() * perStep, cg ? "evaluation" : "step", r.seconds.total(),
        r.seconds.broadPhase * perStep, r.seconds.force * perStep, r.seconds.update * perStep,
        r.seconds.measure * perStep);
  }
  printState("final", out.last);
  if (out.fireStop == "round-off floor") {
    fmt::print(
        "note                    {} stopped at the round-off floor: residual {:.3g} against the tolerance {:.3g}, "
        "which this state cannot reach (the forces ask no sphere to move by a representable amount, step {:.3g} "
        "ulp of the coordinates, and the residual stopped falling)\n",
        name, out.last.residual, o.forceTolerance, out.last.stepUlps);
  }
  fmt::print("time                    {:.2f} s, {} force evaluations, memory {:.1f} MB{}\n", clock.seconds(),
             ranks ? evaluations : m.forceEvaluations(), static_cast<double>(m.memoryBytes()) / 1e6,
             ranks ? " (rank 0's serial copy)" : "");

  const jamming::ContactNetwork net = integrators::softContactNetwork(m, "hgrid-td");
  if (!out.ok)
    fmt::print("note                    not at equilibrium: the contact statistics describe the state as it is\n");
  fmt::print("contacts                {} (overlapping pairs) + {} wall\n", net.contacts.size(),
             net.wallContacts.size());
  fmt::print("z (all spheres)         {:.6f}\n", net.meanCoordination());
  fmt::print("rattlers                {} of {} ({:.4f}; fewer than 4 contacts, removed recursively)\n",
             net.particles - net.backbone, net.particles, net.rattlerFraction());
  if (net.backbone > 0) {
    fmt::print(
        "z (non-rattlers)        {:.6f}; isostatic excess {} contacts, z - z_iso {:.6f} (z_iso = 2 (3N' - {}) / N')\n",
        net.backboneCoordination(), net.isostaticExcess(),
        2.0 * static_cast<double>(net.isostaticExcess()) / static_cast<double>(net.backbone), net.periodicAxes - 1);
  } else {
    fmt::print("z (non-rattlers)        undefined (every sphere a rattler: not jammed)\n");
  }
  for (const auto& c : integrators::rattlersBySize(m.particles().radius(), net.rattler, o.sizeClasses)) {
    if (c.count == 0) continue;
    fmt::print("  r in [{:.4g}, {:.4g}]  {:>9} spheres  rattler fraction {:.4f}\n", c.rLow, c.rHigh, c.count,
               static_cast<double>(c.rattlers) / static_cast<double>(c.count));
  }
  if (protocol && out.ok)
    fmt::print("phi_J                   {:.10f} (at p/k {:.4g})\n", out.last.packingFraction, out.last.reducedPressure);
  fmt::print("result                  {}\n", out.stopReason);
  if (!o.output.empty() && minimiseRoot()) writeOutput(o, start, m, out, net);
  if (out.interrupted) return kExitInterrupted;
  return out.ok ? kExitOk : kExitTargetNotReached;
}

}  // namespace

Runner addMinimise(CLI::App& app) {
  auto opt = std::make_shared<MinimiseOptions>();
  CLI::App* cmd = app.add_subcommand(
      "minimise",
      "FIRE energy minimisation of frictionless soft spheres; --target-pressure: pressure-controlled jamming");
  addOptions(cmd, opt.get());
  return [opt, cmd]() -> int { return runMinimise(*opt, *cmd); };
}

}  // namespace polydem::app
