#include "errors.hpp"

#include "cli/arguments.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/io/point_table.hpp"

namespace pointfair::python {

namespace py = pybind11;

void register_errors(py::module_& module) {
  py::register_exception<io::IoError>(module, "IoError", PyExc_OSError);
  const auto& param_error = py::register_exception<ParamError>(module, "ParamError", PyExc_ValueError);
  // An option the CLI's parser refuses is a parameter error here.
  static PyObject* const param_type = param_error.ptr();
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const cli::UsageError& e) {
      PyErr_SetString(param_type, e.what());
    }
  });
}

}  // namespace pointfair::python
