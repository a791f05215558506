// pointfair eval CLOUD --truth T: quality of a cloud against ground truth (see
// pointfair/eval/metrics.hpp for every measure's definition).
#include <filesystem>
#include <cstdio>
#include <iostream>
#include <optional>

#include "commands.hpp"
#include "run_support.hpp"
#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/common/version.hpp"
#include "pointfair/eval/metrics.hpp"
#include "pointfair/eval/truth.hpp"
#include "pointfair/io/point_table.hpp"
#include "pointfair/shapes/shapes.hpp"

namespace pointfair::cli {

namespace {

JsonObject angle_json(const eval::AngleStats& a) {
  JsonObject j;
  j.add("points", a.count).add("mean_degrees", a.mean_degrees).add("rms_degrees", a.rms_degrees);
  return j;
}

void add_optional(JsonObject& j, std::string_view key, const std::optional<double>& v) {
  if (v) j.add(key, *v);
  else j.add(key, std::numeric_limits<double>::quiet_NaN());  // written as null
}

std::string optional_text(const std::optional<double>& v, double factor, const char* format) {
  if (!v) return "-";
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, *v * factor);
  return buffer;
}

}  // namespace

JsonObject eval_report_json(const eval::EvalReport& r) {
  JsonObject distance;
  distance.add("rms", r.rms_distance).add("max", r.max_distance).add("rms_near_edges", r.rms_near_edges)
      .add("rms_elsewhere", r.rms_elsewhere).add("mean_signed", r.mean_signed_distance);
  JsonObject normals;
  normals.add("all", angle_json(r.normal_all)).add("near_edges", angle_json(r.normal_edges))
      .add("elsewhere", angle_json(r.normal_elsewhere));
  JsonObject features;
  add_optional(features, "precision", r.feature_precision);
  add_optional(features, "recall", r.feature_recall);
  features.add("predicted", r.feature_predicted).add("true", r.feature_true);
  JsonObject j;
  j.add("points", r.points).add("truth_bbox_diagonal", r.diagonal);
  j.add("distance_over_diagonal", distance);
  j.add("chamfer_unit_sphere_1e4", r.chamfer_1e4).add("p2m_unit_sphere_1e4", r.p2m_1e4);
  j.add("normal_error", normals);
  add_optional(j, "curvature_rms", r.curvature_rms);
  j.add("curvature_points", r.curvature_points);
  j.add("features", features);
  j.add("bbox_diagonal_change", r.bbox_diagonal_change);
  add_optional(j, "max_displacement_over_diagonal", r.max_displacement);
  add_optional(j, "rms_displacement_over_diagonal", r.rms_displacement);
  return j;
}

