// Weighted Delaunay neighbours with a verified shell of periodic images; see delaunay_neighbours.hpp.
#include "structure/delaunay_neighbours.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Regular_triangulation_3.h>
#include <CGAL/Regular_triangulation_cell_base_3.h>
#include <CGAL/Regular_triangulation_vertex_base_3.h>
#include <CGAL/Triangulation_vertex_base_with_info_3.h>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <utility>

#include "core/errors.hpp"

namespace polydem::structure {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Triangulation_vertex_base_with_info_3<Index, K, CGAL::Regular_triangulation_vertex_base_3<K>>;
using Cb = CGAL::Regular_triangulation_cell_base_3<K, CGAL::Triangulation_cell_base_3<K>, CGAL::Discard_hidden_points>;
using Tds = CGAL::Triangulation_data_structure_3<Vb, Cb>;
using RT = CGAL::Regular_triangulation_3<K, Tds>;
using WP = K::Weighted_point_3;
using BP = K::Point_3;

struct Entry {
  Index j;
  std::array<double, 3> d;
  bool operator<(const Entry& o) const { return j != o.j ? j < o.j : d < o.d; }
};

// Append to position / owner the images of every particle inside [-t, L + t) on every periodic axis,
// any number of box lengths away (t may exceed L for a few particles in a small box).
void appendImages(const std::vector<Eigen::Vector3d>& wrapped, const Box& box, double shell,
                  std::vector<Eigen::Vector3d>& position, std::vector<Index>& owner) {
  const Index n = static_cast<Index>(wrapped.size());
  std::array<std::vector<int>, 3> shifts;
  for (Index i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) {
      shifts[k].assign(1, 0);
      if (!box.periodic(k)) continue;
      const double L = box.length(k);
      const int reach = static_cast<int>(std::ceil(shell / L)) + 1;
      for (int s = -reach; s <= reach; ++s) {
        const double x = wrapped[i][k] + s * L;
        if (s != 0 && x >= -shell && x < L + shell) shifts[k].push_back(s);
      }
    }
    for (int sx : shifts[0]) {
      for (int sy : shifts[1]) {
        for (int sz : shifts[2]) {
          if (sx == 0 && sy == 0 && sz == 0) continue;
          position.push_back(wrapped[i] + Eigen::Vector3d(sx * box.length(0), sy * box.length(1), sz * box.length(2)));
          owner.push_back(i);
        }
      }
    }
  }
}

// Cells with an original vertex (id < n) whose orthosphere could feel a point outside the replicated
// region (see delaunay_neighbours.hpp); 0 without periodic axes or below three dimensions.
Index unverifiedCells(const RT& t, Index n, const Box& box, double shell, double maxR) {
  Index failures = 0;
  if (t.dimension() != 3) return 0;
  for (auto c = t.finite_cells_begin(); c != t.finite_cells_end(); ++c) {
    bool original = false;
    for (int v = 0; v < 4; ++v) original = original || c->vertex(v)->info() < n;
    if (!original) continue;
    const BP z = t.dual(c);
    const WP& p0 = c->vertex(0)->point();
    const double rho2 = CGAL::squared_distance(z, p0.point()) - p0.weight();
    const double need = std::sqrt(std::max(0.0, rho2 + maxR * maxR));
    for (int k = 0; k < 3; ++k) {
      if (!box.periodic(k)) continue;
      const double zk = z[k];
      if (!(zk - need >= -shell && zk + need <= box.length(k) + shell)) {
        ++failures;
        break;
      }
    }
  }
  return failures;
}

// The triangulation's edges from an original, as sorted distinct keys (original i) << 32 | point id,
// read off the cells (each edge is shared by several cells, so deduplicated).
std::vector<std::uint64_t> edgeKeys(const RT& t, Index n) {
  std::vector<std::uint64_t> keys;
  auto add = [&](Index a, Index b) {
    if (a < n) keys.push_back(static_cast<std::uint64_t>(a) << 32 | static_cast<std::uint32_t>(b));
    if (b < n) keys.push_back(static_cast<std::uint64_t>(b) << 32 | static_cast<std::uint32_t>(a));
  };
  if (t.dimension() == 3) {
    keys.reserve(static_cast<std::size_t>(n) * 40);
    for (auto c = t.finite_cells_begin(); c != t.finite_cells_end(); ++c) {
      const Index v[4] = {c->vertex(0)->info(), c->vertex(1)->info(), c->vertex(2)->info(), c->vertex(3)->info()};
      for (int a = 0; a < 4; ++a) {
        for (int b = a + 1; b < 4; ++b) add(v[a], v[b]);
      }
    }
  } else {
    for (auto e = t.finite_edges_begin(); e != t.finite_edges_end(); ++e) {
      add(e->first->vertex(e->second)->info(), e->first->vertex(e->third)->info());
    }
  }
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  return keys;
}

