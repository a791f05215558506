#pragma once
// Keyword options of pointfair.smooth, curvature and smooth_file: the options of the CLI's
// `pointfair smooth` and `pointfair curvature` under the same names in snake_case
// (cutoff_origin for --cutoff-origin; lambda_ or lambda for --lambda), parsed by the CLI's
// own option table (tools/cli/method_options.cpp), so that names, defaults, ranges and
// errors are the command's. paper=True applies first; the others override it, as options
// after --paper do.
#include <pybind11/pybind11.h>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "cli/method_options.hpp"
#include "pointfair/smooth.hpp"

namespace pointfair::python {

namespace py = pybind11;

/// Which command's options a function takes.
enum class OptionSet {
  /// pointfair.smooth: the method's and the finish's options, threads, progress,
  /// neighbors_from (an array).
  Smooth,
  /// pointfair.curvature: the method's options (as `pointfair curvature`), threads.
  Curvature,
  /// pointfair.smooth_file: `pointfair smooth`'s options but --json and --quiet;
  /// neighbors_from (a file), progress, memory_budget.
  File,
};

struct Options {
  SmoothParams params;
  cli::OutputOptions output;
  /// threads=N was given (output.threads holds it).
  bool threads_given = false;
  /// progress=callable, or None.
  py::object progress = py::none();
  /// neighbors_from=: an array (Smooth) or a path (File, in `reference`); None if not given.
  py::object neighbors_from = py::none();
  std::string reference;
  /// memory_budget= in bytes (File): an int or a size text as the CLI's ("256M", "2G").
  std::optional<std::uint64_t> memory_budget;
};

/// Parses `kwargs` for `function` ("pointfair.smooth", ...). Throws ParamError (ValueError)
/// naming the option and the problem: an unknown name, a value of the wrong kind, or one the
/// CLI's parser or SmoothParams::validate refuses.
Options parse_options(const py::kwargs& kwargs, OptionSet set, std::string_view function);

/// While one lives, parallel_for uses `threads` workers (0: all cores) when `given`; the
/// default (all cores) again afterwards. The setting is the process's, as the CLI's --threads.
class ThreadCount {
 public:
  ThreadCount(bool given, int threads);
  ~ThreadCount();
  ThreadCount(const ThreadCount&) = delete;
  ThreadCount& operator=(const ThreadCount&) = delete;

 private:
  bool given_;
};

}  // namespace pointfair::python
