#include "arrays.hpp"

#include <bit>
#include <string>

#include "pointfair/common/params_error.hpp"

namespace pointfair::python {

using namespace pybind11::literals;

namespace {

std::string shape_text(const py::array& a) {
  std::string text = "(";
  for (py::ssize_t d = 0; d < a.ndim(); ++d) {
    if (d > 0) text += ", ";
    text += std::to_string(a.shape(d));
  }
  return text + (a.ndim() == 1 ? ",)" : ")");
}

}  // namespace

bool native_order(const py::dtype& dtype) {
  const char order = dtype.byteorder();
  constexpr char native = std::endian::native == std::endian::little ? '<' : '>';
  return order == '=' || order == '|' || order == native;
}

PointsIn points_in(py::handle object, std::string_view what) {
  const py::module_ numpy = py::module_::import("numpy");
  const std::string name(what);
  py::array array;
  if (py::isinstance<py::array>(object)) {
    array = py::reinterpret_borrow<py::array>(object);
  } else {
    try {
      array = numpy.attr("asarray")(object, "dtype"_a = numpy.attr("float64"));
    } catch (const py::error_already_set& e) {
      throw ParamError(name + ": not convertible to an array of float64 positions (" + e.what() + ")");
    }
  }
  const std::string dtype = py::str(array.dtype()).cast<std::string>();
  // Native-order float64 only: the positions are read as doubles where they lie.
  const py::dtype type = array.dtype();
  if (type.kind() != 'f' || type.itemsize() != 8 || !native_order(type))
    throw ParamError(name + ": expected dtype float64, got " + dtype + " (convert with .astype(numpy.float64))");
  if (array.ndim() != 2 || array.shape(1) != 3)
    throw ParamError(name + ": expected an array of shape (N, 3), got shape " + shape_text(array));
  const bool contiguous = (array.flags() & py::array::c_style) != 0;
  const bool aligned = reinterpret_cast<std::uintptr_t>(array.data()) % alignof(double) == 0;
  if (!contiguous || !aligned) array = numpy.attr("ascontiguousarray")(array);
  PointsIn in;
  in.owner = array;
  in.points = {static_cast<const Vec3*>(array.data()), static_cast<std::size_t>(array.shape(0))};
  return in;
}

py::array_t<double> points_out(std::vector<Vec3>&& points) {
  const auto n = static_cast<py::ssize_t>(points.size());
  if (n == 0) return py::array_t<double>(std::vector<py::ssize_t>{0, 3});
  auto* held = new std::vector<Vec3>(std::move(points));
  py::capsule owner(held, [](void* p) { delete static_cast<std::vector<Vec3>*>(p); });
  static_assert(sizeof(Vec3) == 3 * sizeof(double));
  return py::array_t<double>({n, py::ssize_t{3}},
                             {static_cast<py::ssize_t>(sizeof(Vec3)), static_cast<py::ssize_t>(sizeof(double))},
                             held->front().data(), owner);
}

}  // namespace pointfair::python
