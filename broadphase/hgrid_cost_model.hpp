#pragma once
// The HGrid cost model: the expected work of a hierarchical grid and the optimiser that picks its levels
// and cell sizes (thesis §2.2.3-§2.2.5). This header gathers the parts, one concept per file pair:
//   hgrid_cost_psd.hpp         the size distribution as the model sees it: number density and partial
//                              moments int r^k f(r) dr over bands of interaction diameter
//   hgrid_cost_evaluation.hpp  T/N of eq. 2.35 for given levels (cubic or snapped cells) and the cost
//                              ratio K; what K means
//   hgrid_cell_sizes.hpp       the cell-size rules of §2.2.5 and the appendix procedure of ch. 2.1
//   minimisers.hpp             generic Nelder-Mead and BFGS (tested on their own)
//   hgrid_optimiser.hpp        the "optimal" rule, the level/mode optimiser and its cache
//   calibrate_k.hpp            K measured on this machine: the one K the library uses
//
// References (thesis numbering): V. Ogarko, PhD thesis on polydisperse smooth hard spheres (University of
// Twente), ch. 2; its ch. 2.1 is Ogarko & Luding, Comput. Phys. Commun. 183 (2012) 931 and its ch. 2.2 is
// Krijgsman, Ogarko & Luding, Comp. Part. Mech. 1 (2014) 357.
#include "broadphase/hgrid_cell_sizes.hpp"
#include "broadphase/hgrid_cost_evaluation.hpp"
#include "broadphase/hgrid_cost_psd.hpp"
#include "broadphase/hgrid_optimiser.hpp"
