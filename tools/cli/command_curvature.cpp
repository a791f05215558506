// pointfair curvature IN OUT: frames, principal curvatures and feature classes, no motion.
#include <chrono>
#include <cstdio>
#include <iostream>

#include "commands.hpp"
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
  parser.positional("IN", "Input point file (.ply, .las, .laz, .xyz, .txt, .pts, .csv).", &input);
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

  std::size_t classes[3] = {0, 0, 0};
  for (const auto c : attributes.feature) ++classes[static_cast<int>(c)];
  if (!output.quiet)
    std::fprintf(stderr,
                 "curvature: %zu points (k %d, lambda %.4g, eps %.4g): %zu smooth, %zu edge, %zu corner, "
                 "%zu degenerate, %.2f s -> %s\n",
                 table.size(), neighbor_params.k, lambda, neighborhoods.eps, classes[0], classes[1], classes[2],
                 attributes.degenerate, seconds, output_path.c_str());
  if (output.json) {
    JsonObject counts;
    counts.add("smooth", classes[0]).add("edge", classes[1]).add("corner", classes[2]);
    JsonObject j;
    j.add("command", "curvature").add("version", version()).add("input", input).add("output", output_path);
    j.add("points", table.size()).add("threads", thread_count());
    j.add("parameters", parameters_json(params, neighbor_params.k, neighborhoods.eps, lambda));
    j.add("feature_classes", counts).add("degenerate_points", attributes.degenerate);
    j.add("seconds", seconds);
    std::cout << j.str() << std::endl;
  }
  return 0;
}

}  // namespace pointfair::cli
