#pragma once
// A container's points written to a point file a chunk at a time (pointfair export, and
// smooth with a point-file output out of core): memory stays within a budget whatever the
// cloud's size.
#include <cstdint>
#include <filesystem>
#include <vector>

#include "method_options.hpp"
#include "pointfair/io/point_selection.hpp"

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

struct SelectedExportSummary {
  std::uint64_t points = 0;
  /// Records the selection kept (the container's rows), and of them those whose position changed.
  std::uint64_t selected = 0, moved = 0;
};

/// Writes `source` to `output` (format by extension, atomically) record by record, in its
/// order, with the smoothed positions of the records `selection` keeps: the k-th of them takes
/// the position of the k-th point (original order) of the finished run in `container`, which
/// was imported from exactly those records (tiles::StreamImportOptions::select); normals the
/// source has are refreshed for them as export_container does. Every other record is written
/// as read. An empty `container` (a selection of no point) writes the source as it was.
/// Memory stays within `memory_budget` but for a LAS output from a source without a
/// quantization, whose chunks the LAS writer holds until its end. Throws IoError naming the
/// file when the source and the container disagree (the source changed during the run).
SelectedExportSummary export_selected(const std::filesystem::path& container, const std::filesystem::path& source,
                                      const io::PointSelection& selection, const std::filesystem::path& output,
                                      const OutputOptions& out, std::uint64_t memory_budget);

/// Writes sources[i] to outputs[i] (format by extension, atomically), record by record, with
/// the smoothed positions of the finished run in `container`, which was imported from the
/// sources' points concatenated in this order (a folder run): the points of sources[0] take the
/// container's first points (original order), and so on. Normals a source has are refreshed as
/// export_container does (the container then needs a finished run with attributes); every
/// other field is written as read, in the source's layout. Each
/// output appears when complete. Memory stays within `memory_budget`. Throws IoError naming the
/// file when the sources and the container disagree (a file changed during the run).
void export_folder(const std::filesystem::path& container, const std::vector<std::filesystem::path>& sources,
                   const std::vector<std::filesystem::path>& outputs, const OutputOptions& out,
                   std::uint64_t memory_budget);

}  // namespace pointfair::cli
