#include "broadphase/delaunay.hpp"

#include <algorithm>
#include <cmath>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Regular_triangulation_3.h>
#include <CGAL/Regular_triangulation_cell_base_3.h>
#include <CGAL/Regular_triangulation_vertex_base_3.h>
#include <CGAL/Triangulation_vertex_base_with_info_3.h>
#include <fmt/format.h>

#include "core/errors.hpp"

namespace polydem::broadphase {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Triangulation_vertex_base_with_info_3<Index, K, CGAL::Regular_triangulation_vertex_base_3<K>>;
// Hidden points are discarded: we find them as the ids missing from the vertices and triangulate
// them in the next layer, which keeps their ids (CGAL's per-cell hidden lists lose the info).
using Cb = CGAL::Regular_triangulation_cell_base_3<K, CGAL::Triangulation_cell_base_3<K>, CGAL::Discard_hidden_points>;
using Tds = CGAL::Triangulation_data_structure_3<Vb, Cb>;
using RT = CGAL::Regular_triangulation_3<K, Tds>;
using WP = K::Weighted_point_3;
using BP = K::Point_3;
using VH = RT::Vertex_handle;

constexpr Index kNone = -1;

}  // namespace

struct Delaunay::Impl {
  // Triangulated points ("ids"): id < N is particle id's centre, ids >= N are periodic images.
  struct Point {
    double c[3];
    double R;        // ball radius r + skin / 2 + margin; weight R^2
    Index particle;
    int layer;       // triangulation holding it as a vertex
    bool live;
  };
  std::vector<Point> pts;
  std::vector<VH> vertex;       // per id, in layers[pts[id].layer]
  std::vector<Index> nextImage; // per id: next image of the same particle (linked list)
  std::vector<Index> firstImage;  // per particle
  std::vector<Index> freeIds;
  std::vector<std::unique_ptr<RT>> layers;
  Index liveImages = 0;

  // Triangulation graph of all layers as CSR over ids (build only).
  std::vector<Index> graphStart, graphAdj;
  // Walk scratch.
  std::vector<std::uint32_t> stamp;
  std::uint32_t currentStamp = 0;
  std::vector<Index> queue;
  std::vector<VH> adjacentScratch;
  std::vector<Pair> found;
  std::vector<char> dropped;

  double margin = 0.0, cut = 0.0;

  WP weighted(Index id) const {
    const Point& p = pts[id];
    return WP(BP(p.c[0], p.c[1], p.c[2]), p.R * p.R);
  }

  Index allocate() {
    if (!freeIds.empty()) {
      const Index id = freeIds.back();
      freeIds.pop_back();
      return id;
    }
    pts.emplace_back();
    vertex.emplace_back();
    nextImage.push_back(kNone);
    stamp.push_back(0);
    return static_cast<Index>(pts.size() - 1);
  }

  /// Append images of particle p (centre c, ball radius R) within `cut` of periodic faces; returns
  /// the new ids through `out`.
  template <class F>
  void makeImages(const Box& box, Index p, F&& onImage) {
    const Point base = pts[p];
    double options[3][3];
    int counts[3];
    for (int k = 0; k < 3; ++k) {
      counts[k] = 0;
      options[k][counts[k]++] = 0.0;
      if (!box.periodic(k)) continue;
      if (base.c[k] <= cut) options[k][counts[k]++] = box.length(k);
      if (base.c[k] >= box.length(k) - cut) options[k][counts[k]++] = -box.length(k);
    }
    for (int a = 0; a < counts[0]; ++a) {
      for (int b = 0; b < counts[1]; ++b) {
        for (int d = 0; d < counts[2]; ++d) {
          if (a == 0 && b == 0 && d == 0) continue;
          const Index id = allocate();
          Point& q = pts[id];
          q = base;
          q.c[0] += options[0][a];
          q.c[1] += options[1][b];
          q.c[2] += options[2][d];
          q.live = true;
          nextImage[id] = firstImage[p];
          firstImage[p] = id;
          ++liveImages;
          onImage(id);
        }
      }
    }
  }

  bool ballsMeet(Index a, Index b) const {
    const Point& p = pts[a];
    const Point& q = pts[b];
    const double dx = p.c[0] - q.c[0], dy = p.c[1] - q.c[1], dz = p.c[2] - q.c[2];
    const double limit = p.R + q.R;
    // The relative slack only widens the walk; reporting uses the exact predicate.
    return dx * dx + dy * dy + dz * dz <= limit * limit * (1.0 + 1e-10);
  }

