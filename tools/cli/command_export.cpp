// pointfair export IN.h5 OUT: a container (with or without a finished run) to a point file.
#include <cstdio>
#include <iostream>

#include "commands.hpp"
#include "out_of_core.hpp"
#include "run_support.hpp"
#include "pointfair/tiles/container.hpp"

namespace pointfair::cli {

int run_export(const Args& args) {
  std::string input, output;
  OutputOptions out;
  bool tile_order = false, input_positions = false;
  ArgumentParser parser("pointfair export",
                        "Writes the points of an HDF5 scan container to a point file, in the input's "
                        "point order. For a container holding a finished smoothing run, the smoothed "
                        "positions and (with --attributes or --colour-by) the run's per-point results.");
  parser.positional("IN", "Input container (.h5).", &input);
  parser.positional("OUT", "Output point file (.ply, .las, .xyz, .txt, .pts, .csv).", &output);
  parser.flag("tile-order", "Write points in the container's tile order instead of the input's order.",
              [&] { tile_order = true; });
  parser.flag("input-positions", "Write the input positions even when the container holds a run.",
              [&] { input_positions = true; });
  add_output_options(parser, out, true);
  if (!parser.parse(args)) return 0;
  if (!is_container_path(input)) throw UsageError("pointfair export: IN must be a .h5 file, got '" + input + "'");
  tiles::ReadContainerOptions options;
  options.original_order = !tile_order;
  options.result_positions = !input_positions;
  io::PointTable table = tiles::read_container(input, options);
  bool has_results = false;
  {
    const auto f = tiles::h5::File::open(input, false);
    has_results = !input_positions && tiles::has_finished_run(f) && f.exists("/run/attributes/k1");
  }
  if (has_results && (out.attributes || out.colour_by != ColourBy::None))
    add_result_columns(table, tiles::read_run_attributes(input, !tile_order), out, out.attributes);
  write_output(output, table, out, input);
  if (!out.quiet)
    std::fprintf(stderr, "export: %zu points%s -> %s\n", table.size(),
                 has_results ? " (smoothed)" : "", output.c_str());
  return 0;
}

}  // namespace pointfair::cli
