#include "curvature_folder.hpp"

#include <chrono>
#include <cstdio>
#include <iostream>
#include <vector>

#include "interrupt.hpp"
#include "point_folder_run.hpp"
#include "run_support.hpp"
#include "pointfair/common/colour.hpp"
#include "pointfair/common/parallel.hpp"
#include "pointfair/common/version.hpp"
#include "pointfair/flow/euler_step.hpp"
#include "pointfair/io/attribute_roles.hpp"

namespace pointfair::cli {

int run_curvature_folder(const std::filesystem::path& in_dir, const std::filesystem::path& out_dir,
                         const SmoothParams& params, const OutputOptions& output) {
  const FolderRun files = plan_folder_run(in_dir, out_dir);
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<io::PointTable> parts;
  const io::PointTable cloud = read_folder(files, output.quiet, parts);
  throw_if_interrupted();
  const NeighborParams neighbor_params = resolve_k(params, cloud.positions).neighbors;
  const Neighborhoods neighborhoods = build_neighborhoods(cloud.positions, neighbor_params);
  throw_if_interrupted();
  const double lambda = resolve_lambda(cloud.positions, neighborhoods, params.flow);
  const PointAttributes attributes = compute_attributes(cloud.positions, neighborhoods, params.flow, lambda);
  // One colour range over every file; a file with colours of its own keeps them unless
  // --colour-by asks, as a single file does.
  const ColourBy by = output.colour_by_given ? output.colour_by : ColourBy::MaxCurvature;
  std::vector<Rgb> colours;
  if (by != ColourBy::None) colours = colour_by_scalar(colour_scalar(attributes, by), output.colour_clip);
  const io::ScalarType type = curvature_type(attributes);
  OutputOptions columns = output;
  columns.colour_by = ColourBy::None;
  std::size_t first = 0;
  for (std::size_t f = 0; f < parts.size(); ++f) {
    io::PointTable& part = parts[f];
    const std::size_t n = part.size();
    const bool colour = !colours.empty() && (output.colour_by_given || !io::has_colour(part));
    columns.attribute_prefix = attribute_prefix_for(files.outputs[f]);
    add_result_columns(part, slice_attributes(attributes, first, n), columns, true, type);
    if (colour) set_colours(part, std::span<const Rgb>(colours).subspan(first, n));
    throw_if_interrupted();
    write_output(files.outputs[f], part, output, files.inputs[f]);
    first += n;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  print_curvature_summary({.input = in_dir.string(), .output = out_dir.string(), .files = parts.size(),
                           .points = cloud.size(), .k = neighbor_params.k, .eps = neighborhoods.eps,
                           .lambda = lambda, .seconds = seconds},
                          attributes, params, output);
  return 0;
}

void print_curvature_summary(const CurvatureSummary& s, const PointAttributes& attributes, const SmoothParams& params,
                             const OutputOptions& output) {
  std::size_t classes[3] = {0, 0, 0};
  for (const auto c : attributes.feature) ++classes[static_cast<int>(c)];
  const std::string files = s.files > 0 ? " in " + std::to_string(s.files) + " files" : std::string();
  if (!output.quiet)
    std::fprintf(stderr,
                 "curvature: %zu points%s (k %d, lambda %.4g, eps %.4g): %zu smooth, %zu edge, %zu corner, "
                 "%zu degenerate, %.2f s -> %s\n",
                 s.points, files.c_str(), s.k, s.lambda, s.eps, classes[0], classes[1], classes[2],
                 attributes.degenerate, s.seconds, s.output.c_str());
  if (!output.json) return;
  JsonObject counts;
  counts.add("smooth", classes[0]).add("edge", classes[1]).add("corner", classes[2]);
  JsonObject j;
  j.add("command", "curvature").add("version", version()).add("input", s.input).add("output", s.output);
  if (s.files > 0) j.add("files", s.files);
  j.add("points", s.points).add("threads", thread_count());
  j.add("parameters", parameters_json(params, s.k, s.eps, s.lambda));
  j.add("feature_classes", counts).add("degenerate_points", attributes.degenerate);
  j.add("seconds", s.seconds);
  std::cout << j.str() << std::endl;
}

}  // namespace pointfair::cli
