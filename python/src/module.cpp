// pointfair._pointfair: the library's functions on NumPy arrays (python/pointfair/__init__.py
// is the package's face).
#include <pybind11/pybind11.h>

#include <cstdint>
#include <string>

#include "bind_io.hpp"
#include "bind_smooth.hpp"
#include "errors.hpp"
#include "arrays.hpp"
#include "pointfair/common/version.hpp"

namespace py = pybind11;

PYBIND11_MODULE(_pointfair, m) {
  m.doc() = "pointfair: denoising point clouds with the anisotropic mean curvature flow";
  m.attr("__version__") = std::string(pointfair::version());
  pointfair::python::register_errors(m);
  pointfair::python::bind_smooth(m);
  pointfair::python::bind_io(m);
  // The address the library reads `points` from: the array's own data when no copy is made.
  m.def("_points_address", [](const py::handle& points) {
    const auto in = pointfair::python::points_in(points, "points");
    return reinterpret_cast<std::uintptr_t>(in.points.data());
  });
}
