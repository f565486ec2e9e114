#pragma once
// Which linear-programming solver the jamming tests use: GLPK's simplex (optional, libglpk-dev) for up
// to kSimplexLimit spheres, the interior point of jamming/interior_point.hpp beyond.

namespace polydem::jamming {

enum class LpSolver {
  Automatic,      ///< GLPK's simplex up to kSimplexLimit movable spheres (if built with GLPK), else interior point
  Simplex,        ///< GLPK's simplex (exact vertex; minutes at N = 1000, does not finish at N = 10,000)
  InteriorPoint,  ///< jamming/interior_point.hpp on the force form (about a minute per load at N = 10,000)
};
inline constexpr int kSimplexLimit = 2000;

/// True if this build has GLPK (the ideal-contact test and the simplex load test; the interior-point
/// load test is always built).
bool jammingTestAvailable();

}  // namespace polydem::jamming
