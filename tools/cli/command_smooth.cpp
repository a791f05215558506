// pointfair smooth IN OUT: the (an)isotropic mean curvature flow on a point file.
#include <chrono>
#include <cstdio>
#include <iostream>

#include "commands.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "interrupt.hpp"
#include "progress.hpp"
#include "number_text.hpp"
#include "las_options.hpp"
#include "run_support.hpp"
#include "selection_options.hpp"
#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/common/version.hpp"
#include "pointfair/io/attribute_roles.hpp"
#include "pointfair/io/point_selection.hpp"

namespace pointfair::cli {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int run_smooth(const Args& args) {
  // HDF5 containers, --memory-budget and --resume: the out-of-core run (command_smooth_tiled.cpp).
  if (wants_out_of_core(args)) return run_smooth_out_of_core(args);
  std::string input, output_path, reference;
  SmoothParams params;
  OutputOptions output;
  ArgumentParser parser("pointfair smooth",
                        "Denoises a point cloud with the anisotropic mean curvature flow of Lange & "
                        "Polthier (2005), keeping sharp edges and corners. Reads and writes PLY, LAS "
                        "and XYZ/CSV text: only the positions change (and normals, which are "
                        "recomputed); every other attribute, colours included, and the file's "
                        "layout (PLY encoding, text columns, header, separator) come back as they "
                        "were (docs/formats.md).");
  parser.positional("IN", "Input point file (.ply, .las, .xyz, .txt, .pts, .csv).", &input);
  parser.positional("OUT", "Output point file; written under a temporary name and renamed when complete.",
                    &output_path);
  add_method_options(parser, params);
  add_finish_options(parser, params);
  parser.value("neighbors-from", "REF",
               "Build the neighbourhoods from this cloud (same points, same order) instead of the "
               "input: the paper's noise-free neighbourhoods.",
               [&](std::string_view v) { reference = std::string(v); });
  SelectionOptions select;
  add_selection_options(parser, select);
  add_output_options(parser, output, true);
  add_las_options(parser, output.las);
  if (!parser.parse(args)) return 0;
  require_las_output(output.las, output_path);
  params.validate();
  require_selection_compatible(select, output.attributes, output.colour_by != ColourBy::None);
  set_thread_count(output.threads);
  // A named pipe or a device at OUT is refused before any work, not after it.
  io::require_output_path(output_path);
  output.attribute_prefix = attribute_prefix_for(output_path);

  const auto t_start = std::chrono::steady_clock::now();
  io::PointTable table = read_input(input, output.quiet);
  std::vector<Vec3> reference_positions;
  if (!reference.empty()) {
    reference_positions = read_input(reference, output.quiet).positions;
    if (reference_positions.size() != table.size())
      throw ParamError(reference + ": has " + std::to_string(reference_positions.size()) + " points, " + input +
                       " has " + std::to_string(table.size()) +
                       " (--neighbors-from needs the input's points in the same order)");
  }
  // With --classes or --returns the run sees only the selected points (`table` holds them);
  // the others stay in `whole` as they were read, and the moved points go back into it.
  io::PointTable whole;
  std::vector<std::size_t> rows;
  const bool selecting = !select.selection.all();
  if (selecting) {
    rows = io::selected_rows(table, select.selection, input);
    whole = std::move(table);
    table = io::select_rows(whole, rows);
    if (!reference_positions.empty()) {
      std::vector<Vec3> picked;
      picked.reserve(rows.size());
      for (const std::size_t i : rows) picked.push_back(reference_positions[i]);
      reference_positions = std::move(picked);
    }
    if (!output.quiet)
      std::fprintf(stderr, "smooth: %zu of %zu points selected%s\n", table.size(), whole.size(),
                   table.size() == 0 ? ": none to smooth, the file is written back as it was" : "");
  }
  const double seconds_read = seconds_since(t_start);
  const std::vector<Vec3> before = table.positions;

  // One progress line per stage; the steps' line says how the automatic stop works, since
  // their count is only the most steps run.
  const bool auto_stop = params.flow.flow == Flow::Anisotropic && params.flow.lambda == 0.0 &&
                         params.lambda_every_step && (params.stop_lambda_ratio > 0.0 || params.stop_plateau > 0.0);
  std::string step_label = "smooth: step";
  if (auto_stop)
    step_label = "smooth: step (stops once the noise measure lambda falls to " + format_number(params.stop_lambda_ratio) +
                 " of its start or levels off)";
  // A selection of no point: nothing to smooth, the file goes back as it was.
  const bool run = !(selecting && table.size() == 0);
  if (!output.quiet && run)
    std::fprintf(stderr, "smooth: %zu %spoints read; neighbourhoods...\n", table.size(), selecting ? "selected " : "");
  Progress steps_progress(step_label, !output.quiet);
  Progress finish_progress("smooth: finish (quadric fits, points x passes)", !output.quiet);
  SmoothOptions options;
  options.neighbor_reference = reference_positions;
  options.progress = [&](SmoothStage stage, std::size_t done, std::size_t total) {
    throw_if_interrupted();  // unwinds out of smooth(): nothing has been written yet
    if (stage == SmoothStage::Steps) {
      steps_progress.update(static_cast<long long>(done), static_cast<long long>(total));
    } else if (stage == SmoothStage::Finish) {
      steps_progress.finish();
      finish_progress.update(static_cast<long long>(done), static_cast<long long>(total));
    }
  };
  throw_if_interrupted();
  SmoothReport report;
  try {
    const StopOnInterrupt stop_on_interrupt;  // a signal ends the current step or fit within a second
    if (run) report = smooth(table.positions, params, options);
  } catch (const Stopped&) {
    throw_if_interrupted();
    throw;
  }
  steps_progress.finish();
  finish_progress.finish();