// The CSR rows of out from the sorted edge keys (each row sorted by neighbour, then displacement).
void fillRows(const std::vector<std::uint64_t>& keys, const std::vector<Eigen::Vector3d>& position,
              const std::vector<Index>& owner, const std::vector<Eigen::Vector3d>& wrapped, NeighbourList& out) {
  const Index n = static_cast<Index>(wrapped.size());
  std::vector<Entry> row;
  out.neighbour.resize(keys.size());
  out.displacement.resize(3, static_cast<Eigen::Index>(keys.size()));
  std::size_t k = 0;
  for (Index i = 0; i < n; ++i) {
    row.clear();
    while (k < keys.size() && static_cast<Index>(keys[k] >> 32) == i) {
      const Index id = static_cast<Index>(keys[k] & 0xffffffffu);
      const Eigen::Vector3d d = position[id] - wrapped[i];
      row.push_back({owner[id], {d[0], d[1], d[2]}});
      ++k;
    }
    std::sort(row.begin(), row.end());
    const Index base = out.start[i];
    for (std::size_t e = 0; e < row.size(); ++e) {
      out.neighbour[base + e] = row[e].j;
      out.displacement.col(base + static_cast<Eigen::Index>(e)) =
          Eigen::Vector3d(row[e].d[0], row[e].d[1], row[e].d[2]);
    }
    out.start[i + 1] = base + static_cast<Index>(row.size());
  }
}

}  // namespace

NeighbourList delaunayNeighbours(const SphereView& spheres, const Box& box, const NeighbourOptions& options) {
  requireValidSpheres(spheres, "delaunayNeighbours");
  if (!(options.imageShell >= 0.0) || !std::isfinite(options.imageShell)) {
    throw ConfigError(
        fmt::format("delaunayNeighbours: imageShell must be finite and >= 0, got {}", options.imageShell));
  }
  const Index n = spheres.count();
  NeighbourList out;
  out.start.assign(static_cast<std::size_t>(n) + 1, 0);
  out.displacement.resize(3, 0);
  if (n == 0) return out;

  std::vector<Eigen::Vector3d> wrapped(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) wrapped[i] = box.wrap(spheres.centre.col(i));
  const double maxR = spheres.radius.maxCoeff();
  bool anyPeriodic = false;
  double maxPeriodicLength = 0.0;
  for (int k = 0; k < 3; ++k) {
    if (box.periodic(k)) {
      anyPeriodic = true;
      maxPeriodicLength = std::max(maxPeriodicLength, box.length(k));
    }
  }
  double shell = 0.0;
  if (anyPeriodic) {
    shell = options.imageShell > 0.0 ? options.imageShell : 2.0 * std::cbrt(box.volume() / n) + 2.0 * maxR;
  }

  std::vector<std::pair<WP, Index>> input;
  std::vector<Eigen::Vector3d> position;  // per point id; ids < n are the originals
  std::vector<Index> owner;
  for (int attempt = 1;; ++attempt) {
    input.clear();
    position.assign(wrapped.begin(), wrapped.end());
    owner.resize(static_cast<std::size_t>(n));
    for (Index i = 0; i < n; ++i) owner[i] = i;
    if (anyPeriodic) appendImages(wrapped, box, shell, position, owner);
    const Index total = static_cast<Index>(position.size());
    input.reserve(static_cast<std::size_t>(total));
    for (Index id = 0; id < total; ++id) {
      const Eigen::Vector3d& x = position[id];
      const double r = spheres.radius[owner[id]];
      input.emplace_back(WP(BP(x[0], x[1], x[2]), r * r), id);
    }
    RT t;
    t.insert(input.begin(), input.end());

    // Verify the shell: cells with an original vertex must not feel points outside the replicated region.
    const Index failures = anyPeriodic ? unverifiedCells(t, n, box, shell, maxR) : 0;
    if (failures > 0 && shell < 2.0 * maxPeriodicLength) {
      shell *= 2.0;
      continue;
    }

    const std::vector<std::uint64_t> keys = edgeKeys(t, n);
    std::vector<char> isVertex(static_cast<std::size_t>(n), 0);
    for (auto v = t.finite_vertices_begin(); v != t.finite_vertices_end(); ++v) {
      if (v->info() < n) isVertex[v->info()] = 1;
    }
    out.hidden = static_cast<Index>(std::count(isVertex.begin(), isVertex.end(), 0));
    fillRows(keys, position, owner, wrapped, out);
    out.imageShell = shell;
    out.attempts = attempt;
    out.unverifiedCells = failures;
    return out;
  }
}

}  // namespace polydem::structure
