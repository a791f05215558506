#pragma once
// A container's points written to a point file (pointfair export, and smooth with a point-file
// output out of core) with the result columns the output options ask for: the streaming is the
// library's (pointfair/tiles/export.hpp); the columns, and the colour range over the whole
// cloud, are the command's.
#include <cstdint>
#include <filesystem>

#include "method_options.hpp"
#include "pointfair/tiles/export.hpp"

namespace pointfair::cli {

struct ExportSummary {
  std::uint64_t points = 0;
  /// The container held a finished run with per-point results.
  bool has_results = false;
};

/// Whether the points of `container` have normal columns (io::normal_columns of its schema):
/// a run's normals replace them on export.
bool container_has_normal_columns(const std::filesystem::path& container);

/// Writes `container` to `output` (tiles::export_points with options.original_order,
/// input_positions and memory_budget), with colour and attribute columns from a finished run
/// as `out` asks (the colour range is the exact clip quantile of the whole cloud, found in a
/// few passes over the run's results). Refuses to overwrite `input` when given.
ExportSummary export_container(const std::filesystem::path& container, const std::filesystem::path& output,
                               const OutputOptions& out, const tiles::StreamExportOptions& options,
                               const std::filesystem::path& input = {});

}  // namespace pointfair::cli
