#include "python/convert.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "apps/polydem/common.hpp"
#include "core/errors.hpp"

namespace polydem::python {

namespace {

std::string shapeText(const py::array& a) {
  std::string t = "(";
  for (py::ssize_t k = 0; k < a.ndim(); ++k) t += fmt::format("{}{}", k ? ", " : "", a.shape(k));
  return t + (a.ndim() == 1 ? ",)" : ")");
}

}  // namespace

Centres::Centres(const py::handle& object, const std::string& what) {
  auto any = py::array::ensure(object);
  if (!any) throw ConfigError(fmt::format("{}: expected an array of shape (N, 3) or (3, N)", what));
  const bool rows = any.ndim() == 2 && any.shape(1) == 3;
  const bool columns = any.ndim() == 2 && any.shape(0) == 3 && !rows;
  if (!rows && !columns) {
    throw ConfigError(
        fmt::format("{}: expected an array of shape (N, 3) or (3, N), got shape {}", what, shapeText(any)));
  }
  const bool isDouble = any.dtype().is(py::dtype::of<double>());
  const bool sameBytes = rows ? (any.flags() & py::array::c_style) != 0 : (any.flags() & py::array::f_style) != 0;
  // Only the caller's own array counts: a list or another dtype was converted into a temporary by ensure().
  if (isDouble && sameBytes && any.ptr() == object.ptr()) {
    keep_ = any;
    const Index n = static_cast<Index>(rows ? any.shape(0) : any.shape(1));
    new (&map_) Eigen::Map<const Eigen::Matrix3Xd>(static_cast<const double*>(any.data()), 3, n);
    return;
  }
  copy_ = toMatrix3X(object, what);
  new (&map_) Eigen::Map<const Eigen::Matrix3Xd>(copy_->data(), 3, copy_->cols());
}

Radii::Radii(const py::handle& object, const std::string& what, Index count) {
  keep_ = DoubleArray::ensure(object);
  if (!keep_ || keep_.ndim() != 1) {
    throw ConfigError(fmt::format("{}: expected a 1-D array of radii", what));
  }
  if (count >= 0 && keep_.shape(0) != count) {
    throw ConfigError(fmt::format("{}: {} radii for {} centres", what, keep_.shape(0), count));
  }
  if (!(keep_.flags() & py::array::c_style)) keep_ = DoubleArray(py::array::ensure(keep_, py::array::c_style));
  new (&map_) Eigen::Map<const Eigen::VectorXd>(keep_.data(), keep_.shape(0));
}

Eigen::Matrix3Xd toMatrix3X(const py::handle& object, const std::string& what) {
  auto a = DoubleArray::ensure(object);
  if (!a || a.ndim() != 2 || (a.shape(1) != 3 && a.shape(0) != 3)) {
    throw ConfigError(fmt::format("{}: expected an array of shape (N, 3) or (3, N)", what));
  }
  const bool rows = a.shape(1) == 3;
  const Index n = static_cast<Index>(rows ? a.shape(0) : a.shape(1));
  Eigen::Matrix3Xd m(3, n);
  auto r = a.unchecked<2>();
  for (Index i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) m(k, i) = rows ? r(i, k) : r(k, i);
  }
  return m;
}

Eigen::VectorXd toVector(const py::handle& object, const std::string& what) {
  auto a = DoubleArray::ensure(object);
  if (!a || a.ndim() != 1) throw ConfigError(fmt::format("{}: expected a 1-D array", what));
  Eigen::VectorXd v(a.shape(0));
  auto r = a.unchecked<1>();
  for (py::ssize_t i = 0; i < a.shape(0); ++i) v[i] = r(i);
  return v;
}

std::vector<Index> toIndices(const py::handle& object, const std::string& what) {
  auto a = IndexArray::ensure(object);
  if (!a || a.ndim() != 1) throw ConfigError(fmt::format("{}: expected a 1-D integer array", what));
  auto r = a.unchecked<1>();
  std::vector<Index> v(static_cast<std::size_t>(a.shape(0)));
  for (py::ssize_t i = 0; i < a.shape(0); ++i) v[static_cast<std::size_t>(i)] = r(i);
  return v;
}

py::array_t<double> copyOut(const Eigen::Matrix3Xd& m) {
  py::array_t<double> a({static_cast<py::ssize_t>(m.cols()), py::ssize_t{3}});
  std::copy(m.data(), m.data() + m.size(), a.mutable_data());
  return a;
}

py::array_t<double> copyOut(const Eigen::VectorXd& v) {
  py::array_t<double> a(static_cast<py::ssize_t>(v.size()));
  std::copy(v.data(), v.data() + v.size(), a.mutable_data());
  return a;
}

py::array_t<Index> copyOut(const std::vector<Index>& v) {
  py::array_t<Index> a(static_cast<py::ssize_t>(v.size()));
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

namespace {
template <typename T>
py::array_t<T> readOnly(py::array_t<T> a) {
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}
}  // namespace

py::array_t<double> viewOf(const Eigen::Matrix3Xd& m, const py::handle& owner) {
  return readOnly(py::array_t<double>({static_cast<py::ssize_t>(m.cols()), py::ssize_t{3}},
                                      {static_cast<py::ssize_t>(3 * sizeof(double)), py::ssize_t{sizeof(double)}},
                                      m.data(), owner));
}

py::array_t<double> viewOf(const Eigen::VectorXd& v, const py::handle& owner) {
  return readOnly(
      py::array_t<double>({static_cast<py::ssize_t>(v.size())}, {py::ssize_t{sizeof(double)}}, v.data(), owner));
}

py::array_t<Index> viewOf(const std::vector<Index>& v, const py::handle& owner) {
  return readOnly(
      py::array_t<Index>({static_cast<py::ssize_t>(v.size())}, {py::ssize_t{sizeof(Index)}}, v.data(), owner));
}

std::array<Boundary, 3> boundariesFrom(const py::handle& object) {
  if (py::isinstance<py::str>(object)) return app::parseBoundaries(object.cast<std::string>());
  std::string text;
  for (const py::handle& word : object) text += (text.empty() ? "" : ",") + py::str(word).cast<std::string>();
  return app::parseBoundaries(text);
}

py::tuple boundaryWords(const Box& box) {
  py::tuple t(3);
  for (int k = 0; k < 3; ++k) t[static_cast<std::size_t>(k)] = py::str(box.periodic(k) ? "periodic" : "wall");
  return t;
}

Box boxFrom(const py::handle& object, const py::handle& boundaries) {
  if (py::isinstance<Box>(object)) return object.cast<Box>();
  const Eigen::VectorXd lengths = toVector(object, "box");
  if (lengths.size() != 3) throw ConfigError(fmt::format("box: expected three edge lengths, got {}", lengths.size()));
  return Box(Eigen::Vector3d(lengths[0], lengths[1], lengths[2]),
             boundaries.is_none() ? std::array<Boundary, 3>{Boundary::Periodic, Boundary::Periodic, Boundary::Periodic}
                                  : boundariesFrom(boundaries));
}

}  // namespace polydem::python
