// polydem bench: the shared scene preparation, timing and report writing (see bench_common.hpp).
#include "apps/polydem/bench_common.hpp"

namespace polydem::app::bench {

/// Reorder particles along a Morton (Z-order) curve of their positions, as a DEM code does once at
/// start-up, so that particles close in space are close in memory.
void mortonSort(Configuration& c) {
  const Index n = static_cast<Index>(c.radius.size());
  std::vector<std::pair<std::uint64_t, Index>> keys;
  broadphase::mortonOrder(SphereView{c.position, c.radius}, c.box, keys);
  Eigen::Matrix3Xd position(3, n);
  Eigen::VectorXd radius(n);
  for (Index k = 0; k < n; ++k) {
    position.col(k) = c.position.col(keys[static_cast<std::size_t>(k)].second);
    radius[k] = c.radius[keys[static_cast<std::size_t>(k)].second];
  }
  c.position.swap(position);
  c.radius.swap(radius);
}

std::filesystem::path stateCache(const BenchOptions& opt) {
  return opt.cacheDir.empty() ? std::filesystem::path(opt.out) / "states" : std::filesystem::path(opt.cacheDir);
}

/// A non-overlapping configuration at `packing`: random sequential addition when it reaches the target;
/// otherwise (dense = edmd) Lubachevsky-Stillinger growth with the event-driven engine from the densest
/// RSA state, stopped exactly at the target (the seed's preparation, ch. 2.1.4; the same as
/// `polydem jam --target-phi`), or (dense = rsa) the densest RSA state in steps of 0.04. Compressed
/// states are cached as HDF5 files keyed by distribution, N, packing and seed. Particles are Morton-sorted.
BenchScene makeBenchScene(const BenchOptions& opt, const DistributionSpec& spec, Index count, double packing,
                          std::uint64_t seed, double equilibrate) {
  const auto dist = makeDistribution(spec);
  PackingRequest request;
  request.radii = dist->sample(count, Sampling::Systematic, seed);
  std::mt19937_64 rng(seed);
  std::shuffle(request.radii.begin(), request.radii.end(), rng);
  request.boundaries = {Boundary::Periodic, Boundary::Periodic, Boundary::Periodic};
  request.seed = seed;
  request.maxAttemptsPerParticle = 2000;  // fail fast when RSA stalls
  BenchScene scene;
  scene.label = spec.kind == "mono" ? "mono" : fmt::format("{} omega={:g}", spec.kind, spec.omega);
  if (spec.kind == "power-law") scene.label += fmt::format(" alpha={:g}", spec.alpha);
  // Small wide systems: a periodic box must hold two cut-offs; use walls when it cannot.
  double volume = 0.0;
  for (double r : request.radii) volume += 4.0 / 3.0 * kPi * r * r * r;
  const double rmax = *std::max_element(request.radii.begin(), request.radii.end());
  if (std::cbrt(volume / packing) < 2.0 * (2.2 * rmax)) {
    request.boundaries = {Boundary::Wall, Boundary::Wall, Boundary::Wall};
    scene.label += " (walls)";
  }
  const std::filesystem::path cached =
      stateCache(opt) / fmt::format("{}_w{:g}_a{:g}_n{}_phi{:g}_s{}{}{}.h5", spec.kind, spec.omega, spec.alpha, count,
                                    packing, seed, request.boundaries[0] == Boundary::Wall ? "_walls" : "",
                                    equilibrate > 0.0 ? fmt::format("_eq{:g}", equilibrate) : std::string());
  if ((opt.dense == "edmd" || equilibrate > 0.0) && std::filesystem::exists(cached)) {
    const io::ParticleData data = io::readParticles(cached);
    scene.config.box = data.box;
    scene.config.position = data.position;
    scene.config.radius = data.radius;
    mortonSort(scene.config);
    scene.packing = packing;
    scene.placement = fmt::format("cached {}", cached.filename().string());
    return scene;
  }
  for (double phi = packing; phi > 0.05; phi -= 0.04) {
    request.packingFraction = phi;
    try {
      scene.config = randomSequentialAddition(request);
    } catch (const ConfigError&) {
      continue;  // RSA stalled: try a little less dense
    }
    scene.packing = phi;
    const bool compressing = phi != packing && opt.dense == "edmd";
    if (phi == packing) {
      scene.placement = "rsa";
    } else if (!compressing) {
      scene.placement = fmt::format("rsa (stalled at {:.2f}, used {:.2f})", packing, phi);
    }
    if (compressing || equilibrate > 0.0) {
      Stopwatch clock;
      edmd::HardSphereSystem system(scene.config.box, scene.config.position, scene.config.radius,
                                    edmd::maxwellBoltzmannVelocities(scene.config.radius, seed), edmd::SystemOptions{});
      if (compressing) {
        edmd::CompressionOptions copt;
        copt.schedule = {{1e-2, std::numeric_limits<double>::infinity()}};
        copt.targetPackingFraction = packing;
        const edmd::CompressionResult r = edmd::compress(system, copt);
        scene.placement = fmt::format("edmd from rsa {:.2f}", phi);
        fmt::print(
            "  {} N = {}: RSA stalled, event-driven compression {:.2f} -> {:.3f} ({}, {:.0f} collisions per "
            "particle, {:.1f} s)\n",
            scene.label, count, phi, system.packingFraction(), r.stopReason,
            static_cast<double>(r.counts.collisions) / count, clock.seconds());
      }
      if (equilibrate > 0.0) {
        // Random sequential addition leaves every sphere apart from its neighbours, unlike a compressed
        // fluid: relax all states the same way (hard-sphere collisions at fixed density) so that systems
        // prepared differently have comparable local structure.
        edmd::runAtFixedDensity(system, equilibrate, std::min(equilibrate, 100.0));
        scene.placement += fmt::format(", {:g} collisions/particle at fixed density", equilibrate);
      }
      scene.config.position = system.positions();
      scene.config.radius = system.radii();
      scene.packing = system.packingFraction();
      std::filesystem::create_directories(cached.parent_path());
      io::ParticleData data;
      data.box = scene.config.box;
      data.position = scene.config.position;
      data.radius = scene.config.radius;
      data.id.resize(static_cast<std::size_t>(count));
      for (Index i = 0; i < count; ++i) data.id[static_cast<std::size_t>(i)] = i;
      data.attributes["generator"] = "polydem bench: " + scene.placement;
      data.attributes["distribution"] = dist->describe();
      io::writeParticles(cached, data);
    }
    mortonSort(scene.config);
    return scene;
  }
  throw ConfigError(fmt::format("could not place {} at any packing fraction", scene.label));
}

/// Create the directory `dir` (and its parents) for output; ConfigError naming `what` if that fails or
/// `dir` is an existing file.
void prepareOutputDirectory(const std::filesystem::path& dir, std::string_view what) {
  std::error_code ec;
  if (std::filesystem::exists(dir, ec) && !std::filesystem::is_directory(dir, ec)) {
    throw ConfigError(fmt::format("{} '{}': exists and is not a directory", what, dir.string()));
  }
  std::filesystem::create_directories(dir, ec);
  if (ec) throw ConfigError(fmt::format("{} '{}': cannot create the directory: {}", what, dir.string(), ec.message()));
  io::checkOutputPath(dir / "README.md", what);
}

/// A particle file benchmarked as it is (Morton-sorted like every scene). A benchmark of fewer than two
/// particles has no pair to find and no time per particle worth reporting: refused.
BenchScene sceneFromFile(const std::string& file) {
  const io::ParticleData data = io::readParticles(file);
  if (data.count() < 2) {
    throw InputError(fmt::format("{}: {} particle{}: a broad-phase benchmark needs at least 2", file, data.count(),
                                 data.count() == 1 ? "" : "s"));
  }
  BenchScene scene;
  scene.label = std::filesystem::path(file).filename().string();
  scene.config.box = data.box;
  scene.config.position = data.position;
  scene.config.radius = data.radius;
  mortonSort(scene.config);
  scene.packing = (4.0 / 3.0 * kPi * data.radius.array().cube().sum()) / data.box.volume();
  scene.placement = "file " + file;
  return scene;
}

std::string machineDescription() {
  std::string cpu = "unknown CPU";
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("model name", 0) == 0) {
      cpu = line.substr(line.find(':') + 2);
      break;
    }
  }
  return fmt::format("{}, {} hardware threads, compiler g++ {}, flags: {}", cpu, std::thread::hardware_concurrency(),
                     __VERSION__, POLYDEM_CXX_FLAGS);
}

