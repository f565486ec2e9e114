// polydem analyze: contact network, rattlers, isostaticity, cumulative coordination Z(tau) and the pair
// correlation g(x) of a hard-sphere packing (e.g. one written by `polydem jam`).
#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <map>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/common.hpp"
#include "core/errors.hpp"
#include "core/io/particle_file.hpp"
#include "edmd/compression.hpp"
#include "edmd/contact_network.hpp"
#include "edmd/jamming_test.hpp"

namespace polydem::app {

namespace {

struct AnalyzeOptions {
  std::string input;
  double contactGap = 0.0;
  double pressure = 0.0;
  std::string broadPhase = "hgrid-td";
  std::string coordinationCsv;
  std::string correlationCsv;
  double correlationMax = 3.0;
  int correlationBins = 600;
  bool certify = false;
  Index removeSphere = -1;
  std::string motionCsv;
  double loadGap = 0.05;
  double displacementLimit = 1e-3;
  int loads = 2;
  bool skipIdeal = false;
};

void writeCsv(const std::string& path, const std::string& header, const std::vector<double>& a,
              const std::vector<double>& b) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) throw InputError(fmt::format("{}: cannot open for writing", path));
  fmt::print(f, "{}\n", header);
  for (std::size_t k = 0; k < a.size(); ++k) fmt::print(f, "{:.10g},{:.10g}\n", a[k], b[k]);
  std::fclose(f);
}

}  // namespace