  /// Breadth-first walk from `start` through vertices whose ball meets the ball of `query`; every
  /// visited vertex is offered to `report`. `adjacent(v, f)` calls f on each neighbour of v.
  template <class Adjacent, class Report>
  std::size_t walk(Index query, Index start, Adjacent&& adjacent, Report&& report) {
    if (++currentStamp == 0) {
      std::fill(stamp.begin(), stamp.end(), 0u);
      currentStamp = 1;
    }
    queue.clear();
    queue.push_back(start);
    stamp[start] = currentStamp;
    std::size_t visits = 0;
    for (std::size_t head = 0; head < queue.size(); ++head) {
      const Index v = queue[head];
      report(v);
      adjacent(v, [&](Index w) {
        ++visits;
        if (stamp[w] == currentStamp) return;
        stamp[w] = currentStamp;
        if (ballsMeet(query, w)) queue.push_back(w);
      });
    }
    return visits;
  }
};

Delaunay::Delaunay() : impl_(std::make_unique<Impl>()) {}
Delaunay::~Delaunay() = default;
Delaunay::Delaunay(Delaunay&&) noexcept = default;
Delaunay& Delaunay::operator=(Delaunay&&) noexcept = default;

void Delaunay::doBuild(const SphereView& spheres) {
  Impl& m = *impl_;
  const Index n = spheres.count();
  m.margin = 1e-12 * (box_.lengths().maxCoeff() + 2.0 * maxRadius_ + skin_);
  auto ballRadius = [&](double r) { return (r + 0.5 * skin_) * (1.0 + 1e-9) + m.margin; };
  m.cut = 2.0 * ballRadius(maxRadius_) + m.margin;
  m.pts.resize(static_cast<std::size_t>(n));
  m.vertex.assign(static_cast<std::size_t>(n), VH());
  m.nextImage.assign(static_cast<std::size_t>(n), kNone);
  m.firstImage.assign(static_cast<std::size_t>(n), kNone);
  m.stamp.assign(static_cast<std::size_t>(n), 0u);
  m.currentStamp = 0;
  m.freeIds.clear();
  m.liveImages = 0;
  for (Index i = 0; i < n; ++i) {
    Impl::Point& p = m.pts[i];
    for (int k = 0; k < 3; ++k) p.c[k] = spheres.centre(k, i);
    p.R = ballRadius(spheres.radius[i]);
    p.particle = i;
    p.layer = 0;
    p.live = true;
  }
  for (Index i = 0; i < n; ++i) m.makeImages(box_, i, [](Index) {});
  const Index total = static_cast<Index>(m.pts.size());
  m.vertex.resize(static_cast<std::size_t>(total));

  // Layers: triangulate, collect the hidden ids, triangulate those, until none is hidden.
  m.layers.clear();
  std::vector<Index> current(static_cast<std::size_t>(total));
  for (Index id = 0; id < total; ++id) current[id] = id;
  std::vector<std::pair<WP, Index>> input;
  std::vector<char> isVertex(static_cast<std::size_t>(total), 0);
  stats_.hidden = 0;
  while (!current.empty()) {
    const int layer = static_cast<int>(m.layers.size());
    auto t = std::make_unique<RT>();
    input.clear();
    for (Index id : current) input.emplace_back(m.weighted(id), id);
    t->insert(input.begin(), input.end());
    for (auto v = t->finite_vertices_begin(); v != t->finite_vertices_end(); ++v) {
      const Index id = v->info();
      isVertex[id] = 1;
      m.vertex[id] = v;
      m.pts[id].layer = layer;
    }
    std::vector<Index> hidden;
    for (Index id : current) {
      if (!isVertex[id]) hidden.push_back(id);
    }
    if (layer == 0) stats_.hidden = static_cast<Index>(hidden.size());
    m.layers.push_back(std::move(t));
    if (hidden.size() == current.size()) {
      throw std::logic_error("delaunay: a regular triangulation kept none of its points");  // cannot happen
    }
    current.swap(hidden);
  }

  // The triangulation graph of every layer as CSR over ids.
  m.graphStart.assign(static_cast<std::size_t>(total) + 1, 0);
  for (const auto& t : m.layers) {
    for (auto e = t->finite_edges_begin(); e != t->finite_edges_end(); ++e) {
      ++m.graphStart[e->first->vertex(e->second)->info() + 1];
      ++m.graphStart[e->first->vertex(e->third)->info() + 1];
    }
  }
  for (Index id = 0; id < total; ++id) m.graphStart[id + 1] += m.graphStart[id];
  m.graphAdj.resize(static_cast<std::size_t>(m.graphStart[total]));
  {
    std::vector<Index> fill(m.graphStart.begin(), m.graphStart.end() - 1);
    for (const auto& t : m.layers) {
      for (auto e = t->finite_edges_begin(); e != t->finite_edges_end(); ++e) {
        const Index a = e->first->vertex(e->second)->info(), b = e->first->vertex(e->third)->info();
        m.graphAdj[fill[a]++] = b;
        m.graphAdj[fill[b]++] = a;
      }
    }
  }
  auto graph = [&m](Index v, auto&& f) {
    for (Index k = m.graphStart[v]; k < m.graphStart[v + 1]; ++k) f(m.graphAdj[k]);
  };

  // Walks. Within a layer every pair is found from both ends: an original reports another original
  // of its layer only from the smaller particle index. Images and cross-layer finds are reported
  // as found, and the table dedupes.
  m.found.clear();
  std::size_t visits = 0;
  for (Index id = 0; id < total; ++id) {
    const Impl::Point& q = m.pts[id];
    const bool original = id < n;
    if (!original && q.layer == 0) continue;  // visible images: their pairs are found from originals
    const Index qp = q.particle;
    const double* xq = spheres.centre.col(qp).data();
    const double rq = spheres.radius[qp];
    auto report = [&](Index v, bool crossLayer) {
      const Index p = m.pts[v].particle;
      if (p == qp) return;
      if (!crossLayer && v < n && p < qp) return;
      if (spheresWithinReach(box_, xq, rq, spheres.centre.col(p).data(), spheres.radius[p], skin_)) {
        m.found.push_back(qp < p ? Pair{qp, p} : Pair{p, qp});
      }
    };
    if (original) visits += m.walk(id, id, graph, [&](Index v) { report(v, false); });
    for (int b = 0; b < q.layer; ++b) {
      // q is hidden in layer b, so the power-nearest vertex of its centre has a ball meeting B_q.
      const VH start = m.layers[b]->nearest_power_vertex(BP(q.c[0], q.c[1], q.c[2]));
      visits += m.walk(id, start->info(), graph, [&](Index v) { report(v, true); });
    }
  }
  if (counting_) counters_.pairTests += visits;
  stats_.visits = visits;
  stats_.points = total;
  stats_.images = m.liveImages;
  stats_.layers = static_cast<int>(m.layers.size());
  table_.assign(std::move(m.found), n);
}

