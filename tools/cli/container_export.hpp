#pragma once
// A container's points written to a point file a chunk at a time (pointfair export, and
// smooth with a point-file output out of core): memory stays within a budget whatever the
// cloud's size.
#include <cstdint>
#include <filesystem>

#include "method_options.hpp"

namespace pointfair::cli {

struct ContainerExport {
  /// The input's point order (true) or the container's tile order.
  bool original_order = true;
  /// Write the input positions even when the container holds a finished run.
  bool input_positions = false;
  /// Bytes of points held at a time (the chunk, its result columns and the reader's scratch).
  std::uint64_t memory_budget = std::uint64_t{256} << 20;
};

struct ExportSummary {
  std::uint64_t points = 0;
  /// The container held a finished run with per-point results.
  bool has_results = false;
};

/// Writes `container` to `output` (format by extension, atomically), with colour and
/// attribute columns from a finished run as `output` asks (the colour range is the exact
/// clip quantile of the whole cloud, found in a few passes over the run's results). Refuses
/// to overwrite `input` when given.
ExportSummary export_container(const std::filesystem::path& container, const std::filesystem::path& output,
                               const OutputOptions& out, const ContainerExport& options,
                               const std::filesystem::path& input = {});

}  // namespace pointfair::cli
