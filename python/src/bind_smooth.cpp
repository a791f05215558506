#include "bind_smooth.hpp"

#include <pybind11/numpy.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "arrays.hpp"
#include "errors.hpp"
#include "options.hpp"
#include "cli/smooth_out_of_core_file.hpp"
#include "cli/smooth_point_file.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "pointfair/tiles/out_of_core_decision.hpp"

namespace pointfair::python {
namespace {

// Raises the pending Python exception (KeyboardInterrupt from Ctrl-C) in C++. Needs the GIL.
void check_signals() {
  if (PyErr_CheckSignals() != 0) throw py::error_already_set();
}

// A progress hook of a run with the GIL released: takes the GIL, lets Python run its signal
// handlers (Ctrl-C raises KeyboardInterrupt there, which ends the run) and calls
// `callback(stage, done, total)` if there is one; whatever it raises ends the run and reaches
// the caller. `callback` is borrowed: the call's keyword arguments hold it.
std::function<void(const std::string&, std::uint64_t, std::uint64_t)> stage_hook(const py::object& callback) {
  PyObject* const function = callback.is_none() ? nullptr : callback.ptr();
  return [function](const std::string& stage, std::uint64_t done, std::uint64_t total) {
    const py::gil_scoped_acquire gil;
    check_signals();
    if (function != nullptr) py::handle{function}(stage, done, total);
  };
}

// SmoothOptions::progress: the stage is 'coarse_steps', 'steps' or 'finish'.
std::function<void(SmoothStage, std::size_t, std::size_t)> progress_hook(const py::object& callback) {
  return [hook = stage_hook(callback)](SmoothStage stage, std::size_t done, std::size_t total) {
    hook(std::string(to_string(stage)), done, total);
  };
}

// The out-of-core run's progress: the stage is 'import' while the input is imported, else the
// run's phase ('k', 'eps', 'neighbors', 'steps', 'finish', 'attributes').
std::function<void(const cli::OutOfCoreProgress&)> out_of_core_progress_hook(const py::object& callback) {
  return [hook = stage_hook(callback)](const cli::OutOfCoreProgress& at) {
    std::string phase = at.importing ? std::string("import") : std::string(at.phase);
    if (phase == "step" || phase == "coarse step") phase += "s";
    std::replace(phase.begin(), phase.end(), ' ', '_');
    hook(phase, at.done, at.total);
  };
}

std::function<void()> signal_hook() {
  return [] {
    const py::gil_scoped_acquire gil;
    check_signals();
  };
}

py::array_t<double> smooth_points(const py::handle& points, const py::kwargs& kwargs) {
  const Options o = parse_options(kwargs, OptionSet::Smooth, "pointfair.smooth");
  const PointsIn in = points_in(points, "points");
  require_finite(in.points, "points");
  PointsIn reference;
  if (!o.neighbors_from.is_none()) {
    reference = points_in(o.neighbors_from, "neighbors_from");
    if (reference.points.size() != in.points.size())
      throw ParamError("neighbors_from: has " + std::to_string(reference.points.size()) + " points, points has " +
                       std::to_string(in.points.size()) + " (it needs the same points in the same order)");
    require_finite(reference.points, "neighbors_from");
  }
  SmoothOptions options;
  options.neighbor_reference = reference.points;
  options.progress = progress_hook(o.progress);
  options.keep_neighborhoods = false;  // only the positions are returned
  // The placement along the normals reads the caller's positions (or their converted copy in
  // `in`), which outlive the run, rather than a copy of its own.
  options.input_positions = in.points;
  std::vector<Vec3> positions;
  {
    const py::gil_scoped_release release;
    const ThreadCount threads(o.threads_given, o.output.threads);
    // The input's one copy: the buffer the flow works in, which becomes the result.
    positions.assign(in.points.begin(), in.points.end());
    smooth(positions, o.params, options);
  }
  return points_out(std::move(positions));
}

py::dict curvature(const py::handle& points, const py::kwargs& kwargs) {
  const Options o = parse_options(kwargs, OptionSet::Curvature, "pointfair.curvature");
  const PointsIn in = points_in(points, "points");
  require_finite(in.points, "points");
  PointAttributes a;
  NeighborParams neighbor_params;
  double eps = 0.0, lambda = 0.0;
  {
    // As `pointfair curvature`: the neighbourhoods of the resolved k, the flow's lambda, the
    // attributes.
    const py::gil_scoped_release release;
    const ThreadCount threads(o.threads_given, o.output.threads);
    neighbor_params = resolve_k(o.params, in.points).neighbors;
    const Neighborhoods neighborhoods = build_neighborhoods(in.points, neighbor_params);
    signal_hook()();
    eps = neighborhoods.eps;
    lambda = resolve_lambda(in.points, neighborhoods, o.params.flow);
    a = compute_attributes(in.points, neighborhoods, o.params.flow, lambda);
  }
  std::vector<std::uint8_t> feature(a.feature.size());
  for (std::size_t i = 0; i < feature.size(); ++i) feature[i] = static_cast<std::uint8_t>(a.feature[i]);
  py::dict out;
  out["normals"] = points_out(std::move(a.normal));
  out["k1"] = column_out(std::move(a.k1));
  out["k2"] = column_out(std::move(a.k2));
  out["d1"] = points_out(std::move(a.d1));
  out["d2"] = points_out(std::move(a.d2));
  out["mean_curvature"] = column_out(std::move(a.mean_curvature));
  out["laplacian_norm"] = column_out(std::move(a.laplacian_norm));
  out["feature_class"] = column_out(std::move(feature));
  out["k"] = neighbor_params.k;
  out["eps"] = eps;
  out["lambda"] = lambda;
  out["degenerate"] = a.degenerate;
  return out;
}

cli::JsonObject smooth_file_in_core(const std::string& input, const std::string& output, const Options& o) {
  cli::PointFileSmooth run;
  run.input = input;
  run.output = output;
  run.reference = o.reference;
  run.params = o.params;
  run.output_options = o.output;
  run.output_options.quiet = true;
  run.progress = progress_hook(o.progress);
  run.check = signal_hook();
  return cli::smooth_point_file(run).json;
}

// As `pointfair smooth IN OUT --memory-budget B`, but a run that fails or is interrupted
// leaves nothing behind (there is no resume here).
cli::JsonObject smooth_file_out_of_core(const std::string& input, const std::string& output, const Options& o) {
  cli::OutOfCoreFileSmooth run;
  run.input = input;
  run.output = output;
  run.params = o.params;
  if (o.memory_budget) run.options.memory_budget = *o.memory_budget;
  run.options.neighbor_reference = o.reference;
  run.output_options = o.output;
  run.output_options.quiet = true;
  run.keep_interrupted = false;
  run.progress = out_of_core_progress_hook(o.progress);
  return cli::smooth_out_of_core_file(run).json;
}

py::dict smooth_file(const std::string& input, const std::string& output, const py::kwargs& kwargs) {
  const Options o = parse_options(kwargs, OptionSet::File, "pointfair.smooth_file");
  io::require_output_path(output);
  cli::JsonObject json;
  {
    const py::gil_scoped_release release;
    // The command's rule: containers, and point files whose in-core run does not fit the
    // budget, go out of core.
    const bool out_of_core = tiles::runs_out_of_core(input, output, o.params, o.memory_budget);
    const ThreadCount threads(o.threads_given, o.output.threads);
    json = out_of_core ? smooth_file_out_of_core(input, output, o) : smooth_file_in_core(input, output, o);
  }
  return py::module_::import("json").attr("loads")(json.str());
}

}  // namespace

void bind_smooth(py::module_& m) {
  m.def("smooth", &smooth_points, py::arg("points"),
        R"doc(smooth(points, **options) -> numpy.ndarray

Denoises (N, 3) float64 positions with the anisotropic mean curvature flow (Lange & Polthier
2005) and the quadric finish, as `pointfair smooth` does, and returns the new (N, 3) array.

options: the command's method and finish options in snake_case (k, eps, eps_factor, steps,
tau, flow, cutoff, cutoff_origin, lambda_, lambda_schedule, stop_lambda_ratio, stop_plateau,
shrink_compensation, momentum, momentum_gate, lambda_factor, constrain_normal, normal, robust_seed, robust_iterations,
robust_bound, robust_gate, rebuild_every, features, edge_quotient, feature_threshold, feature_turn,
feature_gated, weights, density_floor, move, quadric_finish, quadric_k, quadric_angle,
quadric_degree, quadric_passes, quadric_iterations, quadric_early_degree,
quadric_early_iterations, quadric_curvature_reach, quadric_min_k,
quadric_share, quadric_share_turn),
paper=True (the --paper preset; the other options override it), threads (0: all cores),
neighbors_from ((N, 3) positions to build the neighbourhoods from), progress (called as
progress(stage, done, total) with stage 'coarse_steps' (the coarse level's, under heavy noise),
'steps' or 'finish'; an exception it raises ends the
run). Ctrl-C ends the run at the next step. The GIL is released while it runs.)doc");
  m.def("curvature", &curvature, py::arg("points"),
        R"doc(curvature(points, **options) -> dict

Per point normal, principal curvatures k1 >= k2 and directions d1, d2, mean curvature H
('mean_curvature'), |A| ('laplacian_norm') and feature class (0 smooth, 1 edge, 2 corner), as
`pointfair curvature` computes them; also the k, eps and lambda used and the number of
degenerate points. options: the command's method options in snake_case, paper, threads.)doc");
  m.def("smooth_file", &smooth_file, py::arg("input"), py::arg("output"),
        R"doc(smooth_file(input, output, memory_budget=None, **options) -> dict

Runs `pointfair smooth INPUT OUTPUT` and returns its --json summary. options: the command's
options in snake_case (as smooth(), plus colour_by, colour_clip, attributes, encoding,
neighbors_from=path), progress. As the command, it runs out of core (tiles streamed through an
HDF5 file beside OUTPUT, the same bits as in core) for an HDF5 container input or output and
for a cloud whose in-core run does not fit memory_budget (bytes, or '256M', '2G'; 256M for a
container without one); the summary then has 'out_of_core': True, 'tiles' and the run's memory
figures. progress(stage, done, total) is called with stage 'coarse_steps', 'steps' or 'finish'
in core, and 'import', 'k', 'eps', 'neighbors', 'steps', 'finish' or 'attributes' out of core,
those of the coarse level's run prefixed with 'coarse_' ('coarse_sample', 'coarse_steps',
'coarse_moves', ...). A run that
fails or is interrupted (Ctrl-C raises KeyboardInterrupt) leaves no file behind (no resume
here). The GIL is released while it runs.)doc");
}

}  // namespace pointfair::python