void Delaunay::doUpdate(const SphereView& spheres, std::span<const Index> moved) {
  Impl& m = *impl_;
  const Index n = spheres.count();
  // Incremental only with one layer (no hidden points: removing a vertex could expose one) and a
  // full-dimensional triangulation; a large move set is cheaper to rebuild (spatially sorted insert).
  const bool incremental = n > 0 && static_cast<Index>(m.firstImage.size()) == n && m.layers.size() == 1 &&
                           m.layers[0]->dimension() == 3 &&
                           static_cast<double>(moved.size()) <= maxMovedFraction_ * static_cast<double>(n);
  if (!incremental) {
    ++stats_.rebuilds;
    doBuild(spheres);
    return;
  }
  RT& t = *m.layers[0];
  std::size_t expected = t.number_of_vertices();
  auto fail = [&]() {
    ++stats_.rebuilds;
    doBuild(spheres);
  };
  for (Index p : moved) {
    // Drop the old images.
    for (Index id = m.firstImage[p]; id != kNone;) {
      const Index next = m.nextImage[id];
      t.remove(m.vertex[id]);
      --expected;
      if (t.number_of_vertices() != expected) return fail();
      m.pts[id].live = false;
      m.vertex[id] = VH();
      m.freeIds.push_back(id);
      --m.liveImages;
      id = next;
    }
    m.firstImage[p] = kNone;
    Impl::Point& q = m.pts[p];
    for (int k = 0; k < 3; ++k) q.c[k] = spheres.centre(k, p);
    const WP wp = m.weighted(p);
    const VH w = t.move(m.vertex[p], wp);
    if (w == VH() || w->point() != wp || t.number_of_vertices() != expected) return fail();
    w->info() = p;
    m.vertex[p] = w;
    bool ok = true;
    m.makeImages(box_, p, [&](Index id) {
      if (!ok) return;
      m.pts[id].layer = 0;
      const WP wi = m.weighted(id);
      const VH v = t.insert(wi, m.vertex[p]->cell());
      ++expected;
      if (v == VH() || v->point() != wi || t.number_of_vertices() != expected) {
        ok = false;
        return;
      }
      v->info() = id;
      m.vertex[id] = v;
    });
    if (!ok) return fail();
  }
  // Only pairs touching a moved particle can change: recompute those rows with walks over the
  // updated triangulation (CGAL adjacency, the CSR graph is stale now).
  auto adjacent = [&m, &t](Index v, auto&& f) {
    m.adjacentScratch.clear();
    t.finite_adjacent_vertices(m.vertex[v], std::back_inserter(m.adjacentScratch));
    for (const VH& w : m.adjacentScratch) f(w->info());
  };
  m.dropped.assign(static_cast<std::size_t>(n), 0);
  for (Index p : moved) m.dropped[p] = 1;
  m.found.clear();
  std::size_t visits = 0;
  for (Index p : moved) {
    const double* xq = spheres.centre.col(p).data();
    const double rq = spheres.radius[p];
    visits += m.walk(p, p, adjacent, [&](Index v) {
      const Index j = m.pts[v].particle;
      if (j != p && spheresWithinReach(box_, xq, rq, spheres.centre.col(j).data(), spheres.radius[j], skin_)) {
        m.found.push_back(p < j ? Pair{p, j} : Pair{j, p});
      }
    });
  }
  table_.replaceRows(m.dropped, m.found);
  if (counting_) counters_.pairTests += visits;
  stats_.visits = visits;
  stats_.images = m.liveImages;
  ++stats_.moves;
}

