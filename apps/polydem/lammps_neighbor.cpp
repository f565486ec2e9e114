// polydem lammps-neighbor: the `neighbor ... multi`, `neigh_modify collection/interval` and `comm_modify` lines
// a LAMMPS user should use for a particle file's size distribution, chosen by the HGrid cost model.
//
// Correspondence (LAMMPS `neighbor multi`, Shire, Hanley & Stratford, Comp. Part. Mech. (2021), as
// documented for neigh_modify collection/interval): an atom of a finite-size pair style (granular,
// gran/hooke) has the cutoff 2 r (its diameter) and belongs to the first collection whose upper bound c_h is
// >= 2 r (LAMMPS stops with "Atom cutoff exceeds interval cutoffs" when no bound is). Collections i, j
// interact within c_i / 2 + c_j / 2 + skin; each collection has its own bins; with a half list an atom
// searches its own collection's bins and the bins of every larger collection, never a smaller one. That is
// the Bottom-Up HGrid (Ogarko & Luding, Comput. Phys. Commun. 183 (2012) 931): level h holds the particles
// with interaction diameter 2 r + skin in (s_{h-1}, s_h] and searches its own and the coarser levels. So
// collection h <-> level h with c_h = s_h - skin (polydem's skin is LAMMPS's: pairs within r_i + r_j + skin).
// The model counts cubic cells of edge s_h with a 3^3 neighbourhood: K per cell access plus one per pair test
// in a searched volume 27 s^3. LAMMPS bins are half the collection's cutoff with a 5^3 stencil: 125 bin
// accesses and a searched volume 125 (s/2)^3 = (125/216) 27 s^3. Dividing by 125/216 gives the model's form
// with K * 125 * 216 / (125 * 27) = 8 K per cell access: the collections are chosen with 8 K
// (kLammpsBinFactor). Measured (docs/lammps.md): with the unscaled K the optimiser picks more collections,
// which cost LAMMPS 3-10% at size ratios 10-50; with 8 K its choice beats the doubling set at every ratio.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <string>
#include <vector>

#include "apps/polydem/commands.hpp"
#include "apps/polydem/common.hpp"
#include "apps/polydem/validators.hpp"
#include "broadphase/hgrid_cost_model.hpp"
#include "core/errors.hpp"
#include "core/io/particle_io.hpp"