int run_eval(const Args& args) {
  std::string cloud_path, truth_arg, clean_path, input_path;
  eval::EvalParams params;
  eval::TruthParams truth_params;
  OutputOptions output;
  ArgumentParser parser(
      "pointfair eval",
      "Measures a cloud against ground truth: distances to the true surface (RMS, max, near sharp "
      "creases and elsewhere, / bounding-box diagonal of the truth), Chamfer distance CD and "
      "point-to-surface distance P2M in the unit-sphere convention of recent denoising papers "
      "(x1e-4; CD = mean squared nearest distance both ways to the reference cloud, P2M = mean "
      "squared distance to the true surface, one-directional), angle of the PCA normal (k nearest) "
      "to the true normal, principal-curvature error where the truth is analytic, feature-class "
      "precision/recall against the true creases, shrinkage and displacement.");
  parser.positional("CLOUD", "Point file to measure.", &cloud_path);
  parser.value("truth", "T",
               "Ground truth: a truth file from 'pointfair generate --truth-out', a triangle mesh "
               "(.off, .ply), or a shape name with default sizes (cube, octahedron, sphere, ...).",
               [&](std::string_view v) { truth_arg = std::string(v); });
  parser.value("clean", "FILE", "Reference cloud of the Chamfer distance (default: samples of the truth).",
               [&](std::string_view v) { clean_path = std::string(v); });
  parser.value("input", "FILE", "The cloud before processing (same order), for displacements.",
               [&](std::string_view v) { input_path = std::string(v); });
  parser.group(OptionGroup::Method);
  parser.value("normal-k", "N", "Neighbours of the measured PCA normal. Default 16.",
               [&](std::string_view v) { params.normal_k = parse_int(v, "--normal-k"); });
  parser.value("edge-band", "FRACTION", "Near-crease band, fraction of the diagonal. Default 0.01.",
               [&](std::string_view v) { params.edge_band = parse_double(v, "--edge-band"); });
  parser.value("sharp-angle", "DEGREES", "Mesh edges whose face normals differ by more are creases. Default 30.",
               [&](std::string_view v) { truth_params.sharp_angle_degrees = parse_double(v, "--sharp-angle"); });
  parser.flag("no-curvature", "Skip curvature and feature scores.", [&] { params.with_curvature = false; });
  add_method_options(parser, params.method);
  parser.group(OptionGroup::Common);
  parser.flag("json", "Print the result as JSON on stdout instead of the table.", [&] { output.json = true; });
  parser.value("threads", "N", "Worker threads (0 = all cores). Default 0.",
               [&](std::string_view v) { output.threads = parse_int(v, "--threads"); });
  parser.example("pointfair eval smoothed.ply --truth cube.truth --input noisy.ply");
  parser.example("pointfair eval smoothed.ply --truth sphere --json");
  if (!parser.parse(args)) return 0;
  if (truth_arg.empty()) throw UsageError("pointfair eval: --truth is required");
  params.validate();
  set_thread_count(output.threads);

  const eval::TruthSpec spec = eval::truth_from_argument(truth_arg);
  // Every error names its file: the truth's (a mesh or truth file), the cloud's, the others'.
  const bool truth_file = spec.shape == "mesh" || std::filesystem::path(truth_arg).extension() == ".truth";
  std::optional<eval::GroundTruth> truth_holder;
  try {
    truth_holder.emplace(spec, truth_params);
  } catch (const ParamError& e) {
    if (!truth_file) throw;
    throw io::IoError(truth_arg + ": " + e.what());
  }
  const eval::GroundTruth& truth = *truth_holder;
  if (truth_file && !(truth.bounds().diagonal().norm() > 0)) throw io::IoError(truth_arg + ": the truth has an empty bounding box");
  const io::PointTable cloud = read_input(cloud_path, true);
  if (cloud.positions.empty()) throw io::IoError(cloud_path + ": no points to evaluate");
  io::PointTable clean, input;
  if (!clean_path.empty()) clean = read_input(clean_path, true);
  if (!input_path.empty()) input = read_input(input_path, true);
  if (!input_path.empty() && input.size() != cloud.size())
    throw io::IoError(input_path + ": has " + std::to_string(input.size()) + " points, " + cloud_path + " has " +
                      std::to_string(cloud.size()) + " (--input is the same cloud before processing)");
  if (!clean_path.empty() && !(bounding_box_diagonal(clean.positions) > 0))
    throw io::IoError(clean_path + ": the reference cloud has no extent");
  // Coordinates whose squared distances overflow: refused, naming the file.
  const auto require_magnitude = [](const io::PointTable& table, const std::string& file) {
    for (std::size_t i = 0; i < table.size(); ++i)
      if (!(table.positions[i].cwiseAbs().maxCoeff() <= eval::kEvalMaxCoordinate))
        throw io::IoError(file + ": point " + std::to_string(i) +
                          " has a coordinate beyond 1e100 in magnitude, where eval's squared distances overflow: "
                          "rescale the cloud");
  };
  require_magnitude(cloud, cloud_path);
  if (!clean_path.empty()) require_magnitude(clean, clean_path);
  if (!input_path.empty()) require_magnitude(input, input_path);
  const eval::EvalReport r = eval::evaluate(truth, {cloud.positions, clean.positions, input.positions}, params);

  if (output.json) {
    JsonObject j;
    j.add("command", "eval").add("version", version()).add("cloud", cloud_path).add("truth", spec.shape);
    j.add("edge_band_over_diagonal", params.edge_band).add("normal_k", params.normal_k);
    j.add("result", eval_report_json(r));
    std::cout << j.str() << std::endl;
    return 0;
  }
  std::printf("pointfair eval: %s vs %s (%zu points, truth diagonal %.4g)\n", cloud_path.c_str(), spec.shape.c_str(),
              r.points, r.diagonal);
  std::printf("  distance to the truth (1e-3 of diagonal)  RMS %.3f  max %.3f  near creases %.3f  elsewhere %.3f\n",
              1e3 * r.rms_distance, 1e3 * r.max_distance, 1e3 * r.rms_near_edges, 1e3 * r.rms_elsewhere);
  std::printf("  unit sphere (x1e-4)                       CD %.3f  P2M %.3f\n", r.chamfer_1e4, r.p2m_1e4);
  std::printf("  normal error, mean (deg), k=%d            all %.2f  near creases %.2f (%zu pts)  elsewhere %.2f\n",
              params.normal_k, r.normal_all.mean_degrees, r.normal_edges.mean_degrees, r.normal_edges.count,
              r.normal_elsewhere.mean_degrees);
  std::printf("  curvature RMS error (1/length)            %s (%zu pts)\n",
              optional_text(r.curvature_rms, 1.0, "%.4f").c_str(), r.curvature_points);
  std::printf("  features vs true creases                  precision %s  recall %s\n",
              optional_text(r.feature_precision, 1.0, "%.3f").c_str(), optional_text(r.feature_recall, 1.0, "%.3f").c_str());
  std::printf("  shrinkage                                 mean signed %.3f e-3  bbox diagonal change %+.3f%%\n",
              1e3 * r.mean_signed_distance, 100 * r.bbox_diagonal_change);
  std::printf("  displacement from input (1e-3 of diag.)   max %s  RMS %s\n",
              optional_text(r.max_displacement, 1e3, "%.3f").c_str(), optional_text(r.rms_displacement, 1e3, "%.3f").c_str());
  return 0;
}

}  // namespace pointfair::cli
