#pragma once
// pointfair.read and pointfair.write: point files as dicts of arrays.
#include <pybind11/pybind11.h>

namespace pointfair::python {

void bind_io(pybind11::module_& module);

}  // namespace pointfair::python
