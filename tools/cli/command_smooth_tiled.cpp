// pointfair smooth on HDF5 containers, or with --memory-budget: the out-of-core run.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

#include "commands.hpp"
#include "pointfair/neighbors/neighborhood_size.hpp"
#include "container_export.hpp"
#include "interrupt.hpp"
#include "out_of_core.hpp"
#include "progress.hpp"
#include "las_options.hpp"
#include "run_support.hpp"
#include "selection_options.hpp"
#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/common/version.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "pointfair/io/file_lock.hpp"
#include "pointfair/io/point_file.hpp"
#include "pointfair/tiles/budget.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/hdf5_file.hpp"
#include "pointfair/tiles/import.hpp"
#include "pointfair/tiles/tiled_smooth.hpp"

namespace pointfair::cli {

namespace fs = std::filesystem;

bool wants_out_of_core(const Args& args) {
  for (const std::string& a : args) {
    if (a == "--help" || a == "-h") return false;
    if (a == "--memory-budget" || a.starts_with("--memory-budget=") || a == "--resume") return true;
    if (!a.starts_with("--") && is_container_path(a)) return true;
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

void remove_quietly(const fs::path& p) {
  std::error_code ec;
  fs::remove(p, ec);
}

// The folder of a run that writes or reads a point file: ".<OUT's name>.pointfair-run" beside
// OUT, holding the imported input ("input.h5") and the run ("run.h5", "run.h5.partial"). The
// run's own files live in a folder the run made, so that they can never be a user's file; the
// folder is locked for the whole command and removed when the command ends, but for an
// interrupted run, which --resume continues.
fs::path work_folder_of(const fs::path& output) {
  std::string name = ".";
  name += output.filename().string();
  name += ".pointfair-run";
  return output.parent_path() / name;
}

// Makes or (with --resume) reopens the work folder, and locks it. `existed`: it was there
// before (an interrupted run's, which this command must never lose).
std::unique_ptr<io::FolderLock> open_work_folder(const fs::path& work, bool resume, bool& existed) {
  std::error_code ec;
  const bool made = fs::create_directory(work, ec);
  if (ec) throw io::IoError(work.string() + ": cannot create the run's folder: " + ec.message());
  existed = !made;
  if (!made) {
    const auto status = fs::symlink_status(work, ec);
    if (!fs::is_directory(status))
      throw io::IoError(work.string() + ": exists and is not a run's folder: it is left alone; remove or rename it");
    if (!resume)
      throw io::IoError(work.string() +
                        ": an interrupted run is in the way: pass --resume to continue it, or remove the folder");
  }
  auto lock = std::make_unique<io::FolderLock>(work);
  if (!made) {
    for (const auto& entry : fs::directory_iterator(work, ec)) {
      const std::string name = entry.path().filename().string();
      if (name != "input.h5" && name != "run.h5" && name != "run.h5.partial" && !name.starts_with("."))
        throw io::IoError(work.string() + ": holds files this tool did not make (" + name +
                          "): it is left alone; remove or rename it");
    }
  }
  return lock;
}

// Removes the run's files and its folder (only the names it makes).
void remove_work_folder(const fs::path& work) {
  for (const char* name : {"input.h5", "run.h5", "run.h5.partial"}) remove_quietly(work / name);
  remove_quietly(work);  // only when empty: a temporary still being removed keeps it
}

}  // namespace

int run_smooth_out_of_core(const Args& args) {
  std::string input, output_path;
  SmoothParams params;
  OutputOptions output;
  tiles::OutOfCoreOptions ooc;
  bool budget_given = false;
  ArgumentParser parser("pointfair smooth",
                        "Denoises a point cloud with the anisotropic mean curvature flow of Lange & "
                        "Polthier (2005), out of core: tiles of an HDF5 container stream through a "
                        "bounded memory budget, every step is committed to the output file, and the "
                        "result is bit-identical to the in-core run.");
  parser.positional("IN", "Input container (.h5) or point file (.ply, .xyz, ...).", &input);
  parser.positional("OUT", "Output container (.h5) or point file.", &output_path);
  add_method_options(parser, params);
  add_finish_options(parser, params);
  parser.value("memory-budget", "SIZE",
               "Working memory of the run (e.g. 256M, 2G). A point-file input that fits runs in "
               "core. Default 256M.",
               [&](std::string_view v) {
                 ooc.memory_budget = parse_size(v, "--memory-budget");
                 budget_given = true;
               });
  parser.value("neighbors-from", "REF",
               "Build the first neighbourhoods from this cloud (point file or container; same "
               "points, same order) instead of the input.",
               [&](std::string_view v) { ooc.neighbor_reference = std::string(v); });
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
  parser.flag("resume", "Continue the interrupted run in OUT.partial (same parameters).",
              [&] { ooc.resume = true; });
  SelectionOptions select;
  add_selection_options(parser, select);
  add_output_options(parser, output, true);
  add_las_options(parser, output.las);
  if (!parser.parse(args)) return 0;
  require_las_output(output.las, output_path);
  params.validate();
  require_selection_compatible(select, output.attributes, output.colour_by != ColourBy::None);
  set_thread_count(output.threads);
  const auto t_start = std::chrono::steady_clock::now();

  const bool container_in = is_container_path(input), container_out = is_container_path(output_path);
  // The run's container holds the selected points only; the export walks the point file
  // and puts them back among the others.
  const bool selecting = !select.selection.all();
  if (selecting && (container_in || container_out))
    throw UsageError(std::string(select.classes.empty() ? "--returns" : "--classes") +
                     " takes a point file in and out (a container holds only the points a run smooths)");
  io::require_output_path(output_path);
  fs::path run_input = input;
  fs::path imported;
  fs::path work;
  std::unique_ptr<io::FolderLock> work_lock;
  if (!container_in) {
    // The PLY header's count, or a counting pass over a text file: the cloud is not loaded.
    const std::uint64_t points = count_points(input);
    if (!container_out && fits_in_core(points, params, ooc.memory_budget) && !ooc.resume) {
      return run_smooth(without_budget(args));
    }
    io::require_distinct(input, output_path);
  }
  // Tiles follow the budget: a container whose tiles are larger than the budget's (imported
  // under a larger one) is imported again with the budget's tiles, into the run's folder, as
  // a point file is (a container output then holds those tiles). A resumed run takes the
  // input its folder holds.
  const int flow_k = params.neighbors.k == 0 ? kAutoKMax : params.neighbors.k;
  const int k_bound = params.finish ? std::max(flow_k, params.finish->k) : flow_k;
  const std::uint64_t tile_points = tiles::tile_points_for_budget(ooc.memory_budget, k_bound);
  bool retile = false;
  if (container_in) {
    const auto f = tiles::h5::File::open(input, false);
    const tiles::TileTable table = tiles::read_tile_table(f);
    for (std::size_t t = 0; t < table.size(); ++t) retile = retile || table.rows(t) > tile_points;
    retile = retile || (ooc.resume && fs::exists(work_folder_of(output_path) / "input.h5"));
    if (retile) io::require_distinct(input, output_path);
  }
  bool work_existed = false;
  if (!container_in || !container_out || retile) {
    work = work_folder_of(output_path);
    work_lock = open_work_folder(work, ooc.resume, work_existed);
  }
  // The work folder goes when the run is done; when the command fails, only if this command
  // made it and it holds nothing to resume (or the run cannot be continued). An interrupted
  // run's folder that a --resume found stays whatever happens before its end.
  struct WorkGuard {
    fs::path work;
    bool existed = false;
    bool keep = false;
    bool done = false;
    ~WorkGuard() {
      if (work.empty() || (existed && !done)) return;
      std::error_code ec;
      if (done || !keep || !fs::exists(work / "run.h5.partial", ec)) remove_work_folder(work);
    }
  } guard{work, work_existed};
  if (!container_in || retile) {
    imported = work / "input.h5";
    // What the run continues must be this input: its bytes, not only its size (and the same
    // selection of its points).
    std::string digest = io::file_digest(input);
    if (selecting) digest += " classes " + select.classes + " returns " + select.returns;
    if (ooc.resume && fs::exists(imported)) {
      const auto f = tiles::h5::File::open(imported, false);
      if (!f.has_attribute("/", "source_digest") || f.string_attribute("/", "source_digest") != digest)
        throw io::IoError(input + ": the interrupted run in " + work.string() +
                          " was started from another input (its content differs" +
                          (selecting ? std::string(", or its --classes or --returns") : std::string()) +
                          "): give that input, or remove the folder to start again");
    } else {
      tiles::StreamImportOptions import;
      import.container.tiling.max_tile_points = tile_points;
      import.container.source_name = fs::path(input).filename().string();
      import.container.source_size = input_file_size(input);
      if (container_in) {
        // The container's own source, which an export names.
        const auto f = tiles::h5::File::open(input, false);
        import.container.source_name = f.string_attribute("/", "source_name");
        import.container.source_size = static_cast<std::uint64_t>(f.int_attribute("/", "source_size_bytes"));
      }
      import.container.source_digest = digest;
      import.select = select.selection;
      // The import streams the file within the budget (at least its minimum of 16 MiB).
      import.memory_budget = std::max(ooc.memory_budget, kMinImportBudget);
      import.read.on_warning = [quiet = output.quiet](const std::string& message) {
        if (!quiet) std::fprintf(stderr, "warning: %s\n", message.c_str());
      };
      import.progress = [](const std::string&, std::uint64_t, std::uint64_t) { throw_if_interrupted(); };
      tiles::import_points(input, imported, import);
    }
    run_input = imported;
  }
  // A selection of no point: nothing to smooth, the file is written back as it was.
  bool nothing_selected = false;
  if (selecting) {
    const auto f = tiles::h5::File::open(imported, false);
    nothing_selected = tiles::point_count(f) == 0;
    if (nothing_selected && !output.quiet)
      std::fprintf(stderr, "smooth: no point of %s selected: nothing to smooth, the file is written back as it was\n",
                   input.c_str());
  }
  (void)budget_given;
  const fs::path run_output = container_out ? fs::path(output_path) : work / "run.h5";
  // From here an interrupted or failed run keeps what it committed, for --resume.
  guard.keep = true;

  Progress progress("smooth (out of core): step", !output.quiet);
  Progress finish_progress("smooth (out of core): finish, tiles of this pass", !output.quiet);
  Progress attributes_progress("smooth (out of core): attributes, tiles", !output.quiet);
  ooc.attributes = true;
  // A signal stops the run after the phase's current tile or step: what is committed stays in
  // the partial file, and --resume continues from it (as after a kill).
  const std::string kept_in =
      work.empty() ? tiles::partial_name(run_output).filename().string() : work.filename().string();
  const std::string resume_hint = "the run so far is kept in " + kept_in + ": run the same command with --resume to continue";
  ooc.progress = [&](const std::string& phase, std::uint64_t done, std::uint64_t total) {
    throw_if_interrupted(resume_hint);
    const auto d = static_cast<long long>(done), t = static_cast<long long>(total);
    if (phase == "step") {
      progress.update(d, t);
    } else if (phase == "finish") {
      progress.finish();
      finish_progress.update(d, t);
    } else if (phase == "attributes") {
      finish_progress.finish();
      attributes_progress.update(d, t);
    }
  };
  tiles::OutOfCoreReport report;
  try {
    if (!nothing_selected) report = tiles::smooth_out_of_core(run_input, run_output, params, ooc);
  } catch (const ParamError& e) {
    // A point-file run that cannot start (e.g. too small a budget) leaves nothing behind;
    // a container run keeps its partial file for --resume, and says so when the budget was
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
    std::error_code ec;
    if (budget == nullptr || !fs::exists(tiles::partial_name(run_output), ec)) throw;
    throw ParamError(std::string(e.what()) + " (the run so far is kept in " + kept_in +
                     ": add --resume with a larger --memory-budget to continue it, or remove it)");
  } catch (const io::IoError& e) {
    // A failed read or write (a full disk, a disk that fails to sync): a container run keeps
    // the steps committed before it in its partial file, and says so.
    std::error_code ec;
    if (!fs::exists(tiles::partial_name(run_output), ec)) throw;
    throw io::IoError(std::string(e.what()) + " (the steps committed so far are kept in " + kept_in +
                      ": once the cause is fixed, run the same command with --resume to continue)");
  }
  progress.finish();
  finish_progress.finish();
  attributes_progress.finish();
  if (container_out) guard.done = true;  // a container imported again: its folder goes

  double seconds_write = 0.0;
  SelectedExportSummary selected;
  if (selecting) {
    const auto t0 = std::chrono::steady_clock::now();
    selected = export_selected(nothing_selected ? fs::path() : run_output, input, select.selection, output_path,
                               output, ooc.memory_budget);
    guard.done = true;
    seconds_write = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  } else if (!container_out) {
    const auto t0 = std::chrono::steady_clock::now();
    ContainerExport exported;
    exported.memory_budget = ooc.memory_budget;
    export_container(run_output, output_path, output, exported, input);
    guard.done = true;
    seconds_write = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  const double seconds_total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  const int steps_here = report.steps - report.resumed_from;
  const double rate = report.seconds_steps > 0
                          ? static_cast<double>(report.points) * steps_here / report.seconds_steps
                          : 0.0;
  if (!output.quiet && !nothing_selected)
    std::fprintf(stderr,
                 "smooth: %llu %spoints in %zu tiles, %d steps (%d resumed) out of core (k %d, lambda %.4g, eps %.4g) "
                 "in %.2f s (%.3g point-steps/s); working memory %.1f MiB of %.1f MiB; %zu degenerate "
                 "points -> %s\n",
                 static_cast<unsigned long long>(report.points), selecting ? "selected " : "", report.tiles, report.steps,
                 report.resumed_from, report.k, report.lambda, report.eps, seconds_total, rate,
                 static_cast<double>(report.peak_accounted_bytes) / (1 << 20),
                 static_cast<double>(ooc.memory_budget) / (1 << 20), report.degenerate, output_path.c_str());
  if (output.json) {
    JsonObject seconds;
    seconds.add("neighbors", report.seconds_neighbors).add("steps", report.seconds_steps)
        .add("finish", report.seconds_finish).add("attributes", report.seconds_attributes)
        .add("write", seconds_write).add("total", seconds_total);
    JsonObject j;
    j.add("command", "smooth").add("version", version()).add("input", input).add("output", output_path);
    j.add("out_of_core", true)
        .add("points", static_cast<std::size_t>(selecting ? selected.points : report.points))
        .add("tiles", report.tiles);
    if (selecting)
      j.add("selection", selection_json(select, static_cast<std::size_t>(selected.selected),
                                        static_cast<std::size_t>(selected.moved)));
    j.add("steps", report.steps).add("resumed_from", report.resumed_from).add("threads", thread_count());
    j.add("stop_reason", report.stop_reason ? std::string(to_string(*report.stop_reason))
                                            : std::string("unknown (the steps ended before this resume)"));
    j.add("parameters", parameters_json(params, report.k, report.eps, report.lambda));
    j.add("quadric_finish", finish_json(params));
    j.add("placement", params.finish && params.placement == Placement::AlongNormal ? "normal" : "free");
    j.add("memory_budget_bytes", static_cast<std::size_t>(ooc.memory_budget));
    j.add("peak_accounted_bytes", static_cast<std::size_t>(report.peak_accounted_bytes));
    j.add("largest_tile_with_halo", static_cast<std::size_t>(report.largest_tile_with_halo));
    j.add("neighbors_cached", report.neighbors_cached).add("positions_held", report.positions_held);
    j.add("halo_scratch", report.halo_scratch);
    j.add("step_blocks", report.step_blocks);
    j.add("tiles_in_flight", report.tiles_in_flight);
    j.add("rebuilds", report.rebuilds).add("temporal_block", ooc.temporal_block);
    // Bytes the steps read: positions (24 per row) and neighbour lists (4 k + 2 per row).
    const std::size_t list_row_bytes = 4 * static_cast<std::size_t>(report.k) + 2;
    j.add("bytes_read_per_step",
          steps_here > 0 ? static_cast<double>(report.position_rows_read * 24 + report.list_rows_read * list_row_bytes) /
                               steps_here
                         : 0.0);
    j.add("seconds", seconds).add("point_steps_per_second", rate).add("degenerate_points", report.degenerate);
    std::cout << j.str() << std::endl;
  }
  return 0;
}

}  // namespace pointfair::cli
