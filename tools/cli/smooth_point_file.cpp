#include "smooth_point_file.hpp"

#include <chrono>
#include <vector>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/common/version.hpp"
#include "pointfair/io/attribute_roles.hpp"
#include "pointfair/io/point_selection.hpp"
#include "point_folder_run.hpp"

namespace pointfair::cli {

PointFileSmoothResult smooth_point_file(const PointFileSmooth& run) {
  const auto check = [&run] {
    if (run.check) run.check();
  };
  const auto note = [&run](const std::string& text) {
    if (run.note) run.note(text);
  };
  const SmoothParams& params = run.params;
  OutputOptions output = run.output_options;
  output.attribute_prefix = attribute_prefix_for(run.output);

  const auto t_start = std::chrono::steady_clock::now();
  // A folder: its files' points as one cloud (`table`, positions only), each file kept in
  // `parts` to be written back with its share of the result.
  const bool folder = is_folder_input(run.input);
  FolderRun files;
  std::vector<io::PointTable> parts;
  if (folder) files = plan_folder_run(run.input, run.output);
  io::PointTable table = folder ? read_folder(files, output.quiet, parts) : read_input(run.input, output.quiet);
  std::vector<Vec3> reference_positions;
  if (!run.reference.empty()) {
    reference_positions = read_input(run.reference, output.quiet).positions;
    if (reference_positions.size() != table.size())
      throw ParamError(run.reference + ": has " + std::to_string(reference_positions.size()) + " points, " +
                       run.input + " has " + std::to_string(table.size()) +
                       " (--neighbors-from needs the input's points in the same order)");
  }
  // With --classes or --returns the run sees only the selected points (`table` holds them);
  // the others stay in `whole` as they were read, and the moved points go back into it.
  io::PointTable whole;
  std::vector<std::size_t> rows;
  const bool selecting = !run.select.selection.all();
  if (selecting) {
    rows = io::selected_rows(table, run.select.selection, run.input);
    whole = std::move(table);
    table = io::select_rows(whole, rows);
    if (!reference_positions.empty()) {
      std::vector<Vec3> picked;
      picked.reserve(rows.size());
      for (const std::size_t i : rows) picked.push_back(reference_positions[i]);
      reference_positions = std::move(picked);
    }
    note("smooth: " + std::to_string(table.size()) + " of " + std::to_string(whole.size()) + " points selected" +
         (table.size() == 0 ? ": none to smooth, the file is written back as it was" : ""));
  }
  const double seconds_read = seconds_since(t_start);
  const std::vector<Vec3> before = table.positions;
  PointFileSmoothResult result;
  // A selection of no point: nothing to smooth, the file goes back as it was.
  result.smoothed = !(selecting && table.size() == 0);
  if (result.smoothed)
    note("smooth: " + std::to_string(table.size()) + (selecting ? " selected" : "") + " points read; neighbourhoods...");

  const bool need_attributes = output.attributes || output.colour_by != ColourBy::None ||
                               !io::normal_columns(table).empty() || any_normals(parts);
  SmoothOptions options;
  options.neighbor_reference = reference_positions;
  options.progress = run.progress;
  // The flow's lists are kept only for the attributes; the placement reads `before`.
  options.keep_neighborhoods = need_attributes;
  options.input_positions = before;
  check();
  if (result.smoothed) result.report = smooth(table.positions, params, options);
  const SmoothReport& report = result.report;

  auto t0 = std::chrono::steady_clock::now();
  result.degenerate = report.degenerate;
  PointAttributes attributes;
  if (need_attributes && result.smoothed) {
    check();
    // Normal columns alone need no curvature.
    const bool normals_only = !output.attributes && output.colour_by == ColourBy::None;
    attributes = normals_only ? compute_normals(table.positions, report.neighborhoods, params.flow, report.lambda)
                              : compute_attributes(table.positions, report.neighborhoods, params.flow, report.lambda);
    result.degenerate = attributes.degenerate;
    // A folder's files take their normals when they are written.
    if (!folder) add_result_columns(table, attributes, output, output.attributes, curvature_type(attributes));
  }
  result.report.neighborhoods = {};
  const double seconds_attributes = seconds_since(t0);
  check();
  note("smooth: writing " + run.output);
  t0 = std::chrono::steady_clock::now();
  if (selecting) io::splice_rows(whole, rows, table);
  if (folder) write_folder(files, parts, table.positions, attributes, output);
  else write_output(run.output, selecting ? whole : table, output, run.input);
  const double seconds_write = seconds_since(t0);
  result.seconds_total = seconds_since(t_start);
  result.points = selecting ? whole.size() : table.size();
  result.selected = table.size();

  result.moved = displacement_stats(before, table.positions);
  std::size_t moved_points = 0;
  for (std::size_t i = 0; i < before.size(); ++i) moved_points += before[i] != table.positions[i] ? 1 : 0;
  result.rate = report.seconds_steps > 0
                    ? static_cast<double>(table.size()) * report.steps / report.seconds_steps
                    : 0.0;
  JsonObject seconds;
  seconds.add("read", seconds_read).add("neighbors", report.seconds_neighbors)
      .add("steps", report.seconds_steps).add("finish", report.seconds_finish).add("attributes", seconds_attributes)
      .add("coarse_level", report.seconds_coarse).add("write", seconds_write).add("total", result.seconds_total);
  JsonObject& j = result.json;
  j.add("command", "smooth").add("version", version()).add("input", run.input).add("output", run.output);
  j.add("points", result.points).add("steps", report.steps).add("rebuilds", report.rebuilds);
  if (has_momentum(params)) j.add("momentum_restarts", report.momentum_restarts);
  j.add("stop_reason", std::string(to_string(report.stop_reason)));
  j.add("threads", thread_count());
  j.add("parameters", parameters_json(params, report.k, report.eps, report.lambda));
  j.add("neighbors_from", run.reference);
  if (selecting) j.add("selection", selection_json(run.select, table.size(), moved_points));
  if (params.coarse) j.add("coarse_level", coarse_level_json(*params.coarse, report.coarse_levels));
  j.add("quadric_finish", finish_json(params, report.finish_passes));
  j.add("placement", name_of(report.placed_along_normal ? Placement::AlongNormal : Placement::Free));
  j.add("seconds", seconds).add("point_steps_per_second", result.rate);
  j.add("displacement", to_json(result.moved)).add("degenerate_points", result.degenerate);
  return result;
}

}  // namespace pointfair::cli
