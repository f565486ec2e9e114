// polydem analyze: the contact network of a hard-sphere packing and its statistics (contacts, rattlers,
// isostaticity, cumulative coordination Z(tau), pair correlation g(x)).
//
// The input must be a valid hard-sphere packing (jamming::requireHardSpherePacking: no overlap beyond the
// contact tolerance, no density above what any packing of its radii can have); the contact tolerance
// comes from the packing's reduced pressure, which is never assumed (the file's attribute, --pressure or
// --contact-gap); quantities that do not exist for the input (no spheres, an empty backbone) are printed
// as "undefined" with the reason, never as nan or as a vacuous verdict.
#include <fmt/format.h>

#include <cmath>
#include <limits>
#include <map>

#include "apps/polydem/analyze.hpp"
#include "apps/polydem/summary.hpp"
#include "core/errors.hpp"
#include "core/io/attributes.hpp"
#include "core/io/safe_output.hpp"
#include "edmd/compression.hpp"

namespace polydem::app::analyze {

namespace {

/// The packing's reduced pressure: --pressure, else the file's `reduced_pressure` attribute; nullopt if
/// neither (then only --contact-gap can set the contact tolerance). Throws InputError for a malformed or
/// non-positive attribute.
std::optional<double> packingPressure(const AnalyzeOptions& opt, const io::ParticleData& data) {
  if (opt.pressure > 0.0) return opt.pressure;
  const std::optional<double> p = io::numericAttribute(data, "reduced_pressure", opt.input);
  if (p && !(*p > 0.0)) {
    throw InputError(
        fmt::format("{}: attribute reduced_pressure: {} is not a positive reduced pressure; give "
                    "--pressure P (or --contact-gap TAU)",
                    opt.input, *p));
  }
  return p;
}

}  // namespace

std::string csvText(const std::string& header, const std::vector<double>& a, const std::vector<double>& b) {
  std::string text = header + "\n";
  for (std::size_t k = 0; k < a.size(); ++k) text += fmt::format("{:.10g},{:.10g}\n", a[k], b[k]);
  return text;
}

double solidVolume(const io::ParticleData& data) {
  double volume = 0.0;
  for (Index i = 0; i < data.count(); ++i) volume += 4.0 / 3.0 * kPi * std::pow(data.radius[i], 3);
  return volume;
}

void printHeader(const AnalyzeOptions& opt, const io::ParticleData& data) {
  const Index n = data.count();
  fmt::print("{}: {} spheres in a box {}, size ratio {}\n", opt.input, n, data.box.describe(),
             n ? fmt::format("{:.4g}", data.radius.maxCoeff() / data.radius.minCoeff())
               : std::string("undefined (no spheres)"));
  fmt::print("packing fraction        {:.8f}\n", solidVolume(data) / data.box.volume());
  SummaryJson& s = summary();
  s.put("input.file", opt.input);
  s.put("input.spheres", static_cast<std::int64_t>(n));
  s.put("input.box", data.box.describe());
  if (n) {
    s.put("input.size_ratio", data.radius.maxCoeff() / data.radius.minCoeff());
  } else {
    s.undefined("input.size_ratio", "no spheres");
  }
  s.put("packing.packing_fraction", solidVolume(data) / data.box.volume());
}

ContactAnalysis computeContacts(const AnalyzeOptions& opt, const io::ParticleData& data) {
  const SphereView spheres{data.position, data.radius};
  // The contact tolerance rests on the pressure, which is never assumed.
  ContactAnalysis out;
  out.pressure = packingPressure(opt, data);
  const std::optional<double>& pressure = out.pressure;
  if (!pressure && !(opt.contactGap > 0.0)) {
    throw ConfigError(fmt::format(
        "{} has no reduced_pressure attribute, and the contact network (contacts, rattlers, isostaticity, "
        "--certify, --leak-test) needs the contact gap it implies: give --pressure P (the packing's reduced "
        "pressure) or --contact-gap TAU (contact when gap <= TAU (r_i + r_j)), or --structure-only",
        opt.input));
  }
  jamming::ContactOptions& contact = out.contact;
  contact.relativeGap = opt.contactGap > 0.0 ? opt.contactGap : jamming::defaultContactGap(*pressure);
  contact.broadPhase = opt.broadPhase;
  out.validity = jamming::requireHardSpherePacking(
      spheres, data.box, {.overlapTolerance = contact.relativeGap, .broadPhase = opt.broadPhase}, opt.input, data.id);
  // Contacts are found by the minimum image; a periodic length below 2 (2 r_max + gap) would let a sphere
  // touch two images of another, which the search cannot represent.
  out.net = [&] {
    try {
      return jamming::analyseContacts(spheres, data.box, contact);
    } catch (const ConfigError& e) {
      throw InputError(fmt::format("{}: the box is too small for the contact network: {}", opt.input, e.what()));
    }
  }();
  return out;
}

void reportContacts(const AnalyzeOptions& opt, const io::ParticleData& data, const ContactAnalysis& contacts) {
  const SphereView spheres{data.position, data.radius};
  const Index n = data.count();
  const std::optional<double>& pressure = contacts.pressure;
  const jamming::ContactOptions& contact = contacts.contact;
  const jamming::PackingValidity& validity = contacts.validity;
  const jamming::ContactNetwork& net = contacts.net;
  const double phi = solidVolume(data) / data.box.volume();

  printHeader(opt, data);
  summary().put("packing.density_bound", validity.densityBound);
  fmt::print("density bound           {:.8f} ({}); no overlap beyond the contact tolerance\n", validity.densityBound,
             validity.equalSpheres         ? "FCC, equal spheres"
             : validity.densityBound < 1.0 ? "pi/sqrt(18) <r^3>/r_min^3"
                                           : "1, disjoint spheres");
  if (pressure) {
    const std::string source = opt.pressure > 0.0 ? "--pressure" : "file attribute";
    const std::string estimate =
        net.backbone == 0 ? std::string("phi_J estimate undefined: empty backbone, not near jamming")
        : *pressure > 3.0 ? fmt::format("phi_J estimate {:.8f}", edmd::jammingDensityEstimate(phi, *pressure))
                          : std::string("phi_J estimate undefined: needs p > 3");
    fmt::print("reduced pressure        {:.4g} ({})  ({})\n", *pressure, source, estimate);
    summary().put("packing.reduced_pressure", *pressure);
    summary().put("packing.reduced_pressure_source", source);
    if (net.backbone != 0 && *pressure > 3.0) {
      summary().put("packing.phi_j_estimate", edmd::jammingDensityEstimate(phi, *pressure));
    } else {
      summary().undefined("packing.phi_j_estimate", net.backbone == 0 ? "empty backbone" : "needs p > 3");
    }
  } else {
    summary().undefined("packing.reduced_pressure", "no reduced_pressure attribute, no --pressure");
    summary().undefined("packing.phi_j_estimate", "reduced pressure unknown");
    fmt::print(
        "reduced pressure        unknown (no reduced_pressure attribute, no --pressure): phi_J estimate "
        "undefined\n");
  }
  const std::optional<jamming::PairGap> gap = jamming::smallestGap(spheres, data.box, opt.broadPhase);
  auto id = [&](Index i) { return data.id.empty() ? i : data.id[static_cast<std::size_t>(i)]; };
  if (gap) {
    fmt::print("smallest gap            {:.3g} (relative to r_i + r_j; negative = overlap), spheres {} and {}\n",
               gap->gap, id(gap->i), id(gap->j));
    summary().put("packing.smallest_gap.relative_gap", gap->gap);
    summary().put("packing.smallest_gap.ids", std::vector<std::int64_t>{id(gap->i), id(gap->j)});
  } else {
    fmt::print("smallest gap            undefined (fewer than two spheres)\n");
    summary().undefined("packing.smallest_gap", "fewer than two spheres");
  }
  fmt::print("contacts (gap <= {:.1e}) {}  z = {}\n", contact.relativeGap, net.contacts.size(),
             n ? fmt::format("{:.4f}", net.meanCoordination()) : std::string("undefined (no spheres)"));
  fmt::print("rattlers (< {} contacts)  {} ({})\n", contact.minContacts, n - net.backbone,
             n ? fmt::format("{:.2f}%", 100.0 * net.rattlerFraction()) : std::string("undefined: no spheres"));
  fmt::print(
      "backbone                {} spheres, {} contacts, z = {}\n", net.backbone, net.backboneContacts,
      net.backbone ? fmt::format("{:.4f}", net.backboneCoordination()) : std::string("undefined (empty backbone)"));
  SummaryJson& s = summary();
  s.put("contacts.relative_gap", contact.relativeGap);
  s.put("contacts.count", static_cast<std::int64_t>(net.contacts.size()));
  s.put("contacts.min_contacts_backbone", contact.minContacts);
  s.put("contacts.rattlers", static_cast<std::int64_t>(n - net.backbone));
  s.put("contacts.backbone_spheres", static_cast<std::int64_t>(net.backbone));
  s.put("contacts.backbone_contacts", static_cast<std::int64_t>(net.backboneContacts));
  if (n) {
    s.put("contacts.z", net.meanCoordination());
    s.put("contacts.rattler_fraction", net.rattlerFraction());
  } else {
    s.undefined("contacts.z", "no spheres");
    s.undefined("contacts.rattler_fraction", "no spheres");
  }
  if (net.backbone) {
    s.put("contacts.backbone_z", net.backboneCoordination());
    s.put("contacts.isostatic_excess", net.isostaticExcess());
  } else {
    s.undefined("contacts.backbone_z", "empty backbone");
    s.undefined("contacts.isostatic_excess", "empty backbone");
  }
  if (net.backbone == 0) {
    fmt::print("isostaticity            undefined (empty backbone: every sphere is a rattler)\n");
  } else {
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
  fmt::print("backbone contact numbers{}\n", hist.empty() ? " none (empty backbone)" : hist);
  std::vector<std::int64_t> zs, counts;
  for (const auto& [z, count] : histogram) {
    zs.push_back(z);
    counts.push_back(count);
  }
  s.put("contacts.backbone_histogram.contact_number", zs);
  s.put("contacts.backbone_histogram.spheres", counts);

  if (n == 0) {
    fmt::print("Z(tau), all spheres     undefined (no spheres)\n");
  } else {
    // tau up to 0.1, as far as the minimum image reaches on periodic axes: tau 2 r_max <= L / 2 - 2 r_max.
    double periodicMin = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 3; ++k) {
      if (data.box.periodic(k)) periodicMin = std::min(periodicMin, data.box.length(k));
    }
    const double rmax = data.radius.maxCoeff();
    const double tauLimit = (periodicMin / 2.0 - 2.0 * rmax) / (2.0 * rmax * (1.0 + 1e-9));
    std::vector<double> taus;
    for (int e = -15; e <= -1; ++e) {
      if (std::pow(10.0, e) <= tauLimit) taus.push_back(std::pow(10.0, e));
    }
    const std::vector<double> z = jamming::cumulativeCoordination(spheres, data.box, taus, opt.broadPhase);
    std::string line;
    for (std::size_t k = 0; k < taus.size(); ++k) line += fmt::format(" {:.0e}:{:.3f}", taus[k], z[k]);
    if (taus.size() < 15) {
      line += taus.empty()
                  ? std::string(" undefined (the box is too small for gaps of 1e-15)")
                  : fmt::format("; undefined above tau = {:.0e} (gaps beyond half the box length)", taus.back());
    }
    fmt::print("Z(tau), all spheres    {}\n", line);
    s.put("cumulative_coordination.tau", taus);
    s.put("cumulative_coordination.z", z);
    if (!opt.coordinationCsv.empty()) {
      io::writeFileAtomically(opt.coordinationCsv, csvText("tau,Z", taus, z));
      fmt::print("wrote {}\n", opt.coordinationCsv);
    }
  }
  if (!opt.correlationCsv.empty()) {
    const jamming::PairCorrelation g =
        jamming::pairCorrelation(spheres, data.box, opt.correlationMax, opt.correlationBins, opt.broadPhase);
    io::writeFileAtomically(opt.correlationCsv, csvText("x,g", g.x, g.g));
    fmt::print("wrote {}\n", opt.correlationCsv);
  }
}

}  // namespace polydem::app::analyze