std::string today() {
  std::time_t t = std::time(nullptr);
  char buf[64];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M UTC", std::gmtime(&t));
  return buf;
}

/// Run gnuplot on `script`, which sets its output to `png`; the plot is drawn into a temporary file (the
/// script is run from a temporary copy that names it) and committed only when gnuplot succeeds.
bool runGnuplot(const std::filesystem::path& script, const std::filesystem::path& png) {
  std::ifstream in(script);
  std::stringstream text;
  text << in.rdbuf();
  std::string body = text.str();
  io::AtomicFile plot(png);
  const std::string from = "set output '" + png.string() + "'";
  const auto at = body.find(from);
  if (at == std::string::npos) return false;
  body.replace(at, from.size(), "set output '" + plot.temporary().string() + "'");
  io::AtomicFile copy(script);  // never committed: removed when it goes out of scope
  {
    std::ofstream out(copy.temporary());
    out << body;
    if (!out) return false;
  }
  const std::string cmd = fmt::format("gnuplot '{}' 2>/dev/null", copy.temporary().string());
  if (std::system(cmd.c_str()) != 0 || !std::filesystem::exists(plot.temporary())) return false;
  plot.commit();
  return true;
}

Timed timeBackend(broadphase::BroadPhase& bp, const SphereView& spheres, const Box& box, double skin, int repeat) {
  std::vector<broadphase::Pair> pairs;
  std::vector<double> t;
  for (int k = 0; k <= repeat; ++k) {
    CpuStopwatch clock;
    bp.build(spheres, box, skin);
    bp.findPairs(spheres, pairs);
    if (k > 0) t.push_back(clock.seconds());
  }
  Timed r;
  r.seconds = median(t);
  r.spread = (*std::max_element(t.begin(), t.end()) - *std::min_element(t.begin(), t.end())) / r.seconds;
  r.pairs = pairs.size();
  for (const broadphase::Pair& p : pairs) {
    const Eigen::Vector3d d = box.minimumImage(spheres.centre.col(p.i) - spheres.centre.col(p.j));
    const double reach = spheres.radius[p.i] + spheres.radius[p.j];
    if (d.squaredNorm() < reach * reach) ++r.contacts;
  }
  r.bytes = bp.memoryBytes();
  r.description = bp.describe();
  bp.setCounting(true);
  bp.resetCounters();
  bp.build(spheres, box, skin);
  bp.findPairs(spheres, pairs);
  r.pairTests = bp.counters().pairTests;
  r.cellAccesses = bp.counters().cellAccesses;
  bp.setCounting(false);
  return r;
}

std::unique_ptr<broadphase::BroadPhase> gridWith(broadphase::CrossLevel mode, std::vector<double> sizes) {
  sizes.erase(std::unique(sizes.begin(), sizes.end()), sizes.end());
  broadphase::HGridConfig config;
  config.cellSizes = sizes;
  config.mode = mode;
  if (mode == broadphase::CrossLevel::TopDown) {
    auto g = std::make_unique<broadphase::HGridTopDown>();
    g->setConfig(config);
    return g;
  }
  auto g = std::make_unique<broadphase::HGridBottomUp>();
  g->setConfig(config);
  return g;
}

}  // namespace polydem::app::bench
