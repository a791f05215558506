#include "run_support.hpp"

#include <cctype>
#include <cstdio>

#include <algorithm>
#include <cmath>
#include <limits>
#include <iostream>

#include "pointfair/common/colour.hpp"
#include "pointfair/finish/quadric_parameters.hpp"
#include "pointfair/smooth_parameters.hpp"
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

io::WriteOptions write_options(const OutputOptions& output, const std::filesystem::path& input) {
  io::WriteOptions options;
  options.input = input;
  options.ply_encoding = ply_encoding(output.encoding);
  options.las = output.las;
  return options;
}

void write_output(const std::filesystem::path& path, const io::PointTable& table,
                  const OutputOptions& output, const std::filesystem::path& input) {
  io::write_points(path, table, write_options(output, input));
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

JsonObject& add_parameter(JsonObject& j, std::string_view name, const ParameterValue& v) {
  switch (v.kind) {
    case ParameterValue::Kind::Integer: return j.add(name, static_cast<long long>(v.integer));
    case ParameterValue::Kind::Real: return j.add(name, v.real);
    case ParameterValue::Kind::Flag: return j.add(name, v.integer != 0);
    case ParameterValue::Kind::Choice: return j.add(name, v.name);
  }
  return j;
}

JsonObject parameters_json(const SmoothParams& p, int k, double eps, double lambda) {
  const bool fixed_threshold = p.flow.features.threshold > 0;
  const bool lambda_threshold = !fixed_threshold && p.flow.features.scale == FeatureScale::Lambda;
  JsonObject j;
  for (const std::string_view name : kSmoothJsonOrder) {
    // What the run used rather than what was asked for, and the feature threshold's rule.
    if (name == "k") j.add(name, k);
    else if (name == "k_auto") j.add(name, p.neighbors.k == 0);
    else if (name == "eps") j.add(name, eps);
    else if (name == "lambda") j.add(name, lambda);
    else if (name == "lambda_auto") j.add(name, p.flow.lambda == 0.0);
    else if (name == "feature_threshold") {
      if (fixed_threshold) j.add(name, p.flow.features.threshold);
      else if (lambda_threshold) j.add(name, lambda);
      else j.add(name, "auto");
    } else if (name == "feature_turn") {
      if (!fixed_threshold && !lambda_threshold) j.add(name, p.flow.features.turn);
    } else if (name.starts_with("robust_") && p.flow.normal_estimator != NormalEstimator::Robust) {
      // The robust frame's parameters only with it.
    } else {
      const SmoothParameter* parameter = find_parameter<SmoothParams>(kSmoothParameters, &SmoothParameter::json, name);
      add_parameter(j, name, parameter->value(p));
    }
  }
  return j;
}

JsonObject finish_json(const SmoothParams& p, int passes_run) {
  const QuadricProjectionParams q = p.finish.value_or(QuadricProjectionParams{});
  JsonObject j;
  j.add("enabled", p.finish.has_value());
  for (const std::string_view name : kQuadricJsonOrder) {
    const QuadricParameter* parameter = find_parameter<QuadricProjectionParams>(kQuadricParameters,
                                                                                &QuadricParameter::json, name);
    add_parameter(j, name, parameter->value(q));
  }
  // The passes the run took (CoarseLevelParams::finish_passes after a coarse level).
  if (p.finish) j.add("passes_run", passes_run);
  return j;
}

std::string coarse_sample_text(int ratio) {
  if (ratio == 2) return "every second point";
  const int last = ratio % 10;
  const char* suffix = ratio % 100 / 10 == 1 ? "th" : last == 1 ? "st" : last == 2 ? "nd" : last == 3 ? "rd" : "th";
  return "every " + std::to_string(ratio) + suffix + " point";
}

std::string coarse_level_text(const std::vector<CoarseLevelReport>& levels) {
  std::string text;
  for (const CoarseLevelReport& level : levels)
    text += std::string(text.empty() ? " after a coarse level on " : ", itself after one on ") +
            std::to_string(level.points) + " points (" + std::to_string(level.steps) + " steps)";
  return text;
}

JsonObject coarse_level_json(const CoarseLevelParams& coarse, const std::vector<CoarseLevelReport>& levels) {
  JsonObject j;
  j.add("ratio", coarse.ratio).add("cell_spacings", coarse.cell_spacings).add("fine_steps", coarse.fine_steps).add("interpolation_k", coarse.interpolation_k)
      .add("levels_at_most", coarse.levels).add("min_noise_ratio", coarse.min_noise_ratio)
      .add("finish_passes", coarse.finish_passes);
  std::vector<JsonObject> ran;
  for (const CoarseLevelReport& level : levels) {
    ran.emplace_back();
    ran.back().add("points", level.points).add("steps", level.steps);
  }
  j.add("levels", ran);
  return j;
}

}  // namespace pointfair::cli
