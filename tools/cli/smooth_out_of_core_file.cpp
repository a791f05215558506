#include "smooth_out_of_core_file.hpp"

#include <algorithm>
#include <cstdio>
#include <memory>
#include <system_error>

#include "container_export.hpp"
#include "out_of_core.hpp"
#include "point_folder_run.hpp"
#include "run_folder.hpp"
#include "run_support.hpp"
#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/common/version.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "pointfair/io/file_lock.hpp"
#include "pointfair/io/point_folder.hpp"
#include "pointfair/tiles/budget.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/hdf5_file.hpp"
#include "pointfair/tiles/import.hpp"

namespace pointfair::cli {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

// Whether an interrupted run writing `output` left something to resume: its partial file, or
// its coarse level's folder.
bool has_run(const fs::path& output) {
  std::error_code ec;
  return fs::exists(tiles::partial_name(output), ec) || fs::exists(tiles::coarse_folder_name(output), ec);
}

// The run's folder goes when the run is done; when the run fails, only if this run made it
// and it holds nothing to resume (or the run cannot be continued, or keeps nothing). An
// interrupted run's folder that a resume found stays whatever happens before its end. A
// container output's partial file that this run made goes with a failed run that keeps
// nothing.
struct RunFilesGuard {
  fs::path folder;
  bool existed = false;
  bool keep = false;
  bool done = false;
  fs::path partial;  // set while a run that keeps nothing may leave one
  fs::path coarse;   // the output whose coarse level's folder such a run may leave
  ~RunFilesGuard() {
    std::error_code ec;
    if (!partial.empty() && !done) fs::remove(partial, ec);
    if (!coarse.empty() && !done) tiles::remove_coarse_folder(coarse);
    if (folder.empty() || (existed && !done)) return;
    if (done || !keep || !has_run(folder / "run.h5")) remove_run_folder(folder);
  }
};

// Imports `run.input` (a point file, or a container to be tiled again) into `imported` with
// the budget's tiles, or checks that the interrupted run being resumed started from it.
void import_input(const OutOfCoreFileSmooth& run, const fs::path& folder, const fs::path& imported,
                  std::uint64_t tile_points) {
  const bool selecting = !run.select.selection.all();
  const tiles::OutOfCoreOptions& ooc = run.options;
  // What the run continues must be this input: its bytes, not only its size (and the same
  // selection of its points).
  std::string digest = is_folder_input(run.input) ? io::folder_digest(io::point_files_in(run.input))
                                                 : io::file_digest(run.input);
  if (selecting) digest += " classes " + run.select.classes + " returns " + run.select.returns;
  if (ooc.resume && fs::exists(imported)) {
    const auto f = tiles::h5::File::open(imported, false);
    if (!f.has_attribute("/", "source_digest") || f.string_attribute("/", "source_digest") != digest)
      throw io::IoError(run.input + ": the interrupted run in " + folder.string() +
                        " was started from another input (its content differs" +
                        (selecting ? std::string(", or its --classes or --returns") : std::string()) +
                        "): give that input, or remove the folder to start again");
    return;
  }
  tiles::StreamImportOptions import;
  import.container.tiling.max_tile_points = tile_points;
  import.container.source_name = fs::path(run.input).filename().string();
  import.container.source_size = input_file_size(run.input);
  if (tiles::is_container_path(run.input)) {
    // The container's own source, which an export names.
    const auto f = tiles::h5::File::open(run.input, false);
    import.container.source_name = f.string_attribute("/", "source_name");
    import.container.source_size = static_cast<std::uint64_t>(f.int_attribute("/", "source_size_bytes"));
  }
  import.container.source_digest = digest;
  import.select = run.select.selection;
  // The import streams the file within the budget (at least its minimum of 16 MiB).
  import.memory_budget = std::max(ooc.memory_budget, tiles::kMinImportBudget);
  import.read.on_warning = [quiet = run.output_options.quiet](const std::string& message) {
    if (!quiet) std::fprintf(stderr, "warning: %s\n", message.c_str());
  };
  import.progress = [&run](const std::string& pass, std::uint64_t done, std::uint64_t total) {
    if (run.progress) run.progress({.importing = true, .phase = pass, .done = done, .total = total, .kept_in = {}});
  };
  tiles::import_points(run.input, imported, import);
}

JsonObject summary_json(const OutOfCoreFileSmooth& run, const tiles::OutOfCoreReport& report,
                        const tiles::SelectedExportReport& selected, double seconds_write, double seconds_total,
                        double rate) {
  const SmoothParams& params = run.params;
  const bool selecting = !run.select.selection.all();
  const int steps_here = report.steps - report.resumed_from;
  JsonObject seconds;
  seconds.add("coarse_level", report.seconds_coarse).add("neighbors", report.seconds_neighbors).add("steps", report.seconds_steps)
      .add("finish", report.seconds_finish).add("attributes", report.seconds_attributes)
      .add("write", seconds_write).add("total", seconds_total);
  JsonObject j;
  j.add("command", "smooth").add("version", version()).add("input", run.input).add("output", run.output);
  j.add("out_of_core", true)
      .add("points", static_cast<std::size_t>(selecting ? selected.points : report.points))
      .add("tiles", report.tiles);
  if (selecting)
    j.add("selection", selection_json(run.select, static_cast<std::size_t>(selected.selected),
                                      static_cast<std::size_t>(selected.moved)));
  j.add("steps", report.steps).add("resumed_from", report.resumed_from).add("threads", thread_count());
  j.add("stop_reason", report.stop_reason ? std::string(to_string(*report.stop_reason))
                                          : std::string("unknown (the steps ended before this resume)"));
  j.add("parameters", parameters_json(params, report.k, report.eps, report.lambda));
  j.add("quadric_finish", finish_json(params, report.finish_passes));
  if (params.coarse) j.add("coarse_level", coarse_level_json(*params.coarse, report.coarse_levels));
  j.add("placement", name_of(params.finish ? params.placement : Placement::Free));
  j.add("memory_budget_bytes", static_cast<std::size_t>(run.options.memory_budget));
  j.add("peak_accounted_bytes", static_cast<std::size_t>(report.peak_accounted_bytes));
  j.add("largest_tile_with_halo", static_cast<std::size_t>(report.largest_tile_with_halo));
  j.add("finish_tiles_in_parts", static_cast<std::size_t>(report.finish_tiles_in_parts));
  j.add("neighbors_cached", report.neighbors_cached).add("positions_held", report.positions_held);
  j.add("halo_scratch", report.halo_scratch);
  j.add("step_blocks", report.step_blocks);
  j.add("tiles_in_flight", report.tiles_in_flight);
  j.add("rebuilds", report.rebuilds).add("temporal_block", run.options.temporal_block);
  if (has_momentum(params)) j.add("momentum_restarts", report.momentum_restarts);
  // Bytes the steps read: positions (24 per row) and neighbour lists (4 k + 2 per row).
  const std::size_t list_row_bytes = 4 * static_cast<std::size_t>(report.k) + 2;
  j.add("bytes_read_per_step",
        steps_here > 0 ? static_cast<double>(report.position_rows_read * 24 + report.list_rows_read * list_row_bytes) /
                             steps_here
                       : 0.0);
  j.add("seconds", seconds).add("point_steps_per_second", rate).add("degenerate_points", report.degenerate);
  return j;
}

}  // namespace