namespace polydem::app {

namespace {

/// Cell-access cost of a LAMMPS bin stencil relative to the model's 3^3 cells (see the header comment).
constexpr double kLammpsBinFactor = 8.0;

struct LammpsNeighborOptions {
  std::string file;
  double skin = -1.0;  ///< < 0: not given (0.1 of the smallest diameter)
  std::string pair = "granular";
  std::string format = "text";
  double costRatio = broadphase::kDefaultCellOverPairCost;
  int maxLevels = 30;
};

/// `value` printed with 9 significant digits, rounded so the printed number is >= value (a collection
/// bound below a diameter it must hold would make LAMMPS stop).
std::string boundAtLeast(double value) {
  double v = value;
  for (int attempt = 0; attempt < 8; ++attempt) {
    std::string text = fmt::format("{:.9g}", v);
    double parsed = 0.0;
    std::from_chars(text.data(), text.data() + text.size(), parsed);
    if (parsed >= value) return text;
    v = value * (1.0 + 1e-9 * (attempt + 1));
  }
  return fmt::format("{}", value);  // shortest round-trip form: exactly value
}

double parsed(const std::string& text) {
  double v = 0.0;
  std::from_chars(text.data(), text.data() + text.size(), v);
  return v;
}

/// A set of collections: printed bounds c_1 < ... < c_N and the model's prediction for them.
struct Collections {
  std::vector<std::string> bounds;  ///< as printed
  std::vector<double> cellSizes;    ///< s_h = c_h + skin (the HGrid levels the model evaluates)
  std::vector<long> counts;         ///< particles per collection
  double predicted = 0.0;           ///< T/N, Bottom-Up
};

/// Collections from upper diameter bounds (ascending, the last >= the largest diameter).
Collections makeCollections(const std::vector<double>& upperDiameters, const std::vector<double>& sortedDiameters,
                            const broadphase::CostModelPsd& psd, double skin, double K) {
  Collections c;
  for (std::size_t h = 0; h < upperDiameters.size(); ++h) {
    const bool last = h + 1 == upperDiameters.size();
    std::string text = last ? boundAtLeast(upperDiameters[h]) : fmt::format("{:.9g}", upperDiameters[h]);
    if (!c.bounds.empty() && parsed(text) <= parsed(c.bounds.back())) continue;  // equal after rounding: empty
    c.bounds.push_back(text);
  }
  double lower = 0.0;
  for (const std::string& b : c.bounds) {
    const double upper = parsed(b);
    c.cellSizes.push_back(upper + skin);
    const auto lo = std::upper_bound(sortedDiameters.begin(), sortedDiameters.end(), lower);
    const auto hi = std::upper_bound(sortedDiameters.begin(), sortedDiameters.end(), upper);
    c.counts.push_back(static_cast<long>(hi - lo));
    lower = upper;
  }
  c.predicted = broadphase::costPerParticle(psd, c.cellSizes, broadphase::CrossLevel::BottomUp, K);
  return c;
}

/// The collections a LAMMPS user writes by hand: bounds doubling from twice the smallest diameter, the last
/// the largest diameter (as benchmarks/lammps/polydem_to_lammps.py --collections).
std::vector<double> doublingBounds(double dmin, double dmax) {
  std::vector<double> out;
  for (double c = 2.0 * dmin; c < dmax; c *= 2.0) out.push_back(c);
  out.push_back(dmax);
  return out;
}

std::string joined(const std::vector<std::string>& items) {
  std::string out;
  for (const std::string& s : items) out += (out.empty() ? "" : " ") + s;
  return out;
}

int runLammpsNeighbor(const LammpsNeighborOptions& opt) {
  if (opt.pair != "granular" && opt.pair != "gran/hooke") {
    throw ConfigError(fmt::format("--pair must be granular or gran/hooke, got '{}'", opt.pair));
  }
  if (opt.format != "text" && opt.format != "lines") {
    throw ConfigError(fmt::format("--format must be text or lines, got '{}'", opt.format));
  }
  const io::ParticleData data = io::readParticles(opt.file, parseBoundaries("periodic"));
  if (data.count() == 0) throw InputError(fmt::format("{}: no particles", opt.file));
  const std::vector<double> radii(data.radius.data(), data.radius.data() + data.radius.size());
  std::vector<double> diameters(radii);
  for (double& d : diameters) d *= 2.0;
  std::sort(diameters.begin(), diameters.end());
  const double dmin = diameters.front(), dmax = diameters.back();
  if (!(dmin > 0.0) || !std::isfinite(dmax)) {
    throw InputError(fmt::format("{}: radii must be positive and finite (smallest diameter {})", opt.file, dmin));
  }
  const double skin = opt.skin < 0.0 ? 0.1 * dmin : opt.skin;
  const double K = kLammpsBinFactor * opt.costRatio;
  const auto psd = broadphase::CostModelPsd::sample(radii, data.box.volume(), skin);

  // The optimiser restricted to Bottom-Up (what LAMMPS multi does), fewest levels within 1% of the best.
  broadphase::OptimiserOptions options;
  options.maxLevels = opt.maxLevels;
  options.K = K;
  options.mode = broadphase::CrossLevel::BottomUp;
  const broadphase::OptimiserResult result = broadphase::optimiseHGrid(psd, options);
  std::vector<double> chosenBounds;
  if (result.chosen.linkedCell) {
    chosenBounds.push_back(dmax);
  } else {
    for (double s : result.chosen.config.cellSizes) chosenBounds.push_back(std::max(s - skin, 0.0));
    chosenBounds.back() = dmax;  // the top level holds the largest sphere: its bound is its diameter
  }
  const Collections optimised = makeCollections(chosenBounds, diameters, psd, skin, K);
  const Collections doubling = makeCollections(doublingBounds(dmin, dmax), diameters, psd, skin, K);
  // The optimiser keeps the fewest levels within 1% of its best and at most --max-levels, so doubling can
  // come out cheaper: then doubling is the recommendation (never predicted dearer than the hand-made set).
  const bool doublingWins = doubling.predicted < optimised.predicted;
  const Collections& chosen = doublingWins ? doubling : optimised;

  const std::string skinText = fmt::format("{:.9g}", skin);
  const std::vector<std::string> lines = {
      fmt::format("neighbor {} multi", skinText),
      fmt::format("neigh_modify delay 0 every 1 check yes collection/interval {} {}", chosen.bounds.size(),
                  joined(chosen.bounds)),
      "comm_modify mode multi reduce/multi",
  };
  if (opt.format == "lines") {
    for (const std::string& l : lines) fmt::print("{}\n", l);
    return 0;
  }
  // Text: a LAMMPS include file, the report as comments.
  fmt::print("# polydem lammps-neighbor {}: {} particles, diameters {:.6g} .. {:.6g} (ratio {:.4g}), skin {}\n",
             opt.file, data.count(), dmin, dmax, dmax / dmin, skinText);
  fmt::print("# pair_style {}: per-atom cutoff = diameter; collections i, j interact within c_i/2 + c_j/2 + skin\n",
             opt.pair);
  fmt::print(
      "# cost model (Bottom-Up HGrid, K = {:.3g} x {:g} for LAMMPS' 5^3 stencil of half-cutoff bins = {:.3g}): level h "
      "<-> collection h, s_h = c_h + skin\n",
      opt.costRatio, kLammpsBinFactor, K);
  if (doublingWins) {
    fmt::print(
        "# the doubling collections are predicted cheaper ({:.6g}) than the optimiser's choice ({} level{}, "
        "{:.6g}): chosen\n",
        doubling.predicted, optimised.bounds.size(), optimised.bounds.size() == 1 ? "" : "s", optimised.predicted);
  }
  for (const std::string& l : lines) fmt::print("{}\n", l);
  auto table = [&](const char* name, const Collections& c) {
    fmt::print("# {}: {} collection{}, predicted cost {:.6g} per particle\n", name, c.bounds.size(),
               c.bounds.size() == 1 ? "" : "s", c.predicted);
    double lower = 0.0;
    for (std::size_t h = 0; h < c.bounds.size(); ++h) {
      const double upper = parsed(c.bounds[h]);
      fmt::print("#   c_{} = {}: diameters ({:.6g}, {:.6g}], {} particles, bins {:.6g}\n", h + 1, c.bounds[h], lower,
                 upper, c.counts[h], 0.5 * (upper + skin));
      lower = upper;
    }
  };
  table("chosen", chosen);
  table("hand-made doubling", doubling);
  fmt::print("# predicted doubling / chosen = {:.4g}\n", doubling.predicted / chosen.predicted);
  if (chosen.bounds.size() == 1) fmt::print("# one collection: `neighbor {} bin` does the same search\n", skinText);
  fmt::print(
      "# neigh_modify: checked every step, rebuilt when an atom has moved skin/2 (polydem's rule): safe for\n"
      "# any flow; `every M` > 1 is only safe if the log shows 0 dangerous builds\n");
  return 0;
}

}  // namespace

Runner addLammpsNeighbor(CLI::App& app) {
  auto opt = std::make_shared<LammpsNeighborOptions>();
  CLI::App* cmd = app.add_subcommand(
      "lammps-neighbor", "LAMMPS neighbor multi / collection/interval / comm_modify lines for a particle file");
  cmd->add_option("file", opt->file, "particle file (text, .h5, LAMMPS data or dump)")->required();
  cmd->add_option("--skin", opt->skin, "LAMMPS neighbor skin (default: 0.1 of the smallest diameter)")
      ->check(finiteNonNegative());
  cmd->add_option("--pair", opt->pair, "pair style: granular or gran/hooke")->capture_default_str();
  cmd->add_option("--format", opt->format, "text (LAMMPS lines, report as comments) or lines (lines only)")
      ->capture_default_str();
  cmd->add_option("--cost-ratio", opt->costRatio,
                  "cell access / pair test cost ratio K of the HGrid model (scaled by 8 for LAMMPS' bin stencil)")
      ->check(finitePositive())
      ->capture_default_str();
  cmd->add_option("--max-levels", opt->maxLevels, "most collections the optimiser tries")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  return [opt]() { return runLammpsNeighbor(*opt); };
}

}  // namespace polydem::app