  auto t0 = std::chrono::steady_clock::now();
  const bool need_attributes =
      output.attributes || output.colour_by != ColourBy::None || !io::normal_columns(table).empty();
  std::size_t degenerate_final = report.degenerate;
  if (need_attributes && run) {
    throw_if_interrupted();
    const PointAttributes attributes =
        compute_attributes(table.positions, report.neighborhoods, params.flow, report.lambda);
    degenerate_final = attributes.degenerate;
    add_result_columns(table, attributes, output, output.attributes, curvature_type(attributes));
  }
  const double seconds_attributes = seconds_since(t0);
  throw_if_interrupted();
  if (!output.quiet) std::fprintf(stderr, "smooth: writing %s\n", output_path.c_str());
  t0 = std::chrono::steady_clock::now();
  if (selecting) io::splice_rows(whole, rows, table);
  write_output(output_path, selecting ? whole : table, output, input);
  const double seconds_write = seconds_since(t0);
  const double seconds_total = seconds_since(t_start);

  const DisplacementStats moved = displacement_stats(before, table.positions);
  std::size_t moved_points = 0;
  for (std::size_t i = 0; i < before.size(); ++i) moved_points += before[i] != table.positions[i] ? 1 : 0;
  const double rate = report.seconds_steps > 0
                          ? static_cast<double>(table.size()) * report.steps / report.seconds_steps
                          : 0.0;
  if (!output.quiet && run) {
    std::fprintf(stderr,
                 "smooth: %zu points, %d %s steps (k %d, tau %g, lambda %.4g, eps %.4g) in %.2f s "
                 "(%.3g point-steps/s); displacement mean %.4g, max %.4g (%.3g%% of the diagonal); "
                 "%zu degenerate points -> %s\n",
                 table.size(), report.steps, to_string(params.flow.flow).c_str(), report.k, params.flow.tau,
                 report.lambda, report.eps, seconds_total, rate, moved.mean, moved.max,
                 moved.diagonal > 0 ? 100.0 * moved.max / moved.diagonal : 0.0, degenerate_final,
                 output_path.c_str());
  }
  if (output.json) {
    JsonObject seconds;
    seconds.add("read", seconds_read).add("neighbors", report.seconds_neighbors)
        .add("steps", report.seconds_steps).add("finish", report.seconds_finish).add("attributes", seconds_attributes)
        .add("coarse_level", report.seconds_coarse)
        .add("write", seconds_write).add("total", seconds_total);
    JsonObject j;
    j.add("command", "smooth").add("version", version()).add("input", input).add("output", output_path);
    j.add("points", selecting ? whole.size() : table.size()).add("steps", report.steps).add("rebuilds", report.rebuilds);
    j.add("stop_reason", std::string(to_string(report.stop_reason)));
    j.add("threads", thread_count());
    j.add("parameters", parameters_json(params, report.k, report.eps, report.lambda));
    j.add("neighbors_from", reference);
    if (selecting) j.add("selection", selection_json(select, table.size(), moved_points));
    if (params.coarse) {
      JsonObject coarse;
      coarse.add("ratio", params.coarse->ratio).add("fine_steps", params.coarse->fine_steps)
          .add("interpolation_k", params.coarse->interpolation_k).add("levels_at_most", params.coarse->levels)
          .add("min_noise_ratio", params.coarse->min_noise_ratio);
      std::vector<JsonObject> levels;
      for (const CoarseLevelReport& level : report.coarse_levels) {
        levels.emplace_back();
        levels.back().add("points", level.points).add("steps", level.steps);
      }
      coarse.add("levels", levels);
      j.add("coarse_level", coarse);
    }
    j.add("quadric_finish", finish_json(params));
    j.add("placement", report.placed_along_normal ? "normal" : "free");
    j.add("seconds", seconds).add("point_steps_per_second", rate);
    j.add("displacement", to_json(moved)).add("degenerate_points", degenerate_final);
    std::cout << j.str() << std::endl;
  }
  return 0;
}

}  // namespace pointfair::cli
