// pointfair curvature IN OUT: frames, principal curvatures and feature classes, no motion.
#include <chrono>
#include <cstdio>
#include <iostream>

#include "commands.hpp"
#include "curvature_folder.hpp"
#include "point_folder_run.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "interrupt.hpp"
#include "las_options.hpp"
#include "run_support.hpp"
#include "pointfair/common/parallel.hpp"
#include "pointfair/common/version.hpp"
#include "pointfair/io/attribute_roles.hpp"

namespace pointfair::cli {

int run_curvature(const Args& args) {
  std::string input, output_path;
  SmoothParams params;
  OutputOptions output;
  ArgumentParser parser("pointfair curvature",
                        "Estimates per point the normal, principal curvatures k1 >= k2 and "
                        "directions d1, d2, mean curvature H, the length of the (anisotropic) mean "
                        "curvature vector |A| and the feature class (0 smooth, 1 edge, 2 corner), "
                        "without moving any point. Normals point away from the bounding-box "
                        "centre; curvatures are positive where the surface is convex (a sphere: +1/R).");
  parser.positional("IN",
                    "Input point file (.ply, .las, .laz, .xyz, .txt, .pts, .csv), or a folder whose .las "
                    ".laz .ply .xyz files are taken as one cloud, each written into the folder OUT "
                    "(docs/tiles-folder.md).",
                    &input);
  parser.positional("OUT",
                    "Output point file with the attributes as named properties/columns, after the "
                    "input's own (whose normals are replaced); coloured by kmax unless the input "
                    "has colours of its own or --colour-by says otherwise.",
                    &output_path);
  add_method_options(parser, params);
  add_output_options(parser, output, false);
  add_las_options(parser, output.las);
  parser.example("pointfair curvature scan.ply curvature.ply --colour-by kmax");
  parser.example("pointfair curvature scan.las features.las --features maxcurv --json");
  if (!parser.parse(args)) return 0;
  require_las_output(output.las, output_path);
  params.validate();
  set_thread_count(output.threads);
  // A folder IN: its files as one cloud, each written into the folder OUT.
  if (is_folder_input(input)) {
    return run_curvature_folder(without_trailing_separator(input), without_trailing_separator(output_path), params,
                                output);
  }
  // A named pipe or a device at OUT is refused before any work, not after it.
  io::require_output_path(output_path);
  output.attribute_prefix = attribute_prefix_for(output_path);

  const auto t0 = std::chrono::steady_clock::now();
  io::PointTable table = read_input(input, output.quiet);
  // Colouring by curvature is this command's purpose, but a cloud's own colours stay unless
  // --colour-by asks to replace them.
  if (!output.colour_by_given && !io::has_colour(table)) output.colour_by = ColourBy::MaxCurvature;
  throw_if_interrupted();
  const NeighborParams neighbor_params = resolve_k(params, table.positions).neighbors;
  const Neighborhoods neighborhoods = build_neighborhoods(table.positions, neighbor_params);
  throw_if_interrupted();
  const double lambda = resolve_lambda(table.positions, neighborhoods, params.flow);
  const PointAttributes attributes =
      compute_attributes(table.positions, neighborhoods, params.flow, lambda);
  add_result_columns(table, attributes, output, true, curvature_type(attributes));
  throw_if_interrupted();
  write_output(output_path, table, output, input);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  print_curvature_summary({.input = input, .output = output_path, .files = 0, .points = table.size(),
                           .k = neighbor_params.k, .eps = neighborhoods.eps, .lambda = lambda, .seconds = seconds},
                          attributes, params, output);
  return 0;
}

}  // namespace pointfair::cli
