// polydem_backends_report: build, find and update cost per particle and bytes per particle of every
// broad-phase backend on given particle files, for scripts/backends_report.sh (issue 23).
//
// Per file: skin = skin-factor * r_min; particles Morton-sorted as `polydem bench` does. Each backend
// first runs once untimed (warm-up; a backend slower than --budget seconds there is skipped for the
// file and reported as such). Then --repeat rounds, each timing every backend once, the backend order
// rotated from round to round (interleaved, so slow drifts of the machine spread over all backends):
//   build    build() on the unmoved spheres
//   find     findPairs() after that build
//   update   for each fraction f of --moved: a fresh untimed build, then every (1/f)-th sphere (offset
//            by the round) displaced uniformly by up to skin/2 per axis, then update() timed. The pairs
//            found afterwards must agree in number across backends (checked, not timed).
// The CSV holds the medians over rounds in microseconds of thread CPU time per particle (update: per
// particle of the system; update_per_moved: per moved sphere) and memoryBytes() per particle.
//
// Backend names are the registry's, plus lbvh:B for an LBVH with leaves of B spheres and hgrid-td+aabb /
// hgrid-bu+aabb for the HGrid with the AABB pre-check on (off by default since session 17).
//   polydem_backends_report [--backends a,b] [--repeat 5] [--moved 0.01,0.1] [--skin-factor 0.1]
//                           [--budget 60] [--csv out.csv] FILE...
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iostream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "broadphase/hgrid.hpp"
#include "broadphase/lbvh.hpp"
#include "broadphase/linked_cell.hpp"
#include "broadphase/morton_order.hpp"
#include "broadphase/registry.hpp"
#include "core/errors.hpp"
#include "core/io/particle_file.hpp"

