#include "run_support.hpp"

#include <cctype>
#include <cstdio>

#include <algorithm>
#include <cmath>
#include <limits>
#include <iostream>

#include "pointfair/common/colour.hpp"
#include "pointfair/io/attribute_roles.hpp"
#include "pointfair/io/point_file.hpp"
#include "pointfair/shapes/shapes.hpp"

namespace pointfair::cli {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

io::PointTable read_input(const std::filesystem::path& path, bool quiet) {
  io::ReadOptions options;
  options.on_warning = [quiet](const std::string& message) {
    if (!quiet) std::cerr << "warning: " << message << "\n";
  };
  return io::read_points(path, options);
}

std::optional<io::PlyEncoding> ply_encoding(const std::string& encoding) {
  if (encoding == "ascii") return io::PlyEncoding::Ascii;
  if (encoding == "binary-be") return io::PlyEncoding::BinaryBigEndian;
  if (encoding == "binary") return io::PlyEncoding::BinaryLittleEndian;
  return std::nullopt;
}

void write_output(const std::filesystem::path& path, const io::PointTable& table,
                  const OutputOptions& output, const std::filesystem::path& input) {
  io::WriteOptions options;
  options.input = input;
  options.ply_encoding = ply_encoding(output.encoding);
  options.las = output.las;
  io::write_points(path, table, options);
}

bool fits_float(double value) {
  const double magnitude = std::abs(value);
  return magnitude == 0.0 || (magnitude >= std::numeric_limits<float>::min() &&
                              magnitude <= std::numeric_limits<float>::max());
}

io::ScalarType curvature_type(const PointAttributes& a) {
  for (const std::vector<double>* column : {&a.k1, &a.k2, &a.mean_curvature, &a.laplacian_norm})
    for (const double v : *column)
      if (!fits_float(v)) return io::ScalarType::Float64;
  return io::ScalarType::Float32;
}

std::string attribute_prefix_for(const std::filesystem::path& output) {
  return io::point_format_of(output) == io::PointFormat::Ply ? "scalar_" : "";
}

void add_result_columns(io::PointTable& table, const PointAttributes& a,
                        const OutputOptions& output, bool all_attributes, io::ScalarType curvature_type) {
  const std::size_t n = table.size();
  auto column = [n](auto&& get) {
    std::vector<double> v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = get(i);
    return v;
  };
  using io::ScalarType;
  // The input's normals no longer match the moved points: the new ones replace them.
  if (a.normal.size() == n) io::refresh_normals(table, a.normal);
  if (all_attributes) {
    // Normals just refreshed keep their columns, types and orientation. Columns called nx
    // that are not normals (a headerless file's guess, integers) are left alone: the
    // normals then go to normal_x normal_y normal_z.
    const bool refreshed = !io::normal_columns(table).empty();
    const std::string prefix = !table.find("nx") ? "n" : !table.find("normal_x") ? "normal_" : "";
    for (int c = 0; c < 3 && !refreshed && !prefix.empty(); ++c) {
      const char* axis = c == 0 ? "x" : c == 1 ? "y" : "z";
      table.set(prefix + axis, ScalarType::Float32, column([&](std::size_t i) { return a.normal[i][c]; }));
    }
    const std::string& named = output.attribute_prefix;
    table.set(named + "k1", curvature_type, a.k1);
    table.set(named + "k2", curvature_type, a.k2);
    for (int c = 0; c < 3; ++c) {
      const char* axis = c == 0 ? "x" : c == 1 ? "y" : "z";
      table.set(named + "d1" + axis, ScalarType::Float32, column([&](std::size_t i) { return a.d1[i][c]; }));
    }
    for (int c = 0; c < 3; ++c) {
      const char* axis = c == 0 ? "x" : c == 1 ? "y" : "z";
      table.set(named + "d2" + axis, ScalarType::Float32, column([&](std::size_t i) { return a.d2[i][c]; }));
    }
    table.set(named + "mean_curvature", curvature_type, a.mean_curvature);
    table.set(named + "laplacian_norm", curvature_type, a.laplacian_norm);
    table.set(named + "feature_class", ScalarType::UInt8,
              column([&](std::size_t i) { return static_cast<double>(a.feature[i]); }));
  }
  if (output.colour_by != ColourBy::None)
    set_colours(table, colour_by_scalar(colour_scalar(a, output.colour_by), output.colour_clip));
}

std::vector<double> colour_scalar(const PointAttributes& a, ColourBy by) {
  if (by == ColourBy::Laplacian) return a.laplacian_norm;
  std::vector<double> v(a.k1.size());
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = std::max(std::abs(a.k1[i]), std::abs(a.k2[i]));
  return v;
}

void set_colours(io::PointTable& table, std::span<const Rgb> colours) {
  const char* names[3] = {"red", "green", "blue"};
  for (std::size_t c = 0; c < 3; ++c) {
    std::vector<double> v(table.size());
    for (std::size_t i = 0; i < v.size(); ++i) v[i] = static_cast<double>(colours[i][c]);
    table.set(names[c], io::ScalarType::UInt8, std::move(v));
  }
}

DisplacementStats displacement_stats(std::span<const Vec3> before, std::span<const Vec3> after) {
  DisplacementStats s;
  const std::size_t n = std::min(before.size(), after.size());
  s.diagonal = bounding_box_diagonal(before);
  if (n == 0) return s;
  std::vector<double> d(n);
  double sum = 0, sum2 = 0;
  for (std::size_t i = 0; i < n; ++i) {
    d[i] = (after[i] - before[i]).norm();
    sum += d[i];
    sum2 += d[i] * d[i];
  }
  s.mean = sum / static_cast<double>(n);
  s.rms = std::sqrt(sum2 / static_cast<double>(n));
  std::sort(d.begin(), d.end());
  s.median = d[n / 2];
  s.p95 = d[std::min(n - 1, static_cast<std::size_t>(0.95 * static_cast<double>(n)))];
  s.max = d.back();
  return s;
}

JsonObject to_json(const DisplacementStats& s) {
  JsonObject j;
  j.add("mean", s.mean).add("rms", s.rms).add("median", s.median).add("p95", s.p95).add("max", s.max);
  j.add("bbox_diagonal", s.diagonal);
  j.add("max_over_diagonal", s.diagonal > 0 ? s.max / s.diagonal : 0.0);
  return j;
}

JsonObject parameters_json(const SmoothParams& p, int k, double eps, double lambda) {
  JsonObject j;
  j.add("k", k).add("k_auto", p.neighbors.k == 0).add("eps", eps).add("steps", p.steps).add("tau", p.flow.tau);
  j.add("flow", to_string(p.flow.flow)).add("cutoff", to_string(p.flow.cutoff));
  j.add("lambda", lambda).add("lambda_auto", p.flow.lambda == 0.0);
  j.add("lambda_factor", p.flow.lambda_auto_factor).add("lambda_every_step", p.lambda_every_step);
  j.add("constrain_normal", p.flow.constrain_normal).add("rebuild_every", p.rebuild_interval);
  j.add("features", to_string(p.flow.features.mode)).add("edge_quotient", p.flow.features.quotient);
  if (p.flow.features.threshold > 0) j.add("feature_threshold", p.flow.features.threshold);
  else if (p.flow.features.scale == FeatureScale::Lambda) j.add("feature_threshold", lambda);
  else j.add("feature_threshold", "auto").add("feature_turn", p.flow.features.turn);
  j.add("feature_gated", p.flow.feature_gated);
  j.add("weights", to_string(p.flow.weingarten.weights)).add("density_floor", p.flow.weingarten.density_floor);
  j.add("cutoff_origin", p.flow.cutoff_origin == CutoffOrigin::Plane ? "plane" : "point");
  j.add("stop_lambda_ratio", p.stop_lambda_ratio).add("stop_plateau", p.stop_plateau);
  j.add("shrink_compensation", p.shrink_compensation);
  j.add("normal", to_string(p.flow.normal_estimator));
  if (p.flow.normal_estimator == NormalEstimator::Robust)
    j.add("robust_seed", p.flow.robust.seed_neighbors)
        .add("robust_iterations", p.flow.robust.iterations)
        .add("robust_bound", p.flow.robust.inlier_bound);
  return j;
}

JsonObject finish_json(const SmoothParams& p) {
  const QuadricProjectionParams q = p.finish.value_or(QuadricProjectionParams{});
  JsonObject j;
  j.add("enabled", p.finish.has_value()).add("k", q.k).add("angle_degrees", q.normal_angle)
      .add("degree", q.degree).add("passes", q.passes).add("iterations", q.iterations)
      .add("curvature_reach", q.curvature_reach).add("min_k", q.min_k);
  return j;
}

JsonObject coarse_level_json(const CoarseLevelParams& coarse, const std::vector<CoarseLevelReport>& levels) {
  JsonObject j;
  j.add("ratio", coarse.ratio).add("fine_steps", coarse.fine_steps).add("interpolation_k", coarse.interpolation_k)
      .add("levels_at_most", coarse.levels).add("min_noise_ratio", coarse.min_noise_ratio);
  std::vector<JsonObject> ran;
  for (const CoarseLevelReport& level : levels) {
    ran.emplace_back();
    ran.back().add("points", level.points).add("steps", level.steps);
  }
  j.add("levels", ran);
  return j;
}

}  // namespace pointfair::cli
