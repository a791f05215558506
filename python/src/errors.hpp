#pragma once
// The library's errors as Python exceptions: pointfair.IoError (an OSError) for files,
// pointfair.ParamError (a ValueError) for parameters and options; both carry the library's
// message, which names the file or the parameter and the problem.
#include <pybind11/pybind11.h>

#include <string>

namespace pointfair::python {

void register_errors(pybind11::module_& module);

/// Raises NotImplementedError(message) (as a C++ exception that pybind11 passes on).
[[noreturn]] void throw_not_implemented(const std::string& message);

}  // namespace pointfair::python
