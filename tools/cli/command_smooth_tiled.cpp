// pointfair smooth on HDF5 containers, or with --memory-budget: the out-of-core run's arguments
// and printing (the run: smooth_out_of_core_file.hpp).
#include <chrono>
#include <cstdio>
#include <iostream>
#include <optional>
#include <string>

#include "commands.hpp"
#include "interrupt.hpp"
#include "las_options.hpp"
#include "out_of_core.hpp"
#include "point_folder_run.hpp"
#include "progress.hpp"
#include "run_support.hpp"
#include "selection_options.hpp"
#include "smooth_out_of_core_file.hpp"
#include "pointfair/common/parallel.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/out_of_core_decision.hpp"

namespace pointfair::cli {

bool wants_out_of_core(const Args& args) {
  for (const std::string& a : args) {
    if (a == "--help" || a == "-h") return false;
    if (a == "--memory-budget" || a.starts_with("--memory-budget=") || a == "--resume") return true;
    if (!a.starts_with("--") && tiles::is_container_path(a)) return true;
  }
  return false;
}

namespace {

Args without_budget(const Args& args) {
  Args out;
  for (std::size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--memory-budget") {
      ++i;
      continue;
    }
    if (args[i].starts_with("--memory-budget=")) continue;
    out.push_back(args[i]);
  }
  return out;
}

}  // namespace

void add_budget_options(ArgumentParser& parser, std::uint64_t* budget, bool* resume) {
  const OptionGroup group = parser.current_group();
  parser.group(OptionGroup::Common);
  parser.value("memory-budget", "SIZE",
               "Working memory of the run (e.g. 256M, 2G): a point file that does not fit in it runs "
               "out of core, in tiles streamed through a run file beside the output, bit-identical "
               "to the in-core run (docs/out-of-core.md); one that fits runs in core. Without it a "
               "point file runs in core and a container (.h5) in 256M. With it, --help lists the "
               "out-of-core options.",
               [budget](std::string_view v) {
                 const std::uint64_t bytes = parse_size(v, "--memory-budget");
                 if (budget != nullptr) *budget = bytes;
               });
  parser.flag("resume", "Continue the interrupted run in OUT.partial (same parameters).", [resume] {
    if (resume != nullptr) *resume = true;
  });
  parser.group(group);
}

