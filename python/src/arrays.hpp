#pragma once
// NumPy arrays in and out: (N, 3) float64 positions read in place where their layout allows,
// results handed to NumPy without a copy (the array owns the library's vector).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "pointfair/types.hpp"

namespace pointfair::python {

namespace py = pybind11;

/// Whether `dtype` is stored in the machine's byte order (or has none, as 1-byte types).
bool native_order(const py::dtype& dtype);

/// Positions as the library reads them, and what keeps them alive.
struct PointsIn {
  std::span<const Vec3> points;
  /// The array `points` views: the caller's own when it is C-contiguous, aligned float64
  /// (no copy), else a C-contiguous copy of it.
  py::array owner;
};

/// `object` as (N, 3) float64 positions. An ndarray must be float64 of shape (N, 3); any other
/// object is converted with numpy.asarray(object, dtype=float64) first. A float64 array with
/// other strides (a slice, a transpose, Fortran order) is copied. Throws ParamError (ValueError)
/// "<what>: ..." naming the dtype or shape found.
PointsIn points_in(py::handle object, std::string_view what);

/// A new (N, 3) float64 array that owns `points` (moved, not copied).
py::array_t<double> points_out(std::vector<Vec3>&& points);

/// A new (N,) array that owns `values` (moved, not copied).
template <class T>
py::array_t<T> column_out(std::vector<T>&& values) {
  const auto n = static_cast<py::ssize_t>(values.size());
  if (n == 0) return py::array_t<T>(py::ssize_t{0});
  auto* held = new std::vector<T>(std::move(values));
  py::capsule owner(held, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>({n}, {static_cast<py::ssize_t>(sizeof(T))}, held->data(), owner);
}

}  // namespace pointfair::python
