#pragma once
// Bond-orientational order and crystallinity (Ogarko's thesis §3.3.3, eqs. 3.56-3.57; Ogarko & Luding, Soft Matter 9
// (2013) 9530):
//   q_lm(i) = (1 / N_b(i)) sum_{j in nb(i)} Y_lm(r_ij / |r_ij|)                       (3.56)
//   q_l(i)  = sqrt(4 pi / (2l + 1) sum_m |q_lm(i)|^2)        (Steinhardt's rotational invariant)
//   q~_lm(i) = q_lm(i) / sqrt(sum_m |q_lm(i)|^2),  d_l(i, j) = Re sum_m q~_lm(i) conj(q~_lm(j))  (3.57)
// i and j are connected if d_6(i, j) > 0.65; i is solid-like with >= 6 connections; p_c = N_solid / N.
// Global Q_l averages over all bonds: Q_lm = sum_i sum_j Y_lm / sum_i N_b(i).
// Perfect lattices with their first shell: q6 = 0.5745 (FCC, 12), 0.4848 (HCP, 12), 0.3536 (SC, 6),
// 0.6285 (BCC, 8) and 0.5107 (BCC, 8 + 6 = its 14 Delaunay neighbours), which is where the literature's
// "BCC 0.5106" comes from. With Delaunay neighbours, degenerate lattices (FCC/HCP octahedra, SC cubes)
// get tie-broken extra neighbours, so their q6 moves away from the first-shell values.
#include <Eigen/Core>
#include <complex>
#include <vector>

#include "structure/delaunay_neighbours.hpp"

namespace polydem::structure {

struct BondOrderOptions {
  int degree = 6;                     ///< l
  double connectionThreshold = 0.65;  ///< connected if d_l(i, j) > this
  int minConnections = 6;             ///< solid-like with at least this many connections
};

struct BondOrder {
  int degree = 6;
  Eigen::MatrixXcd normalised;   ///< (2l + 1) x N: q~_lm(i), zero for particles without neighbours
  std::vector<double> q;         ///< q_l(i); 0 without neighbours
  std::vector<int> connections;  ///< neighbours j with d_l(i, j) > threshold
  std::vector<char> solid;       ///< 1 = solid-like
  Index solidCount = 0;
  double crystallineFraction = 0.0;  ///< p_c = N_solid / N
  double meanQ = 0.0;                ///< <q_l(i)> over particles with neighbours
  double globalQ = 0.0;              ///< Q_l over all bonds
};

/// q_lm, q_l, connections, solid-like particles and p_c over the given neighbour lists (neighbour list
/// displacements give the bond directions). O(entries l^2). Throws ConfigError for l outside 0..12, a
/// threshold outside [-1, 1] or negative minConnections.
BondOrder bondOrder(const NeighbourList& neighbours, const BondOrderOptions& options = {});

/// d_l(i, j) of two particles of `order`.
double bondCorrelation(const BondOrder& order, Index i, Index j);

}  // namespace polydem::structure
