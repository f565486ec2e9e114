// Size distributions (core/size_distribution.hpp), moments and equivalent mixtures (core/moments.hpp,
// core/equivalent_mixture.hpp), start packings (core/initial_configuration.hpp) and `predict` (eos/).
#include "python/distributions.hpp"

#include <fmt/format.h>
#include <pybind11/stl.h>

#include <cmath>
#include <memory>

#include "core/equivalent_mixture.hpp"
#include "core/errors.hpp"
#include "core/initial_configuration.hpp"
#include "core/moments.hpp"
#include "core/size_distribution.hpp"
#include "eos/eos.hpp"
#include "python/convert.hpp"

namespace polydem::python {

namespace {

Sampling samplingFrom(const std::string& name) {
  if (name == "systematic") return Sampling::Systematic;
  if (name == "random") return Sampling::Random;
  throw ConfigError(fmt::format("sampling '{}': expected systematic or random", name));
}

py::object finiteOrNone(double x) { return std::isfinite(x) ? py::object(py::float_(x)) : py::object(py::none()); }

py::list listOf(const std::array<double, 6>& a) {
  py::list l;
  for (double x : a) l.append(x);
  return l;
}

py::dict mixtureDict(const Mixture& mix) {
  py::dict d;
  d["radius"] = mix.radius;
  d["number_fraction"] = mix.numberFraction;
  d["volume_fraction"] = mix.volumeFraction;
  d["description"] = mix.describe();
  return d;
}

Configuration place(const py::handle& radii, double phi, const py::handle& aspect, const py::handle& boundaries,
                    std::uint64_t seed, std::int64_t maxAttempts, bool overlapping) {
  PackingRequest request;
  const Eigen::VectorXd r = toVector(radii, "radii");
  request.radii.assign(r.data(), r.data() + r.size());
  request.packingFraction = phi;
  const Eigen::VectorXd a = toVector(aspect, "aspect");
  if (a.size() != 3) throw ConfigError(fmt::format("aspect: expected three edge ratios, got {}", a.size()));
  request.aspect = Eigen::Vector3d(a[0], a[1], a[2]);
  request.boundaries = boundariesFrom(boundaries);
  request.seed = seed;
  request.maxAttemptsPerParticle = maxAttempts;
  py::gil_scoped_release release;
  return overlapping ? randomOverlapping(request) : randomSequentialAddition(request);
}

py::dict configurationDict(const Configuration& c) {
  py::dict d;
  d["positions"] = copyOut(c.position);
  d["radii"] = copyOut(c.radius);
  d["box"] = py::cast(c.box);
  return d;
}

}  // namespace

py::dict momentsDict(const Moments& m) {
  py::dict d;
  d["raw"] = listOf(m.raw);
  d["scaled"] = listOf(m.scaled);
  d["central"] = listOf(m.central);
  d["mean"] = m.mean();
  d["o1"] = m.o1;
  d["o2"] = m.o2;
  d["delta"] = m.delta;
  d["A"] = m.a;
  d["kurtosis"] = m.monodisperse() ? py::object(py::none()) : finiteOrNone(m.kurtosis);  // undefined: one radius
  d["monodisperse"] = m.monodisperse();
  if (m.distinctRadii > 0) d["distinct_radii"] = m.distinctRadii;
  d["description"] = m.describe();
  return d;
}

DistributionSpec specFrom(const std::string& kind, double rmin, double omega, double alpha, double sigma, double median,
                          double largeFraction, const std::string& fractionKind) {
  DistributionSpec s;
  s.kind = kind;
  s.rmin = rmin;
  s.omega = omega;
  s.alpha = alpha;
  s.sigma = sigma;
  s.median = median;
  s.largeFraction = largeFraction;
  if (fractionKind == "volume") {
    s.fractionKind = FractionKind::Volume;
  } else if (fractionKind == "number") {
    s.fractionKind = FractionKind::Number;
  } else {
    throw ConfigError(fmt::format("fraction_kind '{}': expected volume or number", fractionKind));
  }
  return s;
}

Distribution::Distribution(const DistributionSpec& spec) : spec_(spec), distribution_(makeDistribution(spec)) {}

void bindDistributions(py::module_& m) {
  py::class_<Distribution, std::shared_ptr<Distribution>>(
      m, "Distribution",
      "A particle size distribution, built as `polydem --dist ...` builds it (core/size_distribution.hpp).")
      .def(py::init([](const std::string& kind, double rmin, double omega, double alpha, double sigma, double median,
                       double largeFraction, const std::string& fractionKind) {
             return std::make_shared<Distribution>(
                 specFrom(kind, rmin, omega, alpha, sigma, median, largeFraction, fractionKind));
           }),
           py::arg("kind") = "mono", py::arg("rmin") = 1.0, py::arg("omega") = 1.0, py::arg("alpha") = 0.0,
           py::arg("sigma") = 0.5, py::arg("median") = 1.0, py::arg("large_fraction") = 0.5,
           py::arg("fraction_kind") = "volume",
           "kind: mono, bi, uniform-radius (us), uniform-volume (uv), power-law, log-normal (ln); the other "
           "arguments as the CLI's --rmin, --omega, --alpha, --sigma, --median, --large-fraction, --fraction-kind")
      .def_property_readonly("kind", [](const Distribution& d) { return d.spec().kind; })
      .def_property_readonly("min_radius", [](const Distribution& d) { return d.get().minRadius(); })
      .def_property_readonly("max_radius", [](const Distribution& d) { return d.get().maxRadius(); })
      .def("describe", [](const Distribution& d) { return d.get().describe(); })
      .def("__repr__", [](const Distribution& d) { return "polydem.Distribution(" + d.get().describe() + ")"; })
      .def(
          "cdf", [](const Distribution& d, double r) { return d.get().cdf(r); }, py::arg("r"))
      .def(
          "quantile", [](const Distribution& d, double q) { return d.get().quantile(q); }, py::arg("q"))
      .def(
          "moment", [](const Distribution& d, int k) { return d.get().moment(k); }, py::arg("k"), "<r^k>, analytic")
      .def(
          "partial_moment",
          [](const Distribution& d, int k, double a, double b) { return d.get().partialMoment(k, a, b); }, py::arg("k"),
          py::arg("a"), py::arg("b"))
      .def(
          "sample",
          [](const Distribution& d, Index count, const std::string& sampling, std::uint64_t seed) {
            const Sampling s = samplingFrom(sampling);
            std::vector<double> r;
            {
              py::gil_scoped_release release;
              r = d.get().sample(count, s, seed);
            }
            return copyOut(Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(r.data(), static_cast<Index>(r.size()))));
          },
          py::arg("count"), py::arg("sampling") = "systematic", py::arg("seed") = 1,
          "N radii (float64): systematic (ascending) or random (draw order), std::mt19937_64(seed)")
      .def(
          "moments", [](const Distribution& d) { return momentsDict(momentsOf(d.get())); }, "analytic moments")
      .def(
          "equivalent_mixture",
          [](const Distribution& d, int nodes) { return mixtureDict(gaussMixture(momentsOf(d.get()), nodes)); },
          py::arg("nodes") = 2, "nodes = 2: equivalent bidisperse mixture; 3: maximally equivalent tridisperse");