Runner addAnalyze(CLI::App& app) {
  auto opt = std::make_shared<AnalyzeOptions>();
  CLI::App* cmd = app.add_subcommand(
      "analyze", "contact network, rattlers, isostaticity, Z(tau) and g(r) of a hard-sphere packing");
  cmd->add_option("input", opt->input, "particle file (.h5/.hdf5 or text)")->required();
  cmd->add_option("--contact-gap", opt->contactGap,
                  "contact when gap <= this x (r_i + r_j); 0 = from the reduced pressure (see --pressure)")
      ->capture_default_str();
  cmd->add_option("--pressure", opt->pressure,
                  "reduced pressure of the packing for the default contact gap (0 = the file's reduced_pressure "
                  "attribute, else 1e6)")
      ->capture_default_str();
  cmd->add_option("--broad-phase", opt->broadPhase, "broad phase for the pair searches")->capture_default_str();
  cmd->add_option("--z-csv", opt->coordinationCsv, "write Z(tau) for tau = 1e-15 .. 1e-1 (tau,Z)");
  cmd->add_option("--gr-csv", opt->correlationCsv, "write g(x), x = r_ij / (r_i + r_j) (x,g)");
  cmd->add_option("--gr-max", opt->correlationMax, "largest x of g(x)")->capture_default_str();
  cmd->add_option("--gr-bins", opt->correlationBins, "bins of g(x)")->capture_default_str();
  cmd->add_flag("--certify", opt->certify,
                "linear-programming test of collective jamming (GLPK): 'jammed' or an unjamming motion");
  cmd->add_option("--remove", opt->removeSphere,
                  "--certify: take this sphere out (e.g. a backbone sphere: a deliberately unjammed packing)");
  cmd->add_option("--load-gap", opt->loadGap,
                  "--certify: pairs with gap <= this x (r_i + r_j) are constraints of the load test")
      ->capture_default_str();
  cmd->add_option("--displacement-limit", opt->displacementLimit,
                  "--certify: a load moving a sphere further than this (mean diameters) unjams")
      ->capture_default_str();
  cmd->add_option("--loads", opt->loads, "--certify: random loads (each also applied reversed)")->capture_default_str();
  cmd->add_flag("--no-ideal", opt->skipIdeal, "--certify: skip the ideal-contact LP test");
  cmd->add_option("--motion-csv", opt->motionCsv, "write the unjamming motion (i,dx,dy,dz) if one is found");

  return [opt]() {
    const io::ParticleData data = io::readParticles(opt->input);
    const Index n = data.count();
    const SphereView spheres{data.position, data.radius};
    double pressure = opt->pressure;
    if (!(pressure > 0.0)) {
      const auto it = data.attributes.find("reduced_pressure");
      pressure = it != data.attributes.end() ? std::stod(it->second) : 1e6;
    }
    edmd::ContactOptions contact;
    contact.relativeGap = opt->contactGap > 0.0 ? opt->contactGap : edmd::defaultContactGap(pressure);
    contact.broadPhase = opt->broadPhase;
    const edmd::ContactNetwork net = edmd::analyseContacts(spheres, data.box, contact);
    double volume = 0.0;
    for (Index i = 0; i < n; ++i) volume += 4.0 / 3.0 * kPi * std::pow(data.radius[i], 3);
    const double phi = volume / data.box.volume();

    fmt::print("{}: {} spheres in a box {}, size ratio {:.4g}\n", opt->input, n, data.box.describe(),
               n ? data.radius.maxCoeff() / data.radius.minCoeff() : 0.0);
    fmt::print("packing fraction        {:.8f}\n", phi);
    fmt::print("reduced pressure        {:.4g}  (phi_J estimate {:.8f})\n", pressure,
               edmd::jammingDensityEstimate(phi, pressure));
    fmt::print("smallest gap            {:.3g} (relative; negative = overlap)\n", net.minGap);
    fmt::print("contacts (gap <= {:.1e}) {}  z = {:.4f}\n", contact.relativeGap, net.contacts.size(),
               net.meanCoordination());
    fmt::print("rattlers (< {} contacts)  {} ({:.2f}%)\n", contact.minContacts, n - net.backbone,
               100.0 * net.rattlerFraction());
    fmt::print("backbone                {} spheres, {} contacts, z = {:.4f}\n", net.backbone, net.backboneContacts,
               net.backboneCoordination());
    {
      const std::int64_t excess = net.isostaticExcess();
      fmt::print("isostaticity            contacts - (3N' {:+d}) = {} ({})\n", 1 - net.periodicAxes, excess,
                 excess == 0  ? "isostatic"
                 : excess < 0 ? "hypostatic: not collectively jammed"
                              : "hyperstatic");
    }
    std::map<int, Index> histogram;
    for (Index i = 0; i < n; ++i) {
      if (!net.rattler[static_cast<std::size_t>(i)]) ++histogram[net.coordination[static_cast<std::size_t>(i)]];
    }
    std::string hist;
    for (const auto& [z, count] : histogram) hist += fmt::format(" {}:{}", z, count);
    fmt::print("backbone contact numbers{}\n", hist);

    std::vector<double> taus;
    for (int e = -15; e <= -1; ++e) taus.push_back(std::pow(10.0, e));
    const std::vector<double> z = edmd::cumulativeCoordination(spheres, data.box, taus, opt->broadPhase);
    std::string line;
    for (std::size_t k = 0; k < taus.size(); ++k) line += fmt::format(" {:.0e}:{:.3f}", taus[k], z[k]);
    fmt::print("Z(tau), all spheres    {}\n", line);
    if (!opt->coordinationCsv.empty()) {
      writeCsv(opt->coordinationCsv, "tau,Z", taus, z);
      fmt::print("wrote {}\n", opt->coordinationCsv);
    }
    if (!opt->correlationCsv.empty()) {
      const edmd::PairCorrelation g =
          edmd::pairCorrelation(spheres, data.box, opt->correlationMax, opt->correlationBins, opt->broadPhase);
      writeCsv(opt->correlationCsv, "x,g", g.x, g.g);
      fmt::print("wrote {}\n", opt->correlationCsv);
    }
    if (opt->certify) {
      edmd::ContactNetwork tested = net;
      if (opt->removeSphere >= 0) {
        if (opt->removeSphere >= n) {
          throw ConfigError(fmt::format("--remove {}: the packing has {} spheres", opt->removeSphere, n));
        }
        // The sphere disappears from the test (no constraints from it); the rattlers stay those of the
        // intact packing, so its neighbours keep being tested.
        tested.rattler[static_cast<std::size_t>(opt->removeSphere)] = 1;
        fmt::print("removed sphere {} ({} contacts, {}) for the jamming test\n", opt->removeSphere,
                   net.coordination[static_cast<std::size_t>(opt->removeSphere)],
                   net.rattler[static_cast<std::size_t>(opt->removeSphere)] ? "a rattler" : "a backbone sphere");
      }
      if (!opt->skipIdeal) {
        const edmd::JammingTestResult ideal = edmd::testCollectiveJamming(spheres, data.box, tested);
        fmt::print("ideal-contact LP test   {} ({:.2f} s; LP optima: opening {:.3g}, floppy {:.3g})\n", ideal.verdict,
                   ideal.seconds, ideal.openingObjective, ideal.floppyObjective);
        std::fflush(stdout);
      }
      edmd::LoadTestOptions loadOptions;
      loadOptions.gapTolerance = opt->loadGap;
      loadOptions.displacementLimit = opt->displacementLimit;
      loadOptions.loads = opt->loads;
      if (opt->removeSphere >= 0) loadOptions.removed.push_back(opt->removeSphere);
      const edmd::LoadTestResult jam = edmd::testJammingUnderLoad(spheres, data.box, tested, loadOptions);
      fmt::print("jamming test (loads)    {} ({} constraints with gap <= {:.2g} (r_i + r_j), {:.2f} s)\n", jam.verdict,
                 jam.constraints, loadOptions.gapTolerance, jam.seconds);
      if (!jam.jammed && !opt->motionCsv.empty()) {
        std::FILE* f = std::fopen(opt->motionCsv.c_str(), "w");
        if (!f) throw InputError(fmt::format("{}: cannot open for writing", opt->motionCsv));
        fmt::print(f, "i,dx,dy,dz\n");
        for (Index i = 0; i < n; ++i) {
          fmt::print(f, "{},{:.10g},{:.10g},{:.10g}\n", i, jam.motion(0, i), jam.motion(1, i), jam.motion(2, i));
        }
        std::fclose(f);
        fmt::print("wrote {}\n", opt->motionCsv);
      }
    }
    return 0;
  };
}

}  // namespace polydem::app