int run_smooth_out_of_core(const Args& args) {
  std::string input, output_path;
  SmoothParams params;
  OutputOptions output;
  tiles::OutOfCoreOptions ooc;
  ArgumentParser parser("pointfair smooth",
                        "Denoises a point cloud with the anisotropic mean curvature flow of Lange & "
                        "Polthier (2005), out of core: tiles of an HDF5 container stream through a "
                        "bounded memory budget, every step is committed to the output file, and the "
                        "result is bit-identical to the in-core run.");
  parser.positional("IN", "Input container (.h5), point file (.ply, .xyz, ...) or folder of point files.", &input);
  parser.positional("OUT", "Output container (.h5), point file, or folder (for a folder IN).", &output_path);
  add_method_options(parser, params);
  add_finish_options(parser, params);
  add_budget_options(parser, &ooc.memory_budget, &ooc.resume);
  parser.group(OptionGroup::Method);
  parser.value("neighbors-from", "REF",
               "Build the first neighbourhoods from this cloud (point file or container; same "
               "points, same order) instead of the input.",
               [&](std::string_view v) { ooc.neighbor_reference = std::string(v); });
  parser.group(OptionGroup::Advanced);
  parser.value("temporal-block", "H",
               "Steps per load of a tile, which then comes with H rings of neighbours (2H with "
               "--shrink-compensation): less I/O per step, same result. Needs a fixed --lambda or "
               "--lambda-schedule once. Default 1.",
               [&](std::string_view v) { ooc.temporal_block = parse_int(v, "--temporal-block"); });
  parser.flag("no-halo-scratch",
              "Read each streamed step's halos from the run file rather than from a scratch file "
              "beside OUT (unlinked; 48 bytes of disk per halo point): slower, same result.",
              [&] { ooc.halo_scratch = false; });
  parser.flag("no-step-blocks",
              "Stream single steps (--temporal-block 1, no --shrink-compensation) each with its "
              "tile's halo, rather than as blocks of one step whose lists come from a scratch "
              "file made once: slower, same result.",
              [&] { ooc.step_blocks = false; });
  SelectionOptions select;
  add_selection_options(parser, select);
  add_output_options(parser, output, true);
  add_las_options(parser, output.las);
  parser.example("pointfair smooth city.las city-smooth.las --memory-budget 2G");
  parser.example("pointfair smooth city.h5 city-smooth.las --resume");
  if (!parser.parse(args)) return 0;
  require_las_output(output.las, output_path);
  params.validate();
  require_selection_compatible(select, output.attributes, output.colour_by != ColourBy::None);
  set_thread_count(output.threads);
  const auto t_start = std::chrono::steady_clock::now();

  // The run's container holds the selected points only; the export walks the point file
  // and puts them back among the others.
  const bool selecting = !select.selection.all();
  if (selecting && (tiles::is_container_path(input) || tiles::is_container_path(output_path)))
    throw UsageError(std::string(select.classes.empty() ? "--returns" : "--classes") +
                     " takes a point file in and out (a container holds only the points a run smooths)");
  check_smooth_paths(input, output_path, select, output, !ooc.neighbor_reference.empty());
  if (!tiles::runs_out_of_core(input, output_path, params, ooc.memory_budget, ooc.resume))
    return run_smooth(without_budget(args));

  // One progress line per phase of the run (not of the import), from the run's start.
  std::optional<Progress> progress, finish_progress, attributes_progress;
  // The coarse level's phases (--coarse-level): its sample, its own steps, the moves.
  std::optional<Progress> coarse_progress;
  std::string coarse_phase;
  OutOfCoreFileSmooth run;
  run.input = input;
  run.output = output_path;
  run.params = params;
  run.options = ooc;
  run.select = select;
  run.output_options = output;
  run.started = t_start;
  run.note = stderr_notes(output.quiet);
  run.progress = [&](const OutOfCoreProgress& at) {
    if (at.importing) {
      throw_if_interrupted();
      return;
    }
    if (!progress) {
      progress.emplace("smooth (out of core): step", !output.quiet);
      finish_progress.emplace("smooth (out of core): finish, tiles of this pass", !output.quiet);
      attributes_progress.emplace("smooth (out of core): attributes, tiles", !output.quiet);
    }
    // A signal stops the run after the phase's current tile or step: what is committed stays in
    // the partial file, and --resume continues from it (as after a kill).
    throw_if_interrupted("the run so far is kept in " + std::string(at.kept_in) +
                         ": run the same command with --resume to continue");
    const auto d = static_cast<long long>(at.done), t = static_cast<long long>(at.total);
    if (at.phase == "coarse sample" || at.phase == "coarse step" || at.phase == "coarse moves") {
      if (at.phase != coarse_phase) {
        coarse_progress.reset();
        coarse_phase = at.phase;
        coarse_progress.emplace("smooth (out of core): coarse level, " +
                                    (at.phase == "coarse step" ? std::string("step") : std::string(at.phase.substr(7)) + " of tiles"),
                                !output.quiet);
      }
      coarse_progress->update(d, t);
      return;
    }
    if (coarse_progress) coarse_progress.reset();
    if (at.phase == "step") {
      progress->update(d, t);
    } else if (at.phase == "finish") {
      progress->finish();
      finish_progress->update(d, t);
    } else if (at.phase == "attributes") {
      finish_progress->finish();
      attributes_progress->update(d, t);
    }
  };
  const OutOfCoreFileSmoothResult result = smooth_out_of_core_file(run);
  if (progress) {
    progress->finish();
    finish_progress->finish();
    attributes_progress->finish();
  }
  const tiles::OutOfCoreReport& report = result.report;
  if (!output.quiet && !result.nothing_selected)
    std::fprintf(stderr,
                 "smooth: %llu %spoints in %zu tiles, %d steps (%d resumed)%s out of core (k %d, lambda %.4g, eps %.4g) "
                 "in %.2f s (%.3g point-steps/s); working memory %.1f MiB of %.1f MiB; %zu degenerate "
                 "points -> %s\n",
                 static_cast<unsigned long long>(report.points), selecting ? "selected " : "", report.tiles, report.steps,
                 report.resumed_from, coarse_level_text(report.coarse_levels).c_str(), report.k, report.lambda, report.eps, result.seconds_total, result.rate,
                 static_cast<double>(report.peak_accounted_bytes) / (1 << 20),
                 static_cast<double>(ooc.memory_budget) / (1 << 20), report.degenerate, output_path.c_str());
  if (output.json) std::cout << result.json.str() << std::endl;
  return 0;
}

}  // namespace pointfair::cli
