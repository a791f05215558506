#include "options.hpp"

#include <algorithm>
#include <vector>

#include "cli/arguments.hpp"
#include "cli/out_of_core.hpp"
#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"

namespace pointfair::python {
namespace {

// Options of the commands that make no sense in a function call.
bool excluded(OptionSet set, std::string_view name) {
  if (name == "json" || name == "quiet" || name == "help") return true;
  if (set == OptionSet::File) return false;
  // smooth() and curvature() return arrays: no file to colour or encode.
  return name == "colour-by" || name == "colour-clip" || name == "encoding" || name == "attributes";
}

std::string option_name(const std::string& key) {
  if (key == "lambda_") return "lambda";
  std::string name = key;
  std::replace(name.begin(), name.end(), '_', '-');
  return name;
}

// The CLI's text of an option's value: str for text, the integer, or the shortest text that
// reads back as the same double (repr).
std::string value_text(const std::string& key, py::handle value) {
  if (py::isinstance<py::str>(value)) return value.cast<std::string>();
  if (py::hasattr(value, "__index__")) return py::str(py::int_(py::reinterpret_borrow<py::object>(value))).cast<std::string>();
  if (py::isinstance<py::float_>(value) || py::hasattr(value, "__float__"))
    return py::repr(py::float_(py::reinterpret_borrow<py::object>(value))).cast<std::string>();
  throw ParamError(key + ": expected a number or a string, got " +
                   py::str(py::type::handle_of(value).attr("__name__")).cast<std::string>());
}

std::string known_names(const cli::ArgumentParser& parser, OptionSet set) {
  std::string text;
  for (std::string name : parser.names()) {
    if (excluded(set, name) || name == "no-quadric-finish") continue;
    std::replace(name.begin(), name.end(), '-', '_');
    text += (text.empty() ? "" : ", ") + (name == "lambda" ? std::string("lambda_") : name);
  }
  return text;
}

}  // namespace

Options parse_options(const py::kwargs& kwargs, OptionSet set, std::string_view function) {
  Options o;
  cli::ArgumentParser parser(std::string(function), "");
  cli::add_method_options(parser, o.params);
  if (set != OptionSet::Curvature) cli::add_finish_options(parser, o.params);
  if (set == OptionSet::File) {
    parser.value("neighbors-from", "REF", "", [&o](std::string_view v) { o.reference = std::string(v); });
  }
  cli::add_output_options(parser, o.output, set == OptionSet::File);

  std::vector<std::string> args;
  bool paper = false;
  std::vector<std::pair<std::string, py::handle>> rest;
  for (const auto& [key_handle, value] : kwargs) {
    const std::string key = py::str(key_handle).cast<std::string>();
    if (key == "progress" && set != OptionSet::Curvature) {
      if (!value.is_none() && !PyCallable_Check(value.ptr()))
        throw ParamError(std::string(function) + ": progress must be callable (stage, done, total), got " +
                         py::str(py::type::handle_of(value).attr("__name__")).cast<std::string>());
      o.progress = py::reinterpret_borrow<py::object>(value);
      continue;
    }
    if (key == "neighbors_from" && set == OptionSet::Smooth) {
      o.neighbors_from = py::reinterpret_borrow<py::object>(value);
      continue;
    }
    if (key == "memory_budget" && set == OptionSet::File) {
      if (value.is_none()) continue;
      if (py::isinstance<py::str>(value)) {
        o.memory_budget = cli::parse_size(value.cast<std::string>(), "memory_budget");
      } else if (py::hasattr(value, "__index__") && !py::isinstance<py::bool_>(value)) {
        const long long bytes = py::int_(py::reinterpret_borrow<py::object>(value)).cast<long long>();
        if (bytes <= 0) throw ParamError("memory_budget must be a positive number of bytes, got " + std::to_string(bytes));
        o.memory_budget = static_cast<std::uint64_t>(bytes);
      } else {
        throw ParamError("memory_budget expects bytes (an int) or a size such as '256M' or '2G'");
      }
      continue;
    }
    const std::string name = option_name(key);
    if (key.find('-') != std::string::npos || !parser.has(name) || excluded(set, name))
      throw ParamError(std::string(function) + ": unknown option '" + key + "' (options: " +
                       known_names(parser, set) + (set == OptionSet::Curvature ? "" : ", progress") +
                       (set == OptionSet::Smooth ? ", neighbors_from" : "") +
                       (set == OptionSet::File ? ", memory_budget" : "") + ")");
    if (name == "threads") o.threads_given = !value.is_none();
    if (name == "paper") {
      if (!py::isinstance<py::bool_>(value)) throw ParamError("paper: expected True or False");
      paper = value.cast<bool>();
      continue;
    }
    rest.emplace_back(key, value);
  }
  if (paper) args.push_back("--paper");
  for (const auto& [key, value] : rest) {
    const std::string name = option_name(key);
    if (value.is_none()) continue;  // the default
    if (parser.is_flag(name) || py::isinstance<py::bool_>(value)) {
      if (!py::isinstance<py::bool_>(value) || !parser.is_flag(name)) {
        throw ParamError(key + ": " + (parser.is_flag(name) ? "expected True or False"
                                                             : "expected a value, got a bool"));
      }
      if (value.cast<bool>()) args.push_back("--" + name);
      else if (name == "quadric-finish") args.push_back("--no-quadric-finish");
      continue;
    }
    args.push_back("--" + name + "=" + value_text(key, value));
  }
  try {
    parser.parse(args);
  } catch (const cli::UsageError& e) {
    throw ParamError(e.what());
  }
  o.params.validate();
  return o;
}

ThreadCount::ThreadCount(bool given, int threads) : given_(given) {
  if (given_) set_thread_count(threads);
}

ThreadCount::~ThreadCount() {
  if (given_) set_thread_count(0);
}

}  // namespace pointfair::python
