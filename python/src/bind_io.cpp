#include "bind_io.hpp"

#include <pybind11/numpy.h>

#include <string>
#include <vector>

#include "arrays.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/io/point_file.hpp"
#include "cli/run_support.hpp"

namespace pointfair::python {
namespace {

template <class T>
py::array typed_column(const std::vector<double>& values) {
  std::vector<T> typed(values.size());
  for (std::size_t i = 0; i < values.size(); ++i) typed[i] = static_cast<T>(values[i]);
  return column_out(std::move(typed));
}

py::array column_of(const io::Attribute& a) {
  using io::ScalarType;
  switch (a.type) {
    case ScalarType::Int8: return typed_column<std::int8_t>(a.values);
    case ScalarType::UInt8: return typed_column<std::uint8_t>(a.values);
    case ScalarType::Int16: return typed_column<std::int16_t>(a.values);
    case ScalarType::UInt16: return typed_column<std::uint16_t>(a.values);
    case ScalarType::Int32: return typed_column<std::int32_t>(a.values);
    case ScalarType::UInt32: return typed_column<std::uint32_t>(a.values);
    case ScalarType::Float32: return typed_column<float>(a.values);
    case ScalarType::Float64: return column_out(std::vector<double>(a.values));
  }
  return column_out(std::vector<double>(a.values));
}

py::dict read(const std::string& path) {
  io::PointTable table;
  std::vector<std::string> warnings;
  {
    const py::gil_scoped_release release;
    io::ReadOptions options;
    options.on_warning = [&warnings](const std::string& message) { warnings.push_back(message); };
    table = io::read_points(path, options);
  }
  // The reader's notes on recoverable oddities ("faces ignored"), as the command prints them.
  for (const std::string& message : warnings)
    if (PyErr_WarnEx(PyExc_RuntimeWarning, message.c_str(), 1) != 0) throw py::error_already_set();
  py::dict out;
  out["xyz"] = points_out(std::move(table.positions));
  for (const io::Attribute& a : table.attributes) out[py::str(a.name)] = column_of(a);
  return out;
}

// The file type of a NumPy dtype: the eight the formats store; bool as uint8; 64-bit integers
// as int32/uint32 when every value fits (NumPy's default integer is int64).
io::ScalarType scalar_type(const std::string& name, const py::array& values) {
  using io::ScalarType;
  const py::dtype type = values.dtype();
  const char kind = type.kind();
  const auto size = type.itemsize();
  const std::string dtype = py::str(py::handle(type)).cast<std::string>();
  if (!native_order(type)) throw ParamError(name + ": dtype " + dtype + " is not in the machine's byte order");
  if (kind == 'b') return ScalarType::UInt8;
  if (kind == 'f' && size == 4) return ScalarType::Float32;
  if (kind == 'f' && size == 8) return ScalarType::Float64;
  if (kind == 'i' && size == 1) return ScalarType::Int8;
  if (kind == 'i' && size == 2) return ScalarType::Int16;
  if (kind == 'i' && size == 4) return ScalarType::Int32;
  if (kind == 'u' && size == 1) return ScalarType::UInt8;
  if (kind == 'u' && size == 2) return ScalarType::UInt16;
  if (kind == 'u' && size == 4) return ScalarType::UInt32;
  if ((kind == 'i' || kind == 'u') && size == 8) {
    const py::module_ numpy = py::module_::import("numpy");
    const ScalarType narrow = kind == 'i' ? ScalarType::Int32 : ScalarType::UInt32;
    const py::object info = numpy.attr("iinfo")(kind == 'i' ? "int32" : "uint32");
    if (values.size() == 0 || (py::int_(values.attr("min")()) >= info.attr("min") &&
                               py::int_(values.attr("max")()) <= info.attr("max")))
      return narrow;
    throw ParamError(name + ": " + dtype + " values beyond " + (kind == 'i' ? "int32" : "uint32") +
                     ", the widest integer the formats store");
  }
  throw ParamError(name + ": dtype " + dtype +
                   " cannot be stored (int8/16/32, uint8/16/32, float32/64 or bool; int64 within int32)");
}

void write(const std::string& path, const py::dict& cloud, const py::object& encoding) {
  if (!cloud.contains("xyz")) throw ParamError(path + ": the cloud has no 'xyz' entry (the (N, 3) positions)");
  io::PointTable table;
  // Positions: float64, or float32 (then stored as float where the format lets it choose).
  py::object xyz = cloud["xyz"];
  if (py::isinstance<py::array>(xyz)) {
    const py::dtype t = py::reinterpret_borrow<py::array>(xyz).dtype();
    if (t.kind() == 'f' && t.itemsize() == 4 && native_order(t)) {
      table.position_type = io::ScalarType::Float32;
      xyz = xyz.attr("astype")("float64");
    }
  }
  const PointsIn in = points_in(xyz, "xyz");
  table.positions.assign(in.points.begin(), in.points.end());
  const auto n = static_cast<py::ssize_t>(table.size());
  const py::module_ numpy = py::module_::import("numpy");
  for (const auto& [key, value] : cloud) {
    const std::string name = py::str(key).cast<std::string>();
    if (name == "xyz") continue;
    const py::array column = numpy.attr("asarray")(value);
    if (column.ndim() != 1 || column.shape(0) != n)
      throw ParamError(name + ": expected an array of shape (" + std::to_string(n) + ",) (one value a point), got " +
                       py::str(py::object(column.attr("shape"))).cast<std::string>());
    const io::ScalarType type = scalar_type(name, column);
    const py::array_t<double, py::array::c_style | py::array::forcecast> doubles(column);
    table.set(name, type, std::vector<double>(doubles.data(), doubles.data() + n));
  }
  io::WriteOptions options;
  if (!encoding.is_none()) {
    const std::string text = py::str(encoding).cast<std::string>();
    options.ply_encoding = cli::ply_encoding(text);
    if (!options.ply_encoding) throw ParamError("encoding must be one of binary, binary-be, ascii, got '" + text + "'");
  }
  const py::gil_scoped_release release;
  io::write_points(path, table, options);
}

}  // namespace

void bind_io(py::module_& m) {
  m.def("read", &read, py::arg("path"),
        R"doc(read(path) -> dict

Reads a point file (.ply, .las, .xyz/.txt/.pts/.csv/.asc) as `pointfair` does: 'xyz', the
(N, 3) float64 positions, and every attribute under its name as an (N,) array of the type the
file stores it in (uint8, int16, float32, ...). Raises pointfair.IoError (an OSError) naming
the file and the problem; what the command prints as warnings are RuntimeWarnings.)doc");
  m.def("write", &write, py::arg("path"), py::arg("cloud"), py::kw_only(), py::arg("encoding") = py::none(),
        R"doc(write(path, cloud, *, encoding=None)

Writes a dict as read() returns it: 'xyz' ((N, 3) float64, or float32) and attributes of
shape (N,), each stored in its dtype (bool as uint8; int64/uint64 as int32/uint32 when the
values fit). The format follows the extension; encoding ('binary', 'binary-be', 'ascii')
chooses PLY's. Written under a temporary name and renamed when complete.)doc");
}

}  // namespace pointfair::python
