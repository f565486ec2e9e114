#pragma once
// GLPK's simplex as the jamming tests call it (internal to polydem_jamming; sources that include this
// are compiled with POLYDEM_JAMMING_WITH_GLPK = 0 or 1 by jamming/CMakeLists.txt).
#if POLYDEM_JAMMING_WITH_GLPK
#include <fmt/format.h>
#include <glpk.h>

#include <algorithm>

#include "core/errors.hpp"

namespace polydem::jamming::glpk {

/// Owns one GLPK problem.
struct Lp {
  glp_prob* p = glp_create_prob();
  ~Lp() { glp_delete_prob(p); }
  Lp() = default;
  Lp(const Lp&) = delete;
  Lp& operator=(const Lp&) = delete;
};

/// Simplex iterations allowed per attempt: 50 per row and column (the load LPs of the tests take a few per row;
/// a degenerate LP on which GLPK's simplex cycles, seen on a 300-sphere walled packing, would run forever).
inline int iterationLimit(glp_prob* p) { return std::max(20000, 50 * (glp_get_num_rows(p) + glp_get_num_cols(p))); }

/// Simplex with presolve, retried once on the scaled problem; the solution status (GLP_OPT, ...).
/// Throws SimulationError if GLPK fails twice (a numerical failure or the iteration limit both times).
inline int solve(glp_prob* p) {
  glp_smcp parm;
  glp_init_smcp(&parm);
  parm.msg_lev = GLP_MSG_OFF;
  parm.presolve = GLP_ON;
  parm.it_lim = iterationLimit(p);
  int rc = glp_simplex(p, &parm);
  if (rc != 0) {
    // Presolve plus the default scaling can end in a numerical failure (GLP_EFAIL, seen on load LPs with
    // hard walls); retry on the scaled problem from an advanced basis without presolve.
    glp_scale_prob(p, GLP_SF_AUTO);
    glp_adv_basis(p, 0);
    parm.presolve = GLP_OFF;
    glp_set_it_cnt(p, 0);
    rc = glp_simplex(p, &parm);
  }
  if (rc != 0) {
    throw SimulationError(fmt::format("jamming test: GLPK simplex failed (return code {}{})", rc,
                                      rc == GLP_EITLIM ? ": iteration limit" : ""));
  }
  return glp_get_status(p);
}

}  // namespace polydem::jamming::glpk
#endif
