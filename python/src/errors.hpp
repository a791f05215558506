#pragma once
// The library's errors as Python exceptions: pointfair.IoError (an OSError) for files,
// pointfair.ParamError (a ValueError) for parameters and options; both carry the library's
// message, which names the file or the parameter and the problem.
#include <pybind11/pybind11.h>

namespace pointfair::python {

void register_errors(pybind11::module_& module);

}  // namespace pointfair::python
