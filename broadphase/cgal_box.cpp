#include "broadphase/cgal_box.hpp"

#include <CGAL/box_intersection_d.h>
#include <fmt/format.h>

#include <algorithm>

#include "core/errors.hpp"

namespace polydem::broadphase {

namespace {

// The box type CGAL's Box_traits_d reads: closed interval per axis and a unique id (the box's slot;
// slots >= N are periodic images). Our own type rather than Box_d<ID_EXPLICIT>, whose ids come from
// a global counter instead of the particle index.
struct SphereBox {
  using NT = double;
  using ID = std::size_t;
  double lo[3], hi[3];
  std::size_t slot;
  static int dimension() { return 3; }
  double min_coord(int d) const { return lo[d]; }
  double max_coord(int d) const { return hi[d]; }
  std::size_t id() const { return slot; }
};

}  // namespace

void CgalBox::doBuild(const SphereView& spheres) {
  const Index n = spheres.count();
  // Margin far above the round-off of coordinate differences, so no accepted pair is pruned.
  const double margin = 1e-12 * (box_.lengths().maxCoeff() + 2.0 * maxRadius_ + skin_);
  std::vector<SphereBox> boxes;
  std::vector<Index> owner;  // particle per box slot
  boxes.reserve(static_cast<std::size_t>(n) + static_cast<std::size_t>(n) / 4);
  owner.reserve(boxes.capacity());
  auto add = [&](const double* c, double e, const Eigen::Vector3d& shift, Index particle) {
    SphereBox b;
    for (int k = 0; k < 3; ++k) {
      b.lo[k] = c[k] + shift[k] - e;
      b.hi[k] = c[k] + shift[k] + e;
    }
    b.slot = boxes.size();
    boxes.push_back(b);
    owner.push_back(particle);
  };
  for (Index i = 0; i < n; ++i)
    add(spheres.centre.col(i).data(), spheres.radius[i] + 0.5 * skin_ + margin, Eigen::Vector3d::Zero(), i);
  // Images: along a periodic axis a pair meeting through the face has one of its two spheres within
  // its own half-extent of that face, so images of those spheres (and their combinations over axes,
  // matched image-to-image too) cover every pair.
  images_ = 0;
  for (Index i = 0; i < n; ++i) {
    const double* c = spheres.centre.col(i).data();
    const double e = spheres.radius[i] + 0.5 * skin_ + margin;
    double options[3][3];
    int counts[3];
    for (int k = 0; k < 3; ++k) {
      counts[k] = 0;
      options[k][counts[k]++] = 0.0;
      if (!box_.periodic(k)) continue;
      if (c[k] - e <= 0.0) options[k][counts[k]++] = box_.length(k);
      if (c[k] + e >= box_.length(k)) options[k][counts[k]++] = -box_.length(k);
    }
    for (int a = 0; a < counts[0]; ++a) {
      for (int b = 0; b < counts[1]; ++b) {
        for (int d = 0; d < counts[2]; ++d) {
          if (a == 0 && b == 0 && d == 0) continue;
          add(c, e, Eigen::Vector3d(options[0][a], options[1][b], options[2][d]), i);
          ++images_;
        }
      }
    }
  }
  boxBytes_ = 2 * boxes.capacity() * sizeof(SphereBox) + owner.capacity() * sizeof(Index);

  scratch_.clear();
  candidates_ = 0;
  std::uint64_t tests = 0;
  auto report = [&](const SphereBox& a, const SphereBox& b) {
    ++tests;
    const Index i = owner[a.slot], j = owner[b.slot];
    if (i == j) return;  // a sphere and its own image
    if (withinReach(spheres, box_, i, j, skin_)) scratch_.push_back(i < j ? Pair{i, j} : Pair{j, i});
  };
  // Closed boxes: touching boxes intersect, so gap == skin is reported.
  CGAL::box_self_intersection_d(boxes.begin(), boxes.end(), report, std::ptrdiff_t(10),
                                CGAL::Box_intersection_d::CLOSED);
  candidates_ = tests;
  if (counting_) counters_.pairTests += tests;
  table_.assign(std::move(scratch_), n);
}

void CgalBox::findPairs(const SphereView&, std::vector<Pair>& out) const {
  out.assign(table_.pairs().begin(), table_.pairs().end());
}

void CgalBox::findNeighbours(const SphereView& spheres, Index i, double reach, std::vector<Index>& out) const {
  if (!(reach >= 0.0 && reach <= skin_)) {
    throw ConfigError(fmt::format("findNeighbours: reach {} must lie in [0, skin = {}]", reach, skin_));
  }
  table_.neighbours(spheres, box_, i, reach, out);
}

std::size_t CgalBox::memoryBytes() const { return table_.memoryBytes() + boxBytes_; }

std::string CgalBox::describe() const {
  return fmt::format("cgal-box (CGAL::box_self_intersection_d, closed boxes, {} periodic image boxes)", images_);
}

}  // namespace polydem::broadphase
