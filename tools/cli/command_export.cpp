// pointfair export IN.h5 OUT: a container (with or without a finished run) to a point file, or
// (--files IN_DIR) back into the files of the folder it was imported from.
#include <cstdio>
#include <iostream>

#include "commands.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "container_export.hpp"
#include "out_of_core.hpp"
#include "point_folder_run.hpp"
#include "las_options.hpp"
#include "run_support.hpp"
#include "pointfair/tiles/budget.hpp"
#include "pointfair/tiles/container.hpp"

namespace pointfair::cli {

int run_export(const Args& args) {
  std::string input, output;
  OutputOptions out;
  bool tile_order = false, input_positions = false;
  std::uint64_t budget = tiles::kDefaultMemoryBudget;
  ArgumentParser parser("pointfair export",
                        "Writes the points of an HDF5 scan container to a point file, in the input's "
                        "point order. For a container holding a finished smoothing run, the smoothed "
                        "positions and (with --attributes or --colour-by) the run's per-point results; "
                        "the input's normals are replaced by the run's, and the file is written in "
                        "the layout of the file that was imported (docs/formats.md).");
  parser.positional("IN", "Input container (.h5).", &input);
  parser.positional("OUT", "Output point file (.ply, .las, .laz, .xyz, .txt, .pts, .csv).", &output);
  std::string files_from;
  parser.value("files", "IN_DIR",
               "The container was imported from the folder IN_DIR (pointfair import IN_DIR, or "
               "pointfair_mpi import): write each of its files back into the folder OUT under its "
               "name, format and layout, with its points' smoothed positions (docs/tiles-folder.md).",
               [&](std::string_view v) { files_from = std::string(v); });
  parser.flag("tile-order", "Write points in the container's tile order instead of the input's order.",
              [&] { tile_order = true; });
  parser.flag("input-positions", "Write the input positions even when the container holds a run.",
              [&] { input_positions = true; });
  parser.value("memory-budget", "SIZE",
               "Memory for points held at a time (e.g. 256M, 2G); the cloud streams through. Default 256M.",
               [&](std::string_view v) { budget = parse_size(v, "--memory-budget"); });
  add_output_options(parser, out, true);
  add_las_options(parser, out.las);
  parser.example("pointfair export city.h5 city-smooth.las");
  parser.example("pointfair export city.h5 city-input.ply --input-positions --encoding ascii");
  parser.example("pointfair export run.h5 smoothed-tiles/ --files tiles/");
  if (!parser.parse(args)) return 0;
  require_las_output(out.las, output);
  if (!tiles::is_container_path(input)) throw UsageError("pointfair export: IN must be a .h5 file, got '" + input + "'");
  if (!files_from.empty()) {
    if (tile_order || input_positions) throw UsageError("--files takes neither --tile-order nor --input-positions");
    require_folder_options({}, out, false);
    const FolderRun files = plan_folder_run(without_trailing_separator(files_from), without_trailing_separator(output));
    tiles::export_folder(input, files.inputs, files.outputs, write_options(out), budget);
    if (!out.quiet)
      std::fprintf(stderr, "export: %zu files -> %s\n", files.outputs.size(), output.c_str());
    return 0;
  }
  io::require_output_path(output);
  tiles::StreamExportOptions options;
  options.original_order = !tile_order;
  options.input_positions = input_positions;
  options.memory_budget = budget;
  const ExportSummary summary = export_container(input, output, out, options, input);
  if (!out.quiet)
    std::fprintf(stderr, "export: %llu points%s -> %s\n", static_cast<unsigned long long>(summary.points),
                 summary.has_results ? " (smoothed)" : "", output.c_str());
  return 0;
}

}  // namespace pointfair::cli