void Delaunay::findPairs(const SphereView&, std::vector<Pair>& out) const {
  out.assign(table_.pairs().begin(), table_.pairs().end());
}

void Delaunay::findNeighbours(const SphereView& spheres, Index i, double reach, std::vector<Index>& out) const {
  if (!(reach >= 0.0 && reach <= skin_)) {
    throw ConfigError(fmt::format("findNeighbours: reach {} must lie in [0, skin = {}]", reach, skin_));
  }
  table_.neighbours(spheres, box_, i, reach, out);
}

std::size_t Delaunay::memoryBytes() const {
  const Impl& m = *impl_;
  std::size_t bytes = table_.memoryBytes() + m.pts.capacity() * sizeof(Impl::Point) +
                      m.vertex.capacity() * sizeof(VH) + (m.graphStart.capacity() + m.graphAdj.capacity() +
                                                          m.nextImage.capacity() + m.firstImage.capacity()) *
                                                             sizeof(Index) +
                      m.stamp.capacity() * sizeof(std::uint32_t);
  for (const auto& t : m.layers) {
    bytes += t->tds().cells().capacity() * sizeof(RT::Cell) + t->tds().vertices().capacity() * sizeof(RT::Vertex);
  }
  return bytes;
}

std::string Delaunay::describe() const {
  return fmt::format(
      "delaunay (CGAL Regular_triangulation_3, EPICK, weights (r + skin/2)^2; {} points incl. {} periodic images "
      "(explicit replication within 2 R_max of periodic faces); {} layer(s), {} hidden in the first; updates: "
      "{} by move(), {} rebuilt)",
      stats_.points, stats_.images, stats_.layers, stats_.hidden, stats_.moves, stats_.rebuilds);
}

bool Delaunay::validate() const {
  const Impl& m = *impl_;
  for (const auto& t : m.layers) {
    if (!t->is_valid()) return false;
  }
  for (std::size_t id = 0; id < m.pts.size(); ++id) {
    if (!m.pts[id].live) continue;
    const VH v = m.vertex[id];
    if (v == VH() || v->info() != static_cast<Index>(id)) return false;
  }
  return true;
}

}  // namespace polydem::broadphase
