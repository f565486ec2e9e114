// `jam` (event-driven compression, edmd/compression.hpp, started as `polydem jam` starts it) and `analyze`
// (the contact network of a hard-sphere packing, through the CLI's own computeContacts of
// apps/polydem/analyze_contacts.cpp: same pressure rule, validity check and messages).
#include <fmt/format.h>
#include <pybind11/functional.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cmath>
#include <optional>

#include "apps/polydem/analyze.hpp"
#include "core/errors.hpp"
#include "core/initial_configuration.hpp"
#include "core/io/particle_file.hpp"
#include "edmd/compression.hpp"
#include "edmd/hard_sphere_system.hpp"
#include "jamming/contact_network.hpp"
#include "python/convert.hpp"
#include "python/distributions.hpp"
#include "python/io.hpp"

namespace polydem::python {

namespace {

py::object finiteOrNone(double x) { return std::isfinite(x) ? py::object(py::float_(x)) : py::object(py::none()); }

py::dict networkDict(const jamming::ContactNetwork& net, const jamming::ContactOptions& options) {
  py::dict d;
  const auto n = static_cast<py::ssize_t>(net.contacts.size());
  py::array_t<Index> i(n), j(n);
  for (py::ssize_t k = 0; k < n; ++k) {
    i.mutable_data()[k] = net.contacts[static_cast<std::size_t>(k)].i;
    j.mutable_data()[k] = net.contacts[static_cast<std::size_t>(k)].j;
  }
  d["contacts"] = py::make_tuple(i, j);
  py::array_t<Index> wi(static_cast<py::ssize_t>(net.wallContacts.size()));
  py::array_t<int> wall(static_cast<py::ssize_t>(net.wallContacts.size()));
  for (std::size_t k = 0; k < net.wallContacts.size(); ++k) {
    wi.mutable_data()[k] = net.wallContacts[k].i;
    wall.mutable_data()[k] = net.wallContacts[k].wall;
  }
  d["wall_contacts"] = py::make_tuple(wi, wall);
  py::array_t<int> z(static_cast<py::ssize_t>(net.coordination.size()));
  std::copy(net.coordination.begin(), net.coordination.end(), z.mutable_data());
  d["coordination"] = z;
  py::array_t<bool> rattler(static_cast<py::ssize_t>(net.rattler.size()));
  for (std::size_t k = 0; k < net.rattler.size(); ++k) rattler.mutable_data()[k] = net.rattler[k] != 0;
  d["rattler"] = rattler;
  d["contact_gap"] = options.relativeGap;
  d["min_contacts"] = options.minContacts;
  d["z"] = net.particles > 0 ? py::object(py::float_(net.meanCoordination())) : py::object(py::none());
  // An empty backbone (every sphere a rattler) has no coordination and no isostaticity: None, not nan.
  d["backbone"] = net.backbone;
  d["backbone_contacts"] = net.backboneContacts;
  d["z_backbone"] = net.backbone > 0 ? py::object(py::float_(net.backboneCoordination())) : py::object(py::none());
  d["isostatic_excess"] = net.backbone > 0 ? py::object(py::int_(net.isostaticExcess())) : py::object(py::none());
  d["rattler_fraction"] = net.particles > 0 ? py::object(py::float_(net.rattlerFraction())) : py::object(py::none());
  d["max_overlap"] = net.maxOverlap;
  d["min_gap"] = net.minGap;
  return d;
}

py::dict progressDict(const edmd::Progress& p) {
  py::dict d;
  d["packing_fraction"] = p.packingFraction;
  d["pressure"] = p.pressure;
  d["phi_j_estimate"] = finiteOrNone(p.jammingEstimate);
  d["rate"] = p.rate;
  d["stage"] = p.stage;
  d["collisions_per_particle"] = p.collisionsPerParticle;
  d["blocks"] = p.blocks;
  d["wall_seconds"] = p.wallSeconds;
  d["time"] = p.time;
  return d;
}

/// Input of analyze: a particle dict, or a file name (read as `polydem analyze FILE` reads it).
io::ParticleData packingFrom(const py::object& packing, std::string& name) {
  if (py::isinstance<py::dict>(packing)) {
    name = "packing";
    return particleData(packing.cast<py::dict>());
  }
  const auto file = packing.cast<std::filesystem::path>();
  name = file.string();
  py::gil_scoped_release release;
  return io::readParticles(file);
}

}  // namespace

void bindJamming(py::module_& m) {
  m.def(
      "jam",
      [](const std::shared_ptr<Distribution>& distribution, Index count, double initialPhi,
         const py::object& boundaries, const std::string& sampling, std::uint64_t seed, const py::object& packing,
         const std::optional<std::string>& schedule, double targetPressure, double targetPhi, double maxCollisions,
         double block, const std::string& broadPhase, double neighbourhoodScale, double skinCap, double contactGap,
         const std::function<void(py::dict)>& progress) {
        // The start: a packing dict (positions, radii, box), or makeStartPacking of the distribution as the CLI.
        io::ParticleData start;
        if (!packing.is_none()) {
          if (distribution) throw ConfigError("jam: give either a distribution or a start packing, not both");
          start = particleData(packing.cast<py::dict>());
        } else {
          if (!distribution) throw ConfigError("jam: give a distribution (with count) or a start packing");
          if (count < 2) {
            throw ConfigError(
                fmt::format("count {}: a compression needs at least 2 spheres (a lone sphere has no binary "
                            "collisions, so neither a pressure nor a collision budget ends its run)",
                            count));
          }
          StartPackingRequest request;
          request.count = count;
          if (sampling != "systematic" && sampling != "random") {
            throw ConfigError(fmt::format("sampling '{}': expected systematic or random", sampling));
          }
          request.sampling = sampling == "random" ? Sampling::Random : Sampling::Systematic;
          request.packingFraction = initialPhi;
          request.boundaries = boundariesFrom(boundaries);
          request.seed = seed;
          py::gil_scoped_release release;
          StartPacking s = makeStartPacking(distribution->get(), request);
          start.box = s.configuration.box;
          start.position = std::move(s.configuration.position);
          start.radius = std::move(s.configuration.radius);
          start.id = std::move(s.id);
          start.attributes["distribution"] = s.distribution;
        }
        edmd::CompressionOptions copt;
        if (schedule) copt.schedule = edmd::parseSchedule(*schedule);
        copt.targetPressure = targetPressure;
        copt.targetPackingFraction = targetPhi;
        copt.maxCollisionsPerParticle = maxCollisions;
        copt.blockCollisionsPerParticle = block;
        edmd::SystemOptions sopt;
        sopt.broadPhase = broadPhase;
        sopt.neighbourhoodScale = neighbourhoodScale;
        sopt.skinCap = skinCap;

        // Python callbacks and signals are handled with the GIL taken back, at block boundaries; an error
        // there stops the compression at the boundary and is raised after it returns.
        std::optional<py::error_already_set> failure;
        const std::function<void(const edmd::Progress&)> onBlock = [&](const edmd::Progress& p) {
          if (!progress || failure) return;
          py::gil_scoped_acquire acquire;
          try {
            progress(progressDict(p));
          } catch (py::error_already_set& e) {
            failure.emplace(std::move(e));
          }
        };
        const edmd::BoundaryHook atBoundary = [&](edmd::HardSphereSystem&, const edmd::CompressionState&) {
          if (failure) return true;
          py::gil_scoped_acquire acquire;
          if (PyErr_CheckSignals() != 0) failure.emplace();
          return failure.has_value();
        };
        std::unique_ptr<edmd::HardSphereSystem> system;
        edmd::CompressionResult result;
        jamming::ContactOptions contact;
        jamming::ContactNetwork net;
        Eigen::Matrix3Xd x;
        Eigen::VectorXd r;
        {
          py::gil_scoped_release release;
          system = std::make_unique<edmd::HardSphereSystem>(start.box, start.position, start.radius,
                                                            edmd::maxwellBoltzmannVelocities(start.radius, seed), sopt);
          edmd::validateCompression(*system, copt);
          result = edmd::compress(*system, copt, onBlock, atBoundary);
          if (!failure) {
            x = system->positions();
            r = system->radii();
            contact.relativeGap = contactGap > 0.0 ? contactGap : jamming::defaultContactGap(result.last.pressure);
            contact.broadPhase = broadPhase;
            net = jamming::analyseContacts(SphereView{x, r}, system->box(), contact);
          }
        }
        if (failure) throw std::move(*failure);
        py::dict out;
        out["positions"] = copyOut(x);
        out["radii"] = copyOut(r);
        out["id"] = copyOut(start.id);
        out["box"] = py::cast(system->box());
        out["packing_fraction"] = system->packingFraction();
        out["pressure"] = result.last.pressure;
        out["phi_j_estimate"] =
            finiteOrNone(edmd::jammingDensityEstimate(system->packingFraction(), result.last.pressure));
        out["target_reached"] = result.targetReached;
        out["stop_reason"] = result.stopReason;
        out["collisions"] = result.counts.collisions;
        out["blocks"] = result.last.blocks;
        out["wall_seconds"] = result.wallSeconds;
        out["schedule"] = edmd::formatSchedule(copt.schedule);
        out["attributes"] = py::cast(start.attributes);
        out["network"] = networkDict(net, contact);
        return out;
      },
      py::arg("distribution") = nullptr, py::arg("count") = 1000, py::arg("initial_phi") = 0.3,
      py::arg("boundaries") = "periodic", py::arg("sampling") = "systematic", py::arg("seed") = 1,
      py::arg("packing") = py::none(), py::arg("schedule") = py::none(), py::arg("target_pressure") = 1e12,
      py::arg("target_phi") = 0.0, py::arg("max_collisions") = 1e7, py::arg("block") = 0.0,
      py::arg("broadphase") = "hgrid-td", py::arg("neighbourhood_scale") = 1.4, py::arg("skin_cap") = 4.0,
      py::arg("contact_gap") = 0.0, py::arg("progress") = nullptr,
      "Event-driven compression (`polydem jam`) of a start packing made from a distribution (or given as a "
      "particle dict); progress(dict) after every block; Ctrl-C stops at a block boundary with KeyboardInterrupt. "
      "Returns positions, radii, box, packing_fraction, pressure, phi_j_estimate, stop_reason, network, ...");

  m.def(
      "analyze",
      [](const py::object& packing, double pressure, double contactGap, const std::string& broadPhase,
         const std::vector<double>& taus) {
        std::string name;
        const io::ParticleData data = packingFrom(packing, name);
        app::analyze::AnalyzeOptions opt;
        opt.input = name;
        opt.pressure = pressure;
        opt.contactGap = contactGap;
        opt.broadPhase = broadPhase;
        app::analyze::ContactAnalysis a;
        std::vector<double> z;
        {
          py::gil_scoped_release release;
          a = app::analyze::computeContacts(opt, data);
          if (!taus.empty()) {
            z = jamming::cumulativeCoordination(SphereView{data.position, data.radius}, data.box, taus, broadPhase);
          }
        }
        py::dict out = networkDict(a.net, a.contact);
        out["spheres"] = data.count();
        out["packing_fraction"] = app::analyze::solidVolume(data) / data.box.volume();
        out["pressure"] = a.pressure ? py::object(py::float_(*a.pressure)) : py::object(py::none());
        out["density_bound"] = a.validity.densityBound;
        out["valid"] = a.validity.valid();
        if (!taus.empty()) {
          out["taus"] = taus;
          out["z_of_tau"] = z;
        }
        return out;
      },
      py::arg("packing"), py::arg("pressure") = 0.0, py::arg("contact_gap") = 0.0, py::arg("broadphase") = "hgrid-td",
      py::arg("taus") = std::vector<double>{},
      "`polydem analyze` (contact network): packing a particle dict or a file; the contact gap from pressure "
      "(or the file's reduced_pressure) or contact_gap. Raises InputError for an invalid hard-sphere packing");

  m.def(
      "check_packing",
      [](const py::object& packing, double tolerance, const std::string& broadPhase) {
        std::string name;
        const io::ParticleData data = packingFrom(packing, name);
        const jamming::PackingValidity v =
            jamming::checkHardSpherePacking(SphereView{data.position, data.radius}, data.box,
                                            {.overlapTolerance = tolerance, .broadPhase = broadPhase});
        py::dict d;
        d["valid"] = v.valid();
        d["packing_fraction"] = v.packingFraction;
        d["density_bound"] = v.densityBound;
        d["worst_overlap"] = v.worstOverlap;
        d["overlaps"] = v.overlaps;
        d["problem"] = jamming::describeInvalidPacking(v, data.id);
        return d;
      },
      py::arg("packing"), py::arg("tolerance") = 1e-8, py::arg("broadphase") = "hgrid-td",
      "overlaps and density bound of a hard-sphere packing (jamming::checkHardSpherePacking)");
}

}  // namespace polydem::python
