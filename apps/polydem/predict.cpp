// polydem predict: moments, equivalent mixtures, fluid equations of state and the jamming-density fits
// of Ogarko's thesis ch. 3 (Ogarko & Luding, J. Chem. Phys. 136 (2012) 124508) for a size distribution (or the radii of
// a particle file). No simulation.
#include <fmt/format.h>

#include <CLI/CLI.hpp>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/common.hpp"
#include "apps/polydem/validators.hpp"
#include "core/equivalent_mixture.hpp"
#include "core/errors.hpp"
#include "core/io/particle_file.hpp"
#include "core/moments.hpp"
#include "eos/eos.hpp"

namespace polydem::app {

namespace {

struct PredictOptions {
  DistributionSpec dist;
  std::string fractionKind = "volume";
  std::vector<double> phi = {0.3, 0.4, 0.5, 0.55, 0.6};
  std::string input;
  std::string givenDistributionOption;  ///< a distribution option given on the command line ("" if none)
};

void printMixture(const char* title, const Mixture& m, double mean) {
  fmt::print("{} ({} species):\n", title, m.size());
  fmt::print("  {:>12} {:>10} {:>12} {:>12} {:>12}\n", "radius", "a/<a>", "number frac", "volume frac", "delta_i");
  for (std::size_t i = 0; i < m.size(); ++i) {
    fmt::print("  {:>12.6g} {:>10.6g} {:>12.6g} {:>12.6g} {:>12.6g}\n", m.radius[i], m.radius[i] / mean,
               m.numberFraction[i], m.volumeFraction[i], m.numberFraction[i] * m.radius[i] / mean);
  }
  if (m.size() >= 2) fmt::print("  size ratio largest/smallest {:.6g}\n", m.radius.front() / m.radius.back());
}

/// Refuse --input together with distribution options, and packing fractions outside [0, 1).
void checkPredictOptions(PredictOptions& opt) {
  finishDistributionSpec(opt.dist, opt.fractionKind);
  if (!opt.input.empty() && !opt.givenDistributionOption.empty()) {
    throw ConfigError(
        fmt::format("{} conflicts with --input {}: the file's own radii define the distribution; "
                    "give either --input or the distribution options",
                    opt.givenDistributionOption, opt.input));
  }
  for (double phi : opt.phi) {
    if (!(phi >= 0.0 && phi < 1.0)) throw ConfigError(fmt::format("--phi: packing fraction {} is not in [0, 1)", phi));
  }
}

/// The moments of the file's radii (--input) or of the distribution; says which on stdout.
Moments loadMoments(const PredictOptions& opt) {
  if (!opt.input.empty()) {
    const io::ParticleData data = io::readParticles(opt.input);
    if (data.count() == 0) {
      throw InputError(fmt::format("{}: holds no particles: there are no radii to take moments of", opt.input));
    }
    fmt::print("radii of {} ({} particles)\n", opt.input, data.radius.size());
    return momentsOfSample(std::span<const double>(data.radius.data(), static_cast<std::size_t>(data.radius.size())));
  }
  const auto dist = makeDistribution(opt.dist);
  fmt::print("distribution: {} (analytic moments)\n", dist->describe());
  return momentsOf(*dist);
}

/// The compressibility factor of every equation of state at every --phi.
void reportEquationsOfState(const PredictOptions& opt, const Moments& m) {
  const eos::MomentRatios r = eos::ratiosOf(m);
  fmt::print("\ncompressibility factor Z = pV/(N kT) (CS and CSK are the monodisperse forms):\n  {:>6}", "phi");
  for (eos::Form f : eos::kAllForms) fmt::print(" {:>9}", eos::formName(f));
  fmt::print("\n");
  for (double phi : opt.phi) {
    fmt::print("  {:>6.4f}", phi);
    for (eos::Form f : eos::kAllForms) fmt::print(" {:>9.5f}", eos::z(f, phi, r));
    fmt::print("\n");
  }
}

/// `polydem predict`: check, load the moments, report mixtures, equations of state and jamming fits.
int runPredict(PredictOptions& opt) {
  checkPredictOptions(opt);
  const Moments m = loadMoments(opt);
  fmt::print("{}\n", m.describe());
  fmt::print("bounds O1^2 <= O2 <= O1: {:.6g} <= {:.6g} <= {:.6g}\n\n", m.o1 * m.o1, m.o2, m.o1);
  printMixture("equivalent bidisperse mixture (matches <a>..<a^3>; eqs. 3.20-3.21)", equivalentBidisperse(m), m.mean());
  printMixture("maximally equivalent tridisperse mixture (matches <a>..<a^5>)", equivalentTridisperse(m), m.mean());
  reportEquationsOfState(opt, m);
  fmt::print("\npredicted jamming density (fits to the seed's own compressions):\n");
  for (const eos::JammingPrediction& p : eos::predictJamming(opt.dist, m)) {
    if (!opt.input.empty() && p.equation.rfind("eq. 3.53", 0) != 0) continue;  // families need --dist
    fmt::print("  {:.4f}  {}  [{}]\n", p.value, p.equation, p.note);
  }
  return 0;
}

}  // namespace

Runner addPredict(CLI::App& app) {
  auto opt = std::make_shared<PredictOptions>();
  CLI::App* cmd = app.add_subcommand(
      "predict", "moments, equivalent bi/tridisperse mixtures, fluid EOS and jamming-density fits of a distribution");
  addDistributionOptions(*cmd, opt->dist, opt->fractionKind);
  cmd->add_option("--phi", opt->phi, "packing fractions at which to evaluate the equations of state, in [0, 1)")
      ->delimiter(',')
      ->check(finiteIn(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("-i,--input", opt->input,
                  "use the radii of this particle file instead of a distribution (no --dist or its options)");

  return [opt, cmd]() {
    opt->givenDistributionOption = firstGivenOption(*cmd, distributionOptionNames());
    return runPredict(*opt);
  };
}

}  // namespace polydem::app
