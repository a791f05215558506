#pragma once
// pointfair.smooth, pointfair.curvature and pointfair.smooth_file.
#include <pybind11/pybind11.h>

namespace pointfair::python {

void bind_smooth(pybind11::module_& module);

}  // namespace pointfair::python
