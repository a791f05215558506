// pointfair smooth IN OUT: the (an)isotropic mean curvature flow on a point file.
#include <cstdio>
#include <iostream>
#include <optional>
#include <string>

#include "commands.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "interrupt.hpp"
#include "progress.hpp"
#include "number_text.hpp"
#include "las_options.hpp"
#include "run_support.hpp"
#include "selection_options.hpp"
#include "point_folder_run.hpp"
#include "smooth_point_file.hpp"
#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/common/version.hpp"
#include "pointfair/io/attribute_roles.hpp"

namespace pointfair::cli {

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
  parser.positional("IN",
                    "Input point file (.ply, .las, .laz, .xyz, .txt, .pts, .csv), or a folder whose "
                    ".las .laz .ply .xyz files are smoothed as one cloud (docs/tiles-folder.md).",
                    &input);
  parser.positional("OUT",
                    "Output point file, written under a temporary name and renamed when complete; "
                    "for a folder IN, the folder that gets one file per input file.",
                    &output_path);
  add_method_options(parser, params);
  add_finish_options(parser, params);
  parser.group(OptionGroup::Method);
  parser.value("neighbors-from", "REF",
               "Build the neighbourhoods from this cloud (same points, same order) instead of the "
               "input: the paper's noise-free neighbourhoods.",
               [&](std::string_view v) { reference = std::string(v); });
  SelectionOptions select;
  add_selection_options(parser, select);
  add_output_options(parser, output, true);
  add_budget_options(parser, nullptr, nullptr);
  add_las_options(parser, output.las);
  parser.example("pointfair smooth scan.ply smoothed.ply");
  parser.example("pointfair smooth scan.las ground.las --classes 2 --steps 50 --json");
  parser.example("pointfair smooth tiles/ smoothed-tiles/");
  if (!parser.parse(args)) return 0;
  require_las_output(output.las, output_path);
  params.validate();
  require_selection_compatible(select, output.attributes, output.colour_by != ColourBy::None);
  set_thread_count(output.threads);
  // A folder IN: its files as one cloud, each written back into the folder OUT.
  check_smooth_paths(input, output_path, select, output, !reference.empty());
  output.attribute_prefix = attribute_prefix_for(output_path);

  // One progress line per stage; the steps' line says how the automatic stop works, since
  // their count is only the most steps run.
  const bool auto_stop = params.flow.flow == Flow::Anisotropic && params.flow.lambda == 0.0 &&
                         params.lambda_every_step && (params.stop_lambda_ratio > 0.0 || params.stop_plateau > 0.0);
  std::string step_label = "smooth: step";
  if (auto_stop)
    step_label = "smooth: step (stops once the noise measure lambda falls to " + format_number(params.stop_lambda_ratio) +
                 " of its start or levels off)";
  // Each made at its stage's first report, so that its time left counts from there; the steps'
  // named by whether a coarse level ran before (then they take --coarse-fine-steps, without
  // the stop).
  std::optional<Progress> coarse_progress, steps_progress, finish_progress;
  PointFileSmooth run;
  run.input = input;
  run.output = output_path;
  run.reference = reference;
  run.params = params;
  run.select = select;
  run.output_options = output;
  run.progress = [&](SmoothStage stage, std::size_t done, std::size_t total) {
    throw_if_interrupted();  // unwinds out of smooth(): nothing has been written yet
    if (stage == SmoothStage::CoarseSteps) {
      if (!coarse_progress)
        coarse_progress.emplace("smooth: coarse level (the flow on " + coarse_sample_text(params.coarse->ratio) +
                                    " first), step",
                                !output.quiet);
      coarse_progress->update(static_cast<long long>(done), static_cast<long long>(total));
    } else if (stage == SmoothStage::Steps) {
      if (!steps_progress) {
        if (coarse_progress) coarse_progress->finish();
        steps_progress.emplace(coarse_progress ? std::string("smooth: step (after the coarse level)") : step_label,
                               !output.quiet);
      }
      steps_progress->update(static_cast<long long>(done), static_cast<long long>(total));
    } else if (stage == SmoothStage::Finish) {
      if (steps_progress) steps_progress->finish();
      if (!finish_progress) finish_progress.emplace("smooth: finish (quadric fits and placements, all passes)", !output.quiet);
      finish_progress->update(static_cast<long long>(done), static_cast<long long>(total));
    }
  };
  run.check = [&] {
    if (coarse_progress) coarse_progress->finish();
    if (steps_progress) steps_progress->finish();
    if (finish_progress) finish_progress->finish();
    throw_if_interrupted();
  };
  run.note = stderr_notes(output.quiet);
  PointFileSmoothResult result;
  try {
    const StopOnInterrupt stop_on_interrupt;  // a signal ends the current step or fit within a second
    result = smooth_point_file(run);
  } catch (const Stopped&) {
    throw_if_interrupted();
    throw;
  }
  const SmoothReport& report = result.report;
  const DisplacementStats& moved = result.moved;
  if (!output.quiet && result.smoothed) {
    std::fprintf(stderr,
                 "smooth: %zu points, %d %s steps%s (k %d, tau %g, lambda %.4g, eps %.4g) in %.2f s "
                 "(%.3g point-steps/s); displacement mean %.4g, max %.4g (%.3g%% of the diagonal); "
                 "%zu degenerate points -> %s\n",
                 result.selected, report.steps, to_string(params.flow.flow).c_str(),
                 coarse_level_text(report.coarse_levels).c_str(), report.k, params.flow.tau,
                 report.lambda, report.eps, result.seconds_total, result.rate, moved.mean, moved.max,
                 moved.diagonal > 0 ? 100.0 * moved.max / moved.diagonal : 0.0, result.degenerate,
                 output_path.c_str());
  }
  if (output.json) std::cout << result.json.str() << std::endl;
  return 0;
}

}  // namespace pointfair::cli
