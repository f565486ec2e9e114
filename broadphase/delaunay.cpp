#include "broadphase/delaunay.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Regular_triangulation_3.h>
#include <CGAL/Regular_triangulation_cell_base_3.h>
#include <CGAL/Regular_triangulation_vertex_base_3.h>
#include <CGAL/Triangulation_vertex_base_with_info_3.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

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
    double R;  // ball radius r + skin / 2 + margin; weight R^2
    Index particle;
    int layer;  // triangulation holding it as a vertex
    bool live;
    signed char shift[3];  // image shift in box lengths (0 for originals)
  };
  std::vector<Point> pts;
  std::vector<VH> vertex;         // per id, in layers[pts[id].layer]
  std::vector<Index> nextImage;   // per id: next image of the same particle (linked list)
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
  std::vector<RT::Cell_handle> cellScratch;
  std::vector<Pair> found;
  std::vector<char> dropped;

  std::size_t inPlaceCount = 0, cgalMoveCount = 0;
  double margin = 0.0, maxR = 0.0;  // round-off margin, largest ball radius

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

  /// Call f(sx, sy, sz) for every image shift (in box lengths) particle p needs: those that put it
  /// within R_p + R_max outside a periodic face, so that it could meet an original ball; every
  /// combination over periodic axes.
  template <class F>
  void forEachShift(const Box& box, Index p, F&& f) const {
    const Point& base = pts[p];
    const double cut = base.R + maxR + margin;
    signed char options[3][3];
    int counts[3];
    for (int k = 0; k < 3; ++k) {
      counts[k] = 0;
      options[k][counts[k]++] = 0;
      if (!box.periodic(k)) continue;
      if (base.c[k] <= cut) options[k][counts[k]++] = 1;
      if (base.c[k] >= box.length(k) - cut) options[k][counts[k]++] = -1;
    }
    for (int a = 0; a < counts[0]; ++a) {
      for (int b = 0; b < counts[1]; ++b) {
        for (int d = 0; d < counts[2]; ++d) {
          if (a == 0 && b == 0 && d == 0) continue;
          f(options[0][a], options[1][b], options[2][d]);
        }
      }
    }
  }

  void placeImage(const Box& box, Index id, Index p) {
    Point& q = pts[id];
    const Point& base = pts[p];
    for (int k = 0; k < 3; ++k) q.c[k] = base.c[k] + q.shift[k] * box.length(k);
  }

  /// Add the images of particle p (see forEachShift); calls onImage(id) for each new id.
  template <class F>
  void makeImages(const Box& box, Index p, F&& onImage) {
    forEachShift(box, p, [&](signed char sx, signed char sy, signed char sz) {
      const Index id = allocate();
      Point& q = pts[id];
      q = pts[p];
      q.shift[0] = sx;
      q.shift[1] = sy;
      q.shift[2] = sz;
      placeImage(box, id, p);
      q.live = true;
      nextImage[id] = firstImage[p];
      firstImage[p] = id;
      ++liveImages;
      onImage(id);
    });
  }

  /// True when p's current images have exactly the shifts it needs now.
  bool sameImageShifts(const Box& box, Index p) const {
    int needed = 0;
    bool all = true;
    forEachShift(box, p, [&](signed char sx, signed char sy, signed char sz) {
      ++needed;
      bool found = false;
      for (Index id = firstImage[p]; id != kNone && !found; id = nextImage[id]) {
        found = pts[id].shift[0] == sx && pts[id].shift[1] == sy && pts[id].shift[2] == sz;
      }
      all = all && found;
    });
    int have = 0;
    for (Index id = firstImage[p]; id != kNone; id = nextImage[id]) ++have;
    return all && have == needed;
  }

  /// Move vertex `id` to its (already updated) point. Relocation filter: if after the move every cell
  /// around the vertex is still positively oriented and every facet of those cells still passes the
  /// power test strictly, the triangulation is the regular triangulation of the moved points, so the
  /// point is just replaced (no combinatorial change; Devillers, Teillaud & de Castro's filtered
  /// relocation). Otherwise, and for hull vertices, CGAL's move() (remove + insert). Returns false
  /// if the point became hidden or collided, so the caller rebuilds.
  bool relocate(RT& t, Index id) {
    const WP wp = weighted(id);
    const VH v = vertex[id];
    cellScratch.clear();
    t.incident_cells(v, std::back_inserter(cellScratch));
    bool inPlace = true;
    for (const auto& c : cellScratch) {
      if (t.is_infinite(c)) {
        inPlace = false;
        break;
      }
    }
    if (inPlace) {
      const WP old = v->point();
      v->set_point(wp);
      const auto orientation = K().orientation_3_object();
      for (const auto& c : cellScratch) {
        if (orientation(c->vertex(0)->point().point(), c->vertex(1)->point().point(), c->vertex(2)->point().point(),
                        c->vertex(3)->point().point()) != CGAL::POSITIVE) {
          inPlace = false;
          break;
        }
        for (int i = 0; i < 4 && inPlace; ++i) {
          // A hull facet across from v stays convex as long as c stays positively oriented.
          if (t.is_infinite(c->neighbor(i))) continue;
          if (t.side_of_power_sphere(c, t.mirror_vertex(c, i)->point(), false) != CGAL::ON_UNBOUNDED_SIDE) {
            inPlace = false;
          }
        }
        if (!inPlace) break;
      }
      if (inPlace) {
        ++inPlaceCount;
        return true;
      }
      v->set_point(old);
    }
    const std::size_t count = t.number_of_vertices();
    ++cgalMoveCount;
    const VH w = t.move(v, wp);
    if (w == VH() || w->point() != wp || t.number_of_vertices() != count) return false;
    w->info() = id;
    vertex[id] = w;
    return true;
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
  // ---- build steps (Delaunay::doBuild) ----

  /// The points of a fresh build: one per particle (ball radius (r + skin/2)(1 + 1e-9) + margin) and
  /// its periodic images; resets the image lists, stamps and free ids.
  void resetPoints(const SphereView& spheres, const Box& box, double skin, double maxRadius) {
    const Index n = spheres.count();
    margin = 1e-12 * (box.lengths().maxCoeff() + 2.0 * maxRadius + skin);
    auto ballRadius = [&](double r) { return (r + 0.5 * skin) * (1.0 + 1e-9) + margin; };
    maxR = ballRadius(maxRadius);
    pts.resize(static_cast<std::size_t>(n));
    vertex.assign(static_cast<std::size_t>(n), VH());
    nextImage.assign(static_cast<std::size_t>(n), kNone);
    firstImage.assign(static_cast<std::size_t>(n), kNone);
    stamp.assign(static_cast<std::size_t>(n), 0u);
    currentStamp = 0;
    freeIds.clear();
    liveImages = 0;
    for (Index i = 0; i < n; ++i) {
      Point& p = pts[i];
      for (int k = 0; k < 3; ++k) p.c[k] = spheres.centre(k, i);
      p.R = ballRadius(spheres.radius[i]);
      p.particle = i;
      p.layer = 0;
      p.live = true;
      p.shift[0] = p.shift[1] = p.shift[2] = 0;
    }
    for (Index i = 0; i < n; ++i) makeImages(box, i, [](Index) {});
    vertex.resize(pts.size());
  }

  /// Layers: triangulate ids 0 .. total - 1, collect the hidden ids, triangulate those, until none is
  /// hidden. Returns the number hidden in the first layer.
  Index triangulateLayers(Index total) {
    layers.clear();
    std::vector<Index> current(static_cast<std::size_t>(total));
    for (Index id = 0; id < total; ++id) current[id] = id;
    std::vector<std::pair<WP, Index>> input;
    std::vector<char> isVertex(static_cast<std::size_t>(total), 0);
    Index hiddenInFirst = 0;
    while (!current.empty()) {
      const int layer = static_cast<int>(layers.size());
      auto t = std::make_unique<RT>();
      input.clear();
      for (Index id : current) input.emplace_back(weighted(id), id);
      t->insert(input.begin(), input.end());
      for (auto v = t->finite_vertices_begin(); v != t->finite_vertices_end(); ++v) {
        const Index id = v->info();
        isVertex[id] = 1;
        vertex[id] = v;
        pts[id].layer = layer;
      }
      std::vector<Index> hidden;
      for (Index id : current) {
        if (!isVertex[id]) hidden.push_back(id);
      }
      if (layer == 0) hiddenInFirst = static_cast<Index>(hidden.size());
      layers.push_back(std::move(t));
      if (hidden.size() == current.size()) {
        throw std::logic_error("delaunay: a regular triangulation kept none of its points");  // cannot happen
      }
      current.swap(hidden);
    }
    return hiddenInFirst;
  }

  /// Call f(a, b) for every directed edge of every layer. CGAL's finite-edge iterator circulates
  /// around every edge to pick a canonical cell (half the build time here), so in 3D the edges are
  /// read off the cells instead (12 directed edges each, repeated for edges shared by cells).
  template <class F>
  void forEachDirectedEdge(F&& f) const {
    for (const auto& t : layers) {
      if (t->dimension() == 3) {
        for (auto c = t->finite_cells_begin(); c != t->finite_cells_end(); ++c) {
          const Index v[4] = {c->vertex(0)->info(), c->vertex(1)->info(), c->vertex(2)->info(), c->vertex(3)->info()};
          for (int a = 0; a < 4; ++a) {
            for (int b = 0; b < 4; ++b) {
              if (a != b) f(v[a], v[b]);
            }
          }
        }
      } else {
        for (auto e = t->finite_edges_begin(); e != t->finite_edges_end(); ++e) {
          const Index a = e->first->vertex(e->second)->info(), b = e->first->vertex(e->third)->info();
          f(a, b);
          f(b, a);
        }
      }
    }
  }

  /// The triangulation graph of every layer as CSR over ids (graphStart, graphAdj), rows deduplicated
  /// with stamps.
  void buildGraph(Index total) {
    graphStart.assign(static_cast<std::size_t>(total) + 1, 0);
    forEachDirectedEdge([this](Index a, Index) { ++graphStart[a + 1]; });
    for (Index id = 0; id < total; ++id) graphStart[id + 1] += graphStart[id];
    graphAdj.resize(static_cast<std::size_t>(graphStart[total]));
    std::vector<Index> fill(graphStart.begin(), graphStart.end() - 1);
    forEachDirectedEdge([&](Index a, Index b) { graphAdj[fill[a]++] = b; });
    // Compact each row to distinct neighbours (an edge is shared by several cells).
    std::vector<Index> seen(static_cast<std::size_t>(total), kNone);
    Index write = 0;
    for (Index id = 0; id < total; ++id) {
      const Index begin = graphStart[id], end = graphStart[id + 1];
      graphStart[id] = write;
      for (Index k = begin; k < end; ++k) {
        const Index w = graphAdj[k];
        if (seen[w] == id) continue;
        seen[w] = id;
        graphAdj[write++] = w;
      }
    }
    graphStart[total] = write;
    graphAdj.resize(static_cast<std::size_t>(write));
  }

  /// Walks into `found`; returns the vertices examined. Within a layer every pair is found from both
  /// ends: an original reports another original of its layer only from the smaller particle index.
  /// Images and cross-layer finds are reported as found, and the table dedupes.
  std::size_t walkAll(const SphereView& spheres, const Box& box, double skin) {
    const Index n = spheres.count();
    const Index total = static_cast<Index>(pts.size());
    auto graph = [this](Index v, auto&& f) {
      for (Index k = graphStart[v]; k < graphStart[v + 1]; ++k) f(graphAdj[k]);
    };
    found.clear();
    std::size_t visits = 0;
    for (Index id = 0; id < total; ++id) {
      const Point& q = pts[id];
      const bool original = id < n;
      if (!original && q.layer == 0) continue;  // visible images: their pairs are found from originals
      const Index qp = q.particle;
      const double* xq = spheres.centre.col(qp).data();
      const double rq = spheres.radius[qp];
      auto report = [&](Index v, bool crossLayer) {
        const Index p = pts[v].particle;
        if (p == qp) return;
        if (!crossLayer && v < n && p < qp) return;
        if (spheresWithinReach(box, xq, rq, spheres.centre.col(p).data(), spheres.radius[p], skin)) {
          found.push_back(qp < p ? Pair{qp, p} : Pair{p, qp});
        }
      };
      if (original) visits += walk(id, id, graph, [&](Index v) { report(v, false); });
      for (int b = 0; b < q.layer; ++b) {
        // q is hidden in layer b, so the power-nearest vertex of its centre has a ball meeting B_q.
        const VH start = layers[b]->nearest_power_vertex(BP(q.c[0], q.c[1], q.c[2]));
        visits += walk(id, start->info(), graph, [&](Index v) { report(v, true); });
      }
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
  m.resetPoints(spheres, box_, skin_, maxRadius_);
  const Index total = static_cast<Index>(m.pts.size());
  stats_.hidden = m.triangulateLayers(total);
  m.buildGraph(total);
  const std::size_t visits = m.walkAll(spheres, box_, skin_);
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
    Impl::Point& q = m.pts[p];
    for (int k = 0; k < 3; ++k) q.c[k] = spheres.centre(k, p);
    if (!m.relocate(t, p)) return fail();
    if (m.sameImageShifts(box_, p)) {
      // Same faces as before: relocate the images too.
      for (Index id = m.firstImage[p]; id != kNone; id = m.nextImage[id]) {
        m.placeImage(box_, id, p);
        if (!m.relocate(t, id)) return fail();
      }
      continue;
    }
    // Crossed into or out of a face layer: drop the old images, insert the new ones.
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
  stats_.inPlace = m.inPlaceCount;
  stats_.cgalMoves = m.cgalMoveCount;
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
  std::size_t bytes =
      table_.memoryBytes() + m.pts.capacity() * sizeof(Impl::Point) + m.vertex.capacity() * sizeof(VH) +
      (m.graphStart.capacity() + m.graphAdj.capacity() + m.nextImage.capacity() + m.firstImage.capacity()) *
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
      "(explicit replication within R + R_max of periodic faces); {} layer(s), {} hidden in the first; updates: "
      "{} incremental ({} vertices relocated in place, {} by CGAL move()), {} rebuilt)",
      stats_.points, stats_.images, stats_.layers, stats_.hidden, stats_.moves, stats_.inPlace, stats_.cgalMoves,
      stats_.rebuilds);
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
