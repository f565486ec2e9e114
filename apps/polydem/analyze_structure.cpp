// polydem analyze: structure of any configuration (gas, liquid, crystal, packing): rattlers by speed,
// bond-orientational order over weighted Delaunay neighbours, channel sizes, S(k) and chi(k).
#include <fmt/format.h>

#include <chrono>
#include <cmath>

#include "apps/polydem/analyze.hpp"
#include "apps/polydem/summary.hpp"
#include "core/io/safe_output.hpp"
#include "structure/bond_order.hpp"
#include "structure/channel_size.hpp"
#include "structure/delaunay_neighbours.hpp"
#include "structure/rattlers.hpp"
#include "structure/structure_factor.hpp"

namespace polydem::app::analyze {

void analyzeStructure(const AnalyzeOptions& opt, const io::ParticleData& data, const jamming::ContactNetwork* net) {
  const bool velocityRattlers = opt.velocityRattlers;
  const double velocityThreshold = opt.velocityRattlerLimit;
  const SphereView spheres{data.position, data.radius};
  const Index n = data.count();
  if (velocityRattlers) {
    if (n == 0) {
      fmt::print("rattlers by speed       undefined (no spheres)\n");
    } else {
      const structure::VelocityRattlers r =
          structure::velocityRattlers(*data.velocity, data.radius, data.box, velocityThreshold);
      fmt::print(
          "rattlers (|v|/v_rms <= {:.1e}) {} ({:.2f}%), volume fraction nu_r {:.5f} ({:.2f}% of the solid "
          "volume)\n",
          velocityThreshold, r.count, 100.0 * r.numberFraction, r.volumeFraction, 100.0 * r.volumeShare);
      summary().put("velocity_rattlers.threshold", velocityThreshold);
      summary().put("velocity_rattlers.count", static_cast<std::int64_t>(r.count));
      summary().put("velocity_rattlers.number_fraction", r.numberFraction);
      summary().put("velocity_rattlers.volume_fraction", r.volumeFraction);
      summary().put("velocity_rattlers.volume_share", r.volumeShare);
      if (net) {
        Index both = 0, geometric = 0;
        for (Index i = 0; i < n; ++i) {
          geometric += net->rattler[static_cast<std::size_t>(i)] != 0;
          both += net->rattler[static_cast<std::size_t>(i)] && r.rattler[static_cast<std::size_t>(i)];
        }
        fmt::print("  vs contact-count rattlers: {} of {} agree ({} by speed only, {} by contacts only)\n", both,
                   geometric, r.count - both, geometric - both);
      }
    }
  }
  if (opt.order || !opt.channelsCsv.empty()) {
    const auto start = std::chrono::steady_clock::now();
    const structure::NeighbourList nb = structure::delaunayNeighbours(spheres, data.box);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    fmt::print("Delaunay neighbours     {} (image shell {:.4g}, {} triangulation(s), {:.2f} s){}\n",
               n ? fmt::format("{:.3f} per sphere", nb.meanDegree()) : std::string("undefined (no spheres)"),
               nb.imageShell, nb.attempts, seconds,
               nb.unverifiedCells ? fmt::format(", {} cells unverified", nb.unverifiedCells) : std::string());
    summary().put("delaunay.image_shell", nb.imageShell);
    summary().put("delaunay.triangulations", nb.attempts);
    summary().put("delaunay.unverified_cells", static_cast<std::int64_t>(nb.unverifiedCells));
    summary().put("delaunay.hidden_spheres", static_cast<std::int64_t>(nb.hidden));
    if (n) {
      summary().put("delaunay.mean_neighbours", nb.meanDegree());
    } else {
      summary().undefined("delaunay.mean_neighbours", "no spheres");
    }
    if (nb.hidden) fmt::print("  {} spheres hidden by overlapping larger ones (no neighbours)\n", nb.hidden);
    if (opt.order) {
      if (nb.entries() == 0) {
        fmt::print("bond order (l = 6)      undefined (no Delaunay neighbours: {})\n",
                   n ? "no sphere has a neighbour" : "no spheres");
      } else {
        const structure::BondOrder order = structure::bondOrder(nb);
        fmt::print("bond order (l = 6)      p_c = {:.4f} ({} solid-like of {}), mean q6 = {:.4f}, Q6 = {:.4f}\n",
                   order.crystallineFraction, order.solidCount, n, order.meanQ, order.globalQ);
        summary().put("bond_order.crystalline_fraction", order.crystallineFraction);
        summary().put("bond_order.solid_like", static_cast<std::int64_t>(order.solidCount));
        summary().put("bond_order.mean_q6", order.meanQ);
        summary().put("bond_order.global_q6", order.globalQ);
      }
    }
    if (!opt.channelsCsv.empty()) {
      const auto t0 = std::chrono::steady_clock::now();
      const structure::ChannelHistogram h = structure::channelSizes(spheres, nb);
      const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (h.channels == 0) {
        fmt::print(
            "channels R_j/r_i        {} acute of {} triangles, none with a gap circle: mean and sd undefined "
            "({:.2f} s)\n",
            h.acute, h.triangles, sec);
      } else {
        fmt::print(
            "channels R_j/r_i        {} acute of {} triangles, {} with a gap circle; mean {:.4f}, sd {:.4f} "
            "({:.2f} s)\n",
            h.acute, h.triangles, h.channels, h.mean, h.stddev, sec);
      }
      summary().put("channels.acute_triangles", static_cast<std::int64_t>(h.acute));
      summary().put("channels.triangles", static_cast<std::int64_t>(h.triangles));
      summary().put("channels.with_gap_circle", static_cast<std::int64_t>(h.channels));
      if (h.channels > 0) {
        summary().put("channels.mean", h.mean);
        summary().put("channels.sd", h.stddev);
      } else {
        summary().undefined("channels.mean", "no channel with a gap circle");
      }
      if (h.overflow) fmt::print("  {} channels with R_j/r_i >= 1e4 are not in the histogram\n", h.overflow);
      std::string text = "x_low,x_mid,f,count\n";
      for (std::size_t k = 0; k < h.counts.size(); ++k) {
        // f is a density over the channels; with none it does not exist (0/0), and the counts say so.
        const double f = h.channels > 0 && std::isfinite(h.density[k]) ? h.density[k] : 0.0;
        text += fmt::format("{:.4f},{:.4f},{:.8g},{}\n", k * h.binWidth, (k + 0.5) * h.binWidth, f, h.counts[k]);
      }
      io::writeFileAtomically(opt.channelsCsv, text);
      fmt::print("wrote {}\n", opt.channelsCsv);
    }
  }
  if (!opt.skCsv.empty()) {
    const auto t0 = std::chrono::steady_clock::now();
    const structure::StructureFactor sk = structure::structureFactor(
        spheres, data.box, {.kMax = opt.skMax, .maxVectors = static_cast<std::int64_t>(opt.skMaxVectors)});
    const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::size_t peak = 0;
    for (std::size_t s = 1; s < sk.s.size(); ++s) {
      if (sk.s[s] > sk.s[peak]) peak = s;
    }
    if (sk.k.empty()) {
      fmt::print("S(k)                    no wave vector up to K = {} in this box ({:.2f} s): S undefined\n", opt.skMax,
                 sec);
    } else {
      fmt::print(
          "S(k)                    {} wave vectors (stride {}) in {} shells up to K = {} ({:.2f} s); S(K_min = "
          "{:.3f}) = {:.4g}, peak S = {:.4g} at K = {:.3f}\n",
          sk.totalVectors, sk.stride, sk.k.size(), opt.skMax, sec, sk.k[0], sk.s[0], sk.s[peak], sk.k[peak]);
      summary().put("structure_factor.wave_vectors", static_cast<std::int64_t>(sk.totalVectors));
      summary().put("structure_factor.k_min", sk.k[0]);
      summary().put("structure_factor.s_at_k_min", sk.s[0]);
      summary().put("structure_factor.peak_s", sk.s[peak]);
      summary().put("structure_factor.peak_k", sk.k[peak]);
    }
    std::string text = "K,S,chi,vectors\n";
    for (std::size_t s = 0; s < sk.k.size(); ++s) {
      text += fmt::format("{:.6f},{:.8g},{:.8g},{}\n", sk.k[s], sk.s[s], sk.chi[s], sk.vectors[s]);
    }
    io::writeFileAtomically(opt.skCsv, text);
    fmt::print("wrote {}\n", opt.skCsv);
  }
}

}  // namespace polydem::app::analyze
