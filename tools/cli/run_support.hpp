#pragma once
// Pieces every command shares: reading the input, turning results into output columns,
// displacement statistics, writing, timing.
#include <chrono>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "json_writer.hpp"
#include "pointfair/common/colour.hpp"
#include "method_options.hpp"
#include "pointfair/common/parameter.hpp"
#include "pointfair/io/ply.hpp"
#include "pointfair/io/point_file.hpp"
#include "pointfair/io/point_table.hpp"
#include "pointfair/smooth.hpp"

namespace pointfair::cli {

/// Seconds from `t0` to now.
double seconds_since(std::chrono::steady_clock::time_point t0);

/// Reads a point file; warnings go to stderr unless quiet.
io::PointTable read_input(const std::filesystem::path& path, bool quiet);

/// The PLY encoding of --encoding ("binary", "binary-be", "ascii"); empty keeps the source's.
std::optional<io::PlyEncoding> ply_encoding(const std::string& encoding);

/// The writer's options of `output` (--encoding, the LAS options), refusing to overwrite
/// `input` when given.
io::WriteOptions write_options(const OutputOptions& output, const std::filesystem::path& input = {});

/// Writes `table` atomically with the chosen encoding, refusing to overwrite `input`.
void write_output(const std::filesystem::path& path, const io::PointTable& table,
                  const OutputOptions& output, const std::filesystem::path& input = {});

/// OutputOptions::attribute_prefix for an output file: "scalar_" for PLY, else empty.
std::string attribute_prefix_for(const std::filesystem::path& output);

/// Replaces the input's normal columns (io::normal_columns) by the new normals, adds colour
/// (red/green/blue) when output.colour_by asks and, if asked, the per-point attribute columns
/// (named with output.attribute_prefix).
/// The curvature columns (k1, k2, mean_curvature, laplacian_norm) are `curvature_type`.
void add_result_columns(io::PointTable& table, const PointAttributes& attributes,
                        const OutputOptions& output, bool all_attributes,
                        io::ScalarType curvature_type = io::ScalarType::Float32);

/// The scalar `by` colours a point by: max(|k1|, |k2|) (kmax) or |A| (laplacian), per point of
/// `attributes`. `by` is not ColourBy::None.
std::vector<double> colour_scalar(const PointAttributes& attributes, ColourBy by);

/// Sets the columns red, green, blue (uint8) of `table` to `colours`, one per row.
void set_colours(io::PointTable& table, std::span<const Rgb> colours);

/// True when `value` is 0 or within float's normal range: stored as float it stays finite and
/// non-zero.
bool fits_float(double value);

/// Float32 when every curvature value of `attributes` fits_float, else Float64: a cloud at an
/// extreme scale (around 1e40 curvatures fall below float's range, around 1e-40 beyond it)
/// keeps its curvatures instead of writing them as 0 or inf.
io::ScalarType curvature_type(const PointAttributes& attributes);

/// Statistics of |after_i - before_i| (length), also relative to the bounding-box diagonal.
struct DisplacementStats {
  double mean = 0, rms = 0, median = 0, p95 = 0, max = 0;
  double diagonal = 0;
};
DisplacementStats displacement_stats(std::span<const Vec3> before, std::span<const Vec3> after);
JsonObject to_json(const DisplacementStats& stats);

/// The method's parameters as a JSON object (with resolved eps and lambda), by their table
/// (smooth_parameters.hpp) in kSmoothJsonOrder.
/// `k`: the neighbourhood size used (SmoothReport::k); "k_auto" says whether it was chosen.
JsonObject parameters_json(const SmoothParams& params, int k, double eps, double lambda);

/// Adds `value` to `j` under `name`: a number, true or false, or a choice's command-line name.
JsonObject& add_parameter(JsonObject& j, std::string_view name, const ParameterValue& value);

/// The finish's parameters (SmoothParams::finish) as a JSON object; "enabled" says whether it
/// runs; the others follow its table (finish/quadric_parameters.hpp) in kQuadricJsonOrder, then
/// "passes_run": the passes the run took (passes_run).
JsonObject finish_json(const SmoothParams& params, int passes_run);

/// The coarse level's parameters (SmoothParams::coarse) and the levels that ran.
/// "every second point", "every 3rd point", ...: the coarse sample of CoarseLevelParams::ratio.
std::string coarse_sample_text(int ratio);

/// " after a coarse level on N points (S steps)" for each coarse level that ran, coarsest
/// last; empty when none ran. For the runs' one-line summaries.
std::string coarse_level_text(const std::vector<CoarseLevelReport>& levels);

JsonObject coarse_level_json(const CoarseLevelParams& coarse, const std::vector<CoarseLevelReport>& levels);

}  // namespace pointfair::cli
