#pragma once
// A container's points to a point file a chunk at a time (the counterpart of import.hpp):
// memory stays within a budget whatever the cloud's size. Which result columns go out (colours,
// curvatures) is the caller's, through a hook that sees every chunk before it is written.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <vector>

#include "pointfair/io/point_file.hpp"
#include "pointfair/io/point_selection.hpp"
#include "pointfair/io/point_table.hpp"
#include "pointfair/smooth.hpp"
#include "pointfair/tiles/budget.hpp"

namespace pointfair::tiles {

/// Adds or replaces columns of a chunk before it is written: `results` holds the run's
/// per-point results of the chunk's rows (with StreamExportOptions::run_attributes; else it is
/// empty). Called first with the output's schema (no rows, empty results), then with every
/// chunk: it must add the same columns to each.
using ChunkColumns = std::function<void(io::PointTable& chunk, const PointAttributes& results)>;

struct StreamExportOptions {
  /// The input's point order (true) or the container's tile order.
  bool original_order = true;
  /// Write the input positions even when the container holds a finished run.
  bool input_positions = false;
  /// Bytes of points held at a time (the chunk, its result columns and the reader's scratch).
  std::uint64_t memory_budget = kDefaultMemoryBudget;
  /// Read the run's per-point results with every chunk, for `columns` (IoError if the
  /// container holds no finished run with them).
  bool run_attributes = false;
  /// Called on the schema and on every chunk; empty: the points go out as the container holds
  /// them.
  ChunkColumns columns;
  /// The output's PLY encoding and LAS options; `write.input`, when given, is refused as the
  /// output.
  io::WriteOptions write;
};

/// Writes the points of `container` to `output` (format by extension, atomically), a chunk at a
/// time: the finished run's positions (or the input's), every input attribute, the columns
/// `options.columns` adds, in the layout of the file that was imported. A LAS output from a
/// source without an integer grid of its own, whose grid the options do not give, takes the
/// grid of the bounds of every point, found in a first pass (the same bytes as writing the
/// whole cloud at once). Returns the number of points written. Throws IoError naming the file.
std::uint64_t export_points(const std::filesystem::path& container, const std::filesystem::path& output,
                            const StreamExportOptions& options = {});

struct SelectedExportReport {
  std::uint64_t points = 0;
  /// Records the selection kept (the container's rows), and of them those whose position changed.
  std::uint64_t selected = 0, moved = 0;
};

/// Writes `source` to `output` (format by extension, atomically) record by record, in its
/// order, with the smoothed positions of the records `selection` keeps: the k-th of them takes
/// the position of the k-th point (original order) of the finished run in `container`, which
/// was imported from exactly those records (StreamImportOptions::select); normals the source
/// has are refreshed for them (io::refresh_normals). Every other record is written as read.
/// An empty `container` (a selection of no point) writes the source as it was. Memory stays
/// within `memory_budget` but for a LAS output from a source without a quantization, whose
/// chunks the LAS writer holds until its end. `write.input` should be `source`. Throws IoError
/// naming the file when the source and the container disagree (the source changed during the
/// run).
SelectedExportReport export_selected(const std::filesystem::path& container, const std::filesystem::path& source,
                                     const io::PointSelection& selection, const std::filesystem::path& output,
                                     const io::WriteOptions& write, std::uint64_t memory_budget);

/// Writes sources[i] to outputs[i] (format by extension, atomically), record by record, with
/// the smoothed positions of the finished run in `container`, which was imported from the
/// sources' points concatenated in this order (a folder of tiles, io/point_folder.hpp): the
/// points of sources[0] take the container's first points (original order), and so on.
/// Normals a source has are refreshed (io::refresh_normals; the container then needs a
/// finished run with attributes); every other field is written as read, in the source's
/// layout. Each output appears when complete. Memory stays within `memory_budget`; `write`'s
/// input is set to each source in turn. Throws IoError naming the file when the sources and
/// the container disagree (a file changed during the run), before any file is written when
/// their point counts differ.
void export_folder(const std::filesystem::path& container, const std::vector<std::filesystem::path>& sources,
                   const std::vector<std::filesystem::path>& outputs, const io::WriteOptions& write,
                   std::uint64_t memory_budget);

}  // namespace pointfair::tiles