namespace {

using namespace polydem;

double threadSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

struct Sample {
  std::vector<double> build, find;
  std::vector<std::vector<double>> update;  // per moved fraction
  std::size_t bytes = 0, pairs = 0;
  std::vector<std::size_t> pairsAfterUpdate;
  std::string description;
  std::string status = "ok";
};

void mortonSort(io::ParticleData& d) {
  const Index n = d.count();
  std::vector<std::pair<std::uint64_t, Index>> keys;
  broadphase::mortonOrder(SphereView{d.position, d.radius}, d.box, keys);
  Eigen::Matrix3Xd x(3, n);
  Eigen::VectorXd r(n);
  for (Index k = 0; k < n; ++k) {
    x.col(k) = d.position.col(keys[static_cast<std::size_t>(k)].second);
    r[k] = d.radius[keys[static_cast<std::size_t>(k)].second];
  }
  d.position.swap(x);
  d.radius.swap(r);
}

/// Spheres moved in round `round` for fraction f, and their displaced centres (deterministic).
void displace(const io::ParticleData& d, double skin, double fraction, int round, Eigen::Matrix3Xd& x,
              std::vector<Index>& moved) {
  const Index n = d.count();
  const Index stride = std::max<Index>(1, static_cast<Index>(std::lround(1.0 / fraction)));
  std::mt19937_64 rng(1000u + static_cast<unsigned>(round));
  std::uniform_real_distribution<double> u(-0.5 * skin, 0.5 * skin);
  x = d.position;
  moved.clear();
  for (Index i = round % stride; i < n; i += stride) {
    Eigen::Vector3d y = x.col(i);
    for (int k = 0; k < 3; ++k) {
      y[k] += u(rng);
      if (!d.box.periodic(k)) y[k] = std::clamp(y[k], 0.0, d.box.length(k));
    }
    x.col(i) = d.box.wrap(y);
    moved.push_back(i);
  }
}

/// A registry backend, `lbvh:B` for the LBVH with leaves of B spheres (leaf-size tuning), or `hgrid-td+aabb` /
/// `hgrid-bu+aabb` for the HGrid with its optional AABB pre-check of cross-level candidates switched on.
std::unique_ptr<broadphase::BroadPhase> makeBackend(const std::string& name) {
  if (name.rfind("lbvh:", 0) == 0) {
    auto bvh = std::make_unique<broadphase::Lbvh>();
    bvh->setLeafSize(std::stoi(name.substr(5)));
    return bvh;
  }
  const std::string aabb = "+aabb";
  if (name.size() > aabb.size() && name.compare(name.size() - aabb.size(), aabb.size(), aabb) == 0) {
    auto bp = broadphase::makeBroadPhase(name.substr(0, name.size() - aabb.size()));
    if (auto* td = dynamic_cast<broadphase::HGridTopDown*>(bp.get())) {
      td->setAabbPrecheck(true);
    } else if (auto* bu = dynamic_cast<broadphase::HGridBottomUp*>(bp.get())) {
      bu->setAabbPrecheck(true);
    } else {
      throw ConfigError(fmt::format("backend '{}': only hgrid-td and hgrid-bu have the AABB pre-check", name));
    }
    return bp;
  }
  return broadphase::makeBroadPhase(name);
}

/// Pair tests linked cell would make (the 27-cell stencil, each pair once): on wide distributions its
/// cells are 2 r_max wide and the count grows like N^2, so the report skips it before running it.
double linkedCellTests(const broadphase::LinkedCell& lc, const io::ParticleData& d) {
  const auto& cells = lc.cellsPerAxis();
  const Eigen::Vector3d& size = lc.cellSize();
  std::vector<double> count(static_cast<std::size_t>(cells[0]) * cells[1] * cells[2], 0.0);
  auto index = [&](int x, int y, int z) { return static_cast<std::size_t>(x + cells[0] * (y + cells[1] * z)); };
  for (Index i = 0; i < d.count(); ++i) {
    int c[3];
    for (int k = 0; k < 3; ++k) c[k] = std::clamp(static_cast<int>(d.position(k, i) / size[k]), 0, cells[k] - 1);
    count[index(c[0], c[1], c[2])] += 1.0;
  }
  // Distinct neighbour coordinates along axis k of cell coordinate c: wrapped on periodic axes,
  // clipped at walls, each once (an axis of one or two cells aliases its neighbours).
  auto around = [&](int k, int c, int* out) {
    int m = 0;
    for (int dc = -1; dc <= 1; ++dc) {
      int q = c + dc;
      if (q < 0 || q >= cells[k]) {
        if (!d.box.periodic(k)) continue;
        q = (q + cells[k]) % cells[k];
      }
      if (std::find(out, out + m, q) == out + m) out[m++] = q;
    }
    return m;
  };
  double tests = 0.0;
  for (int z = 0; z < cells[2]; ++z)
    for (int y = 0; y < cells[1]; ++y)
      for (int x = 0; x < cells[0]; ++x) {
        const double own = count[index(x, y, z)];
        if (own == 0.0) continue;
        int qx[3], qy[3], qz[3];
        const int mx = around(0, x, qx), my = around(1, y, qy), mz = around(2, z, qz);
        double near = 0.0;
        for (int c = 0; c < mz; ++c)
          for (int b = 0; b < my; ++b)
            for (int a = 0; a < mx; ++a) near += count[index(qx[a], qy[b], qz[c])];
        tests += 0.5 * own * near;
      }
  return tests;
}

int run(int argc, char** argv) {
  CLI::App app{"build, find and update cost per particle of every broad-phase backend"};
  std::vector<std::string> files, backends;
  std::vector<double> fractions = {0.01, 0.1};
  int repeat = 5;
  double skinFactor = 0.1, budget = 60.0;
  std::string csvPath = "-";
  app.add_option("files", files, "particle files (.h5 or text)")->required();
  app.add_option("--backends", backends, "backends (default: every registered one)")->delimiter(',');
  app.add_option("--repeat", repeat, "interleaved timed rounds (medians are reported)")->capture_default_str();
  app.add_option("--moved", fractions, "fractions of spheres moved before update()")->delimiter(',');
  app.add_option("--skin-factor", skinFactor, "skin in units of the smallest radius")->capture_default_str();
  app.add_option("--budget", budget, "skip a backend whose untimed warm-up build + find takes longer (s)")
      ->capture_default_str();
  app.add_option("--csv", csvPath, "output CSV ('-' = stdout)")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  if (backends.empty()) backends = broadphase::backendNames();
  if (repeat < 1) {
    fmt::print(stderr, "--repeat must be >= 1\n");
    return 2;
  }

  for (const std::string& name : backends) makeBackend(name);  // a bad name fails before any output
  std::ofstream file;
  if (csvPath != "-") file.open(csvPath);
  std::ostream& csv = csvPath == "-" ? std::cout : file;
  csv << "file,N,omega,packing,boundaries,backend,status,build_us,find_us";
  for (double f : fractions) csv << fmt::format(",update_{:g}_us,update_{:g}_us_per_moved", f, f);
  csv << ",build_find_us,bytes_per_particle,pairs,configuration\n";
  bool agree = true;

  for (const std::string& path : files) {
    io::ParticleData d = io::readParticles(path);
    mortonSort(d);
    const Index n = d.count();
    const double rmin = d.radius.minCoeff(), rmax = d.radius.maxCoeff();
    const double skin = skinFactor * rmin;
    // A periodic box must hold two cut-offs; small wide systems fall back to walls (as `polydem bench` does).
    std::string boundaries = "periodic";
    for (int k = 0; k < 3; ++k) {
      if (d.box.periodic(k) && d.box.length(k) < 2.0 * (2.0 * rmax + skin)) {
        d.box = Box(d.box.lengths(), {Boundary::Wall, Boundary::Wall, Boundary::Wall});
        boundaries = "walls (periodic box below two cut-offs)";
        break;
      }
    }
    if (boundaries == "periodic" && !d.box.fullyPeriodic()) boundaries = d.box.describe();
    const double packing = (4.0 / 3.0 * kPi * d.radius.array().cube().sum()) / d.box.volume();
    const SphereView spheres{d.position, d.radius};
    fmt::print(stderr, "{}: N = {}, omega = {:.4g}, packing {:.3f}, {}\n", path, n, rmax / rmin, packing, boundaries);

    std::map<std::string, Sample> samples;
    std::vector<std::string> active;
    std::vector<broadphase::Pair> pairs;
    for (const std::string& name : backends) {
      Sample& s = samples[name];
      s.update.resize(fractions.size());
      s.pairsAfterUpdate.assign(fractions.size(), 0);
      auto bp = makeBackend(name);
      if (name == "brute" && n > 20000) {
        s.status = "skipped: O(N^2) above N = 20000";
        continue;
      }
      const double t0 = threadSeconds();
      bp->build(spheres, d.box, skin);
      if (const auto* lc = dynamic_cast<const broadphase::LinkedCell*>(bp.get())) {
        const double tests = linkedCellTests(*lc, d);
        if (tests * 2e-9 > budget) {  // about 2 ns per pair test
          s.status = fmt::format("skipped: {:.3g} pair tests predicted (> budget {:g} s)", tests, budget);
          fmt::print(stderr, "  {:<12} {}\n", name, s.status);
          continue;
        }
      }
      bp->findPairs(spheres, pairs);
      const double t = threadSeconds() - t0;
      s.pairs = pairs.size();
      if (t > budget) {
        s.status = fmt::format("skipped: warm-up {:.1f} s > budget {:g} s", t, budget);
        fmt::print(stderr, "  {:<12} {}\n", name, s.status);
        continue;
      }
      active.push_back(name);
    }
    Eigen::Matrix3Xd moved;
    std::vector<Index> which;
    for (int round = 0; round < repeat; ++round) {
      for (std::size_t k = 0; k < active.size(); ++k) {
        const std::string& name = active[(k + static_cast<std::size_t>(round)) % active.size()];
        Sample& s = samples[name];
        auto bp = makeBackend(name);
        bp->build(spheres, d.box, skin);  // sizes buffers and runs auto's optimiser once, untimed
        double t0 = threadSeconds();
        bp->build(spheres, d.box, skin);
        s.build.push_back(threadSeconds() - t0);
        t0 = threadSeconds();
        bp->findPairs(spheres, pairs);
        s.find.push_back(threadSeconds() - t0);
        s.bytes = bp->memoryBytes();
        s.description = bp->describe();
        for (std::size_t f = 0; f < fractions.size(); ++f) {
          displace(d, skin, fractions[f], round, moved, which);
          bp->build(spheres, d.box, skin);
          const SphereView after{moved, d.radius};
          t0 = threadSeconds();
          bp->update(after, which);
          s.update[f].push_back(threadSeconds() - t0);
          bp->findPairs(after, pairs);
          if (round == 0) s.pairsAfterUpdate[f] = pairs.size();
        }
      }
    }
    const Sample* reference = active.empty() ? nullptr : &samples[active.front()];
    for (const std::string& name : backends) {
      const Sample& s = samples[name];
      const bool ran = s.status == "ok";
      if (ran && reference && (s.pairs != reference->pairs || s.pairsAfterUpdate != reference->pairsAfterUpdate)) {
        agree = false;
        fmt::print(stderr, "MISMATCH: {} reports {} pairs, {} expected\n", name, s.pairs, reference->pairs);
      }
      const double perN = 1e6 / static_cast<double>(std::max<Index>(n, 1));
      csv << fmt::format("{},{},{:.6g},{:.4f},\"{}\",{},\"{}\"", path, n, rmax / rmin, packing, boundaries, name,
                         s.status);
      if (ran) {
        csv << fmt::format(",{:.5f},{:.5f}", perN * median(s.build), perN * median(s.find));
        for (std::size_t f = 0; f < fractions.size(); ++f) {
          const double movedCount = std::max(1.0, static_cast<double>(n) * fractions[f]);
          csv << fmt::format(",{:.5f},{:.5f}", perN * median(s.update[f]), 1e6 * median(s.update[f]) / movedCount);
        }
        csv << fmt::format(",{:.5f},{:.2f},{},\"{}\"\n", perN * (median(s.build) + median(s.find)),
                           static_cast<double>(s.bytes) / std::max<Index>(n, 1), s.pairs, s.description);
        fmt::print(stderr, "  {:<12} build {:.4f} find {:.4f} us/particle, {:.1f} B/particle\n", name,
                   perN * median(s.build), perN * median(s.find), static_cast<double>(s.bytes) / std::max<Index>(n, 1));
      } else {
        csv << ",,";
        for (std::size_t f = 0; f < fractions.size(); ++f) csv << ",,";
        csv << fmt::format(",,,{},\"\"\n", s.pairs);
      }
    }
  }
  if (!agree) {
    fmt::print(stderr, "backends disagree on the pair counts\n");
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {  // a bad backend name or an unreadable file: a message, not an abort
    fmt::print(stderr, "polydem_backends_report: {}\n", e.what());
    return 2;
  }
}