  m.def(
      "sample_moments",
      [](const py::handle& radii) {
        const Eigen::VectorXd r = toVector(radii, "radii");
        return momentsDict(momentsOfSample(std::span<const double>(r.data(), static_cast<std::size_t>(r.size()))));
      },
      py::arg("radii"), "moments of a sample of radii");
  m.def(
      "equivalent_mixture",
      [](const py::handle& radii, int nodes) {
        const Eigen::VectorXd r = toVector(radii, "radii");
        return mixtureDict(gaussMixture(
            momentsOfSample(std::span<const double>(r.data(), static_cast<std::size_t>(r.size()))), nodes));
      },
      py::arg("radii"), py::arg("nodes") = 2, "equivalent mixture of a sample of radii (nodes 1..3)");
  m.def(
      "mixture_radii",
      [](const py::dict& mixture, Index count) {
        const Mixture mix = makeMixture(mixture["radius"].cast<std::vector<double>>(),
                                        mixture["number_fraction"].cast<std::vector<double>>());
        const std::vector<double> r = mixtureRadii(mix, count);
        return copyOut(Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(r.data(), static_cast<Index>(r.size()))));
      },
      py::arg("mixture"), py::arg("count"), "count radii realising a mixture dict (largest remainders)");

  m.def(
      "start_packing",
      [](const Distribution& d, Index count, double phi, const py::handle& aspect, const py::handle& boundaries,
         std::uint64_t seed, const std::string& sampling, const std::string& placement, const py::object& radii) {
        StartPackingRequest request;
        request.count = count;
        request.sampling = samplingFrom(sampling);
        if (!radii.is_none()) {
          const Eigen::VectorXd r = toVector(radii, "radii");
          request.radii.assign(r.data(), r.data() + r.size());
        }
        request.packingFraction = phi;
        const Eigen::VectorXd a = toVector(aspect, "aspect");
        if (a.size() != 3) throw ConfigError(fmt::format("aspect: expected three edge ratios, got {}", a.size()));
        request.aspect = Eigen::Vector3d(a[0], a[1], a[2]);
        request.boundaries = boundariesFrom(boundaries);
        request.seed = seed;
        if (placement == "rsa") {
          request.placement = Placement::RandomSequentialAddition;
        } else if (placement == "overlapping") {
          request.placement = Placement::RandomOverlapping;
        } else {
          throw ConfigError(fmt::format("placement '{}': expected rsa or overlapping", placement));
        }
        StartPacking s;
        {
          py::gil_scoped_release release;
          s = makeStartPacking(d.get(), request);
        }
        py::dict out = configurationDict(s.configuration);
        out["id"] = copyOut(s.id);
        out["distribution"] = s.distribution;
        return out;
      },
      py::arg("distribution"), py::arg("count"), py::arg("packing_fraction") = 0.3,
      py::arg("aspect") = std::vector<double>{1.0, 1.0, 1.0}, py::arg("boundaries") = "periodic", py::arg("seed") = 1,
      py::arg("sampling") = "systematic", py::arg("placement") = "rsa", py::arg("radii") = py::none(),
      "The start packing of generate / relax / jam (makeStartPacking): dict positions (N, 3), radii, id, box, "
      "distribution");
  m.def(
      "random_sequential_addition",
      [](const py::handle& radii, double phi, const py::handle& aspect, const py::handle& boundaries,
         std::uint64_t seed, std::int64_t maxAttempts) {
        return configurationDict(place(radii, phi, aspect, boundaries, seed, maxAttempts, false));
      },
      py::arg("radii"), py::arg("packing_fraction") = 0.3, py::arg("aspect") = std::vector<double>{1.0, 1.0, 1.0},
      py::arg("boundaries") = "periodic", py::arg("seed") = 1, py::arg("max_attempts_per_particle") = 20000,
      "RSA of the given radii, largest first, output in the given order: dict positions, radii, box");
  m.def(
      "random_overlapping",
      [](const py::handle& radii, double phi, const py::handle& aspect, const py::handle& boundaries,
         std::uint64_t seed) { return configurationDict(place(radii, phi, aspect, boundaries, seed, 1, true)); },
      py::arg("radii"), py::arg("packing_fraction") = 0.3, py::arg("aspect") = std::vector<double>{1.0, 1.0, 1.0},
      py::arg("boundaries") = "periodic", py::arg("seed") = 1,
      "independent uniform centres (overlaps allowed) at the nominal packing fraction");

  m.def(
      "predict",
      [](const std::shared_ptr<Distribution>& distribution, const py::object& radii, const std::vector<double>& phi) {
        if ((distribution == nullptr) == radii.is_none()) {
          throw ConfigError("predict: give either a distribution or the radii of a sample, not both or neither");
        }
        for (double p : phi) {
          if (!(p >= 0.0 && p < 1.0)) throw ConfigError(fmt::format("phi: packing fraction {} is not in [0, 1)", p));
        }
        Moments mo;
        DistributionSpec spec;
        if (distribution) {
          mo = momentsOf(distribution->get());
          spec = distribution->spec();
        } else {
          const Eigen::VectorXd r = toVector(radii, "radii");
          if (r.size() == 0) throw ConfigError("radii: no radii to take moments of");
          mo = momentsOfSample(std::span<const double>(r.data(), static_cast<std::size_t>(r.size())));
        }
        py::dict out;
        out["moments"] = momentsDict(mo);
        out["bounds"] = py::make_tuple(mo.o1 * mo.o1, mo.o2, mo.o1);
        out["bidisperse"] = mixtureDict(equivalentBidisperse(mo));
        out["tridisperse"] = mixtureDict(equivalentTridisperse(mo));
        out["phi"] = phi;
        py::dict z;
        const eos::MomentRatios ratios = eos::ratiosOf(mo);
        for (eos::Form f : eos::kAllForms) {
          std::vector<double> values;
          for (double p : phi) values.push_back(eos::z(f, p, ratios));
          z[py::str(std::string(eos::formName(f)))] = values;
        }
        out["compressibility"] = z;
        py::list jamming;
        for (const eos::JammingPrediction& p : eos::predictJamming(spec, mo)) {
          // As `polydem predict --input`: the family fits need the distribution, only eq. 3.53 applies to radii.
          if (!distribution && p.equation.rfind("eq. 3.53", 0) != 0) continue;
          py::dict row;
          row["value"] = p.value;
          row["equation"] = p.equation;
          row["note"] = p.note;
          jamming.append(row);
        }
        out["jamming"] = jamming;
        return out;
      },
      py::arg("distribution") = nullptr, py::arg("radii") = py::none(),
      py::arg("phi") = std::vector<double>{0.3, 0.4, 0.5, 0.55, 0.6},
      "`polydem predict` as a dict: moments, bounds, equivalent mixtures, Z(phi) per equation of state, jamming fits");
}

}  // namespace polydem::python
