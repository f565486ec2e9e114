#pragma once
// Conversions between numpy arrays and the engine's Eigen arrays, shared by the binding files.
//
// Layout: the engine keeps centres as a column-major 3 x N matrix (x, y, z of a particle adjacent), which is
// exactly a C-contiguous numpy array of shape (N, 3). Arrays of that layout (and Fortran-ordered (3, N)
// arrays, the same bytes) are read without a copy; any other float64-convertible array is copied once.
// Arrays handed back to Python are (N, 3) and (N,), float64 or int32.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "core/box.hpp"
#include "core/types.hpp"

namespace polydem::python {

namespace py = pybind11;

/// Module-level registration, one per binding file (module.cpp calls them in order).
void bindDistributions(py::module_& m);
void bindBroadPhase(py::module_& m);
void bindSimulation(py::module_& m);
void bindJamming(py::module_& m);
void bindIo(py::module_& m);
void bindAnalysis(py::module_& m);

using DoubleArray = py::array_t<double, py::array::forcecast>;
using IndexArray = py::array_t<Index, py::array::forcecast>;

/// Centres given as (N, 3) or (3, N) float64 (shape (3, 3) is read as (N, 3)): a map onto the caller's
/// memory when the layout allows, else a copy. Keeps the array it maps alive. Throws ConfigError naming
/// `what` for any other shape.
class Centres {
 public:
  Centres(const py::handle& object, const std::string& what);
  Centres(const Centres&) = delete;
  Centres& operator=(const Centres&) = delete;
  Eigen::Ref<const Eigen::Matrix3Xd> matrix() const { return map_; }
  Index count() const { return static_cast<Index>(map_.cols()); }
  /// True when matrix() reads the caller's array (no copy was made).
  bool zeroCopy() const { return !copy_.has_value(); }

 private:
  py::object keep_;
  std::optional<Eigen::Matrix3Xd> copy_;
  Eigen::Map<const Eigen::Matrix3Xd> map_{nullptr, 3, 0};
};

/// Radii as a float64 vector of length `count` (-1: any length); a map when contiguous float64, else a copy.
class Radii {
 public:
  Radii(const py::handle& object, const std::string& what, Index count = -1);
  Radii(const Radii&) = delete;
  Radii& operator=(const Radii&) = delete;
  Eigen::Ref<const Eigen::VectorXd> vector() const { return map_; }
  Index count() const { return static_cast<Index>(map_.size()); }

 private:
  DoubleArray keep_;
  Eigen::Map<const Eigen::VectorXd> map_{nullptr, 0};
};

/// A copy of (N, 3) / (3, N) centres as a 3 x N matrix.
Eigen::Matrix3Xd toMatrix3X(const py::handle& object, const std::string& what);
/// A copy of a 1-D float64 array.
Eigen::VectorXd toVector(const py::handle& object, const std::string& what);
/// A 1-D int32 array as a vector of Index.
std::vector<Index> toIndices(const py::handle& object, const std::string& what);

/// (N, 3) float64 copy of a 3 x N matrix.
py::array_t<double> copyOut(const Eigen::Matrix3Xd& m);
/// (N,) float64 copy.
py::array_t<double> copyOut(const Eigen::VectorXd& v);
/// (N,) int32 copy.
py::array_t<Index> copyOut(const std::vector<Index>& v);
/// (N, 3) read-only view of a 3 x N matrix owned by `owner` (kept alive by the array).
py::array_t<double> viewOf(const Eigen::Matrix3Xd& m, const py::handle& owner);
/// (N,) read-only view.
py::array_t<double> viewOf(const Eigen::VectorXd& v, const py::handle& owner);
py::array_t<Index> viewOf(const std::vector<Index>& v, const py::handle& owner);

/// "periodic", "walls", "periodic,periodic,wall" or a sequence of three such words (the CLI's rule).
std::array<Boundary, 3> boundariesFrom(const py::handle& object);
/// The three boundary words of a box, e.g. ("periodic", "periodic", "wall").
py::tuple boundaryWords(const Box& box);
/// A Box, or a (lengths, boundaries) pair, or three lengths (then `boundaries`).
Box boxFrom(const py::handle& object, const py::handle& boundaries);

}  // namespace polydem::python