OutOfCoreFileSmoothResult smooth_out_of_core_file(const OutOfCoreFileSmooth& run) {
  const auto t_start = run.started.value_or(Clock::now());
  const SmoothParams& params = run.params;
  const std::string& input = run.input;
  const std::string& output_path = run.output;
  const OutputOptions& output = run.output_options;
  tiles::OutOfCoreOptions ooc = run.options;
  const bool container_in = tiles::is_container_path(input), container_out = tiles::is_container_path(output_path);
  // The run's container holds the selected points only; the export walks the point file
  // and puts them back among the others.
  const bool selecting = !run.select.selection.all();
  if (!container_in) io::require_distinct(input, output_path);
  // A folder's files, each written back to the output folder (a container output takes the
  // folder's points as one cloud).
  const bool folder = is_folder_input(input);
  FolderRun files;
  if (folder && !container_out) files = plan_folder_run(input, output_path);
  // Tiles follow the budget: a container whose tiles are larger than the budget's (imported
  // under a larger one) is imported again with the budget's tiles, into the run's folder, as
  // a point file is (a container output then holds those tiles). A resumed run takes the
  // input its folder holds.
  const std::uint64_t tile_points = tiles::run_tile_points(ooc.memory_budget, params);
  bool retile = false;
  if (container_in) {
    const auto f = tiles::h5::File::open(input, false);
    const tiles::TileTable table = tiles::read_tile_table(f);
    for (std::size_t t = 0; t < table.size(); ++t) retile = retile || table.rows(t) > tile_points;
    retile = retile || (ooc.resume && fs::exists(run_folder_of(output_path) / "input.h5"));
    if (retile) io::require_distinct(input, output_path);
  }
  fs::path work;
  std::unique_ptr<io::FolderLock> work_lock;
  bool work_existed = false;
  if (!container_in || !container_out || retile) {
    work = run_folder_of(output_path);
    work_lock = open_run_folder(work, ooc.resume, work_existed);
  }
  RunFilesGuard guard{.folder = work, .existed = work_existed, .keep = false, .done = false, .partial = {}, .coarse = {}};
  fs::path run_input = input;
  fs::path imported;
  if (!container_in || retile) {
    imported = work / "input.h5";
    import_input(run, work, imported, tile_points);
    run_input = imported;
  }
  OutOfCoreFileSmoothResult result;
  // A selection of no point: nothing to smooth, the file is written back as it was.
  if (selecting) {
    const auto f = tiles::h5::File::open(imported, false);
    result.nothing_selected = tiles::point_count(f) == 0;
    if (result.nothing_selected && run.note)
      run.note("smooth: no point of " + input + " selected: nothing to smooth, the file is written back as it was");
  }
  const fs::path run_output = container_out ? fs::path(output_path) : work / "run.h5";
  // From here an interrupted or failed run keeps what it committed, for a resume; or, when it
  // keeps nothing, loses the partial file it made.
  guard.keep = run.keep_interrupted;
  std::error_code ec;
  if (!run.keep_interrupted && !fs::exists(tiles::partial_name(run_output), ec))
    guard.partial = tiles::partial_name(run_output);
  if (!run.keep_interrupted && !fs::exists(tiles::coarse_folder_name(run_output), ec)) guard.coarse = run_output;

  // The attributes (a pass over every tile at the end) only where the output takes them, as
  // in core: the input's normal columns (refreshed), --attributes, colours. A container
  // output keeps them for later exports; a folder's files may each have normals.
  ooc.attributes = container_out || folder || output.attributes || output.colour_by != ColourBy::None ||
                   (!result.nothing_selected && container_has_normal_columns(run_input));
  // What keeps the committed steps when `progress` stops the run (as after a kill), for a
  // resume to continue.
  const std::string kept_in = !run.keep_interrupted ? std::string()
                              : work.empty()        ? tiles::partial_name(run_output).filename().string()
                                                    : work.filename().string();
  ooc.progress = [&run, &kept_in](const std::string& phase, std::uint64_t done, std::uint64_t total) {
    if (run.progress) run.progress({.importing = false, .phase = phase, .done = done, .total = total, .kept_in = kept_in});
  };
  tiles::OutOfCoreReport& report = result.report;
  try {
    if (!result.nothing_selected) report = tiles::smooth_out_of_core(run_input, run_output, params, ooc);
  } catch (const ParamError& e) {
    // A point-file run that cannot start (e.g. too small a budget) leaves nothing behind;
    // a container run keeps its partial file for a resume, and says so when the budget was
    // too small.
    const auto* budget = dynamic_cast<const tiles::BudgetError*>(&e);
    if (!imported.empty()) {
      guard.keep = false;
      if (budget == nullptr) throw;
      // The tiles were sized for the budget: only a larger one helps, with its own tiles.
      throw ParamError("the memory budget of " + tiles::size_text(budget->budget) + " is too small for " + input +
                       " (the run needs " + tiles::size_text(budget->needed, true) + "): give a larger --memory-budget, " +
                       tiles::size_text(tiles::budget_to_name(budget->needed)) + " or more" +
                       (work_existed ? " (the interrupted run stays in " + work.filename().string() + ")" : ""));
    }
    if (budget == nullptr || kept_in.empty() || !has_run(run_output)) throw;
    throw ParamError(std::string(e.what()) + " (the run so far is kept in " + kept_in +
                     ": add --resume with a larger --memory-budget to continue it, or remove it)");
  } catch (const io::IoError& e) {
    // A failed read or write (a full disk, a disk that fails to sync): a container run keeps
    // the steps committed before it in its partial file, and says so.
    if (kept_in.empty() || !has_run(run_output)) throw;
    throw io::IoError(std::string(e.what()) + " (the steps committed so far are kept in " + kept_in +
                      ": once the cause is fixed, run the same command with --resume to continue)");
  }
  if (container_out) guard.done = true;  // a container imported again: its folder goes

  double seconds_write = 0.0;
  tiles::SelectedExportReport selected;
  if (selecting) {
    const auto t0 = Clock::now();
    selected = tiles::export_selected(result.nothing_selected ? fs::path() : run_output, input, run.select.selection,
                                      output_path, write_options(output, input), ooc.memory_budget);
    guard.done = true;
    seconds_write = seconds_since(t0);
  } else if (folder && !container_out) {
    const auto t0 = Clock::now();
    tiles::export_folder(run_output, files.inputs, files.outputs, write_options(output), ooc.memory_budget);
    guard.done = true;
    seconds_write = seconds_since(t0);
  } else if (!container_out) {
    const auto t0 = Clock::now();
    tiles::StreamExportOptions exported;
    exported.memory_budget = ooc.memory_budget;
    export_container(run_output, output_path, output, exported, input);
    guard.done = true;
    seconds_write = seconds_since(t0);
  }
  result.seconds_total = seconds_since(t_start);
  const int steps_here = report.steps - report.resumed_from;
  result.rate = report.seconds_steps > 0
                    ? static_cast<double>(report.points) * steps_here / report.seconds_steps
                    : 0.0;
  result.json = summary_json(run, report, selected, seconds_write, result.seconds_total, result.rate);
  return result;
}

}  // namespace pointfair::cli
