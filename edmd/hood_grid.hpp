#pragma once
// The index of bounding neighbourhoods that answers the one query of a neighbourhood exit (Donev 2006,
// thesis, §3.4.7, Algorithm 10): which neighbourhoods
// overlap the re-centred neighbourhood of sphere i. A multi-level grid: level l holds the spheres with
// radius in [r_min 2^l, r_min 2^(l+1)), in cells of at least twice the level's largest radius, each cell a
// doubly linked list, so a move is O(1) and a query visits the cells within r_i + (largest radius of the
// level) on every level (the top-down search of Ogarko's thesis §2.2.3;
// Krijgsman, Ogarko & Luding, Comp. Part. Mech. 1 (2014) 357).
//
// Why EDMD keeps its own index instead of the shared broad phase's update() + findNeighbours() (STYLE
// §4): an exit moves one sphere, and the shared HGrid parks every sphere that changed cell in an
// overflow hash until its next build; in an event-driven run every neighbourhood moves a few times
// between global rebuilds, so queries ran almost entirely through that hash (profile of the mono
// N = 10,000 run at phi 0.5: 28% of the time in exits, mostly hash probes; uniform volume omega = 50:
// 65%). The broad phase still builds the lists at every global rebuild.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "core/box.hpp"
#include "core/types.hpp"

namespace polydem::edmd {

class HoodGrid {
 public:
  /// Index N spheres (centres 3 x N inside the box, radii > 0). O(N + cells); cells per level <= 8 N.
  void build(const Box& box, const Eigen::Matrix3Xd& centre, const Eigen::VectorXd& radius);
  /// Sphere i now has its centre at x (inside the box; radius unchanged). O(1).
  void move(Index i, const double x[3]);
  /// Every j != i with |c_i - c_j| <= r_i + r_j (minimum image on periodic axes; the predicate
  /// broadphase::spheresWithinReach with reach 0), ascending. Clears out.
  void overlapping(Index i, std::vector<Index>& out) const;

 private:
  struct Level {
    double rmax = 0.0;
    std::array<double, 3> inverseCell{};
    std::array<double, 3> cell{};
    std::array<std::int32_t, 3> n{};
    std::vector<Index> head;  // first sphere of each cell, -1 if empty
  };
  std::int64_t cellOf(const Level& lv, const double x[3]) const;
  void link(Index i);
  void unlink(Index i);

  Box box_;
  std::array<bool, 3> periodic_{};
  std::array<double, 3> length_{};
  std::vector<Level> levels_;
  std::vector<double> xyzr_;  // 4 per sphere: centre and radius, packed for the query loop
  std::vector<std::uint8_t> level_;
  std::vector<std::int64_t> cell_;
  std::vector<Index> next_, prev_;
};

}  // namespace polydem::edmd
