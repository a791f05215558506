#pragma once
// A point file into the HDF5 scan container in bounded memory: the file streams through
// three times (count and bounds; a histogram of a fine grid, from which the tiles are
// built; the scatter of every point into its tile's rows), and never more than a budget's
// worth of points is held.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

#include "pointfair/io/point_selection.hpp"
#include "pointfair/io/point_table.hpp"
#include "pointfair/tiles/budget.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/ranks.hpp"

namespace pointfair::tiles {

struct StreamImportOptions {
  /// Tiles (max_tile_points or a grid cell size), HDF5 chunking and deflate, metadata.
  ImportOptions container;
  /// Bytes the import may hold (the histogram, the scatter buffer, the reader's chunk and
  /// tables). HDF5's own chunk caches (1 MiB per dataset) and the program come on top.
  std::uint64_t memory_budget = kDefaultMemoryBudget;
  /// Most points per chunk read from the input (fewer when a chunk would take more than an
  /// eighth of the budget).
  std::size_t read_chunk_points = 1u << 16;
  /// The points to import (io::open_selected_reader): the others are left out, and the
  /// container's original indices count the selected points only (the k-th selected point of
  /// the input is original index k). The default takes every point.
  io::PointSelection select;
  /// Passed to the input's reader (e.g. "faces ignored" warnings; given once, by the first pass).
  io::ReadOptions read;
  /// Called after every chunk of each pass with the pass ("count", "histogram", "scatter"),
  /// the points read so far in it and the total (0 while counting). It may throw to stop the
  /// import (e.g. on SIGINT): nothing is left behind, as for any error.
  std::function<void(const std::string& pass, std::uint64_t done, std::uint64_t total)> progress;
  /// The processes that import together (nullptr: this one alone; see ranks.hpp). Every rank
  /// calls import_points with the same arguments; each reads its share of the input (an
  /// equal range of the points a binary PLY or LAS declares, reached by seeking; rank 0 reads
  /// all of a text file, whose count is unknown until it is read), the histograms and bounds
  /// are summed over the ranks, and each rank writes its points into their tiles' rows
  /// through parallel HDF5. The container is the one a single process writes, to the bit.
  /// With deflate, the ranks scatter into an uncompressed staging file and rank 0 alone
  /// writes the compressed container from it.
  Ranks* ranks = nullptr;
};

struct StreamImportReport {
  std::uint64_t points = 0;
  std::size_t attributes = 0;
  std::size_t tiles = 0;
  /// Cells of the histogram grid the tiles were built from.
  std::uint64_t histogram_cells = 0;
  /// Tiles cut from one histogram cell holding more than max_tile_points points (split by
  /// input order: their bounds overlap).
  std::size_t split_cell_tiles = 0;
  /// Times the scatter buffer was written out.
  std::size_t flushes = 0;
  /// Largest number of bytes held by the import's own buffers (<= memory_budget).
  std::uint64_t peak_accounted_bytes = 0;
};

/// Reads `input` (any format of io::open_point_reader; a folder of point files, io::point_files_in,
/// as one cloud of their positions only, concatenated in file-name order; or a container: its
/// input positions and attributes, in its points' original order, to be tiled again) and writes the container `output`
/// atomically (a temporary name, renamed when complete), in the layout write_container
/// writes and smooth_out_of_core reads. Tiles (kd splitting, options.container.tiling
/// max_tile_points) are built from a histogram of a grid of up to 2^21 cells over the
/// cloud's bounds: a box of cells is halved at the cell plane nearest its median along its
/// longest side until it holds at most max_tile_points points; a single cell holding more is
/// cut into tiles of consecutive input points. With tiling.cell_size > 0 every cell of that
/// grid is a tile, as in make_tiling. Inside a tile, rows follow the input order (original
/// index ascending), so the tile bounds are exact and export can stream every tile forward.
/// Throws IoError naming the file for unreadable input or output, ParamError for bad
/// options or a budget below 16 MiB.
StreamImportReport import_points(const std::filesystem::path& input, const std::filesystem::path& output,
                                 const StreamImportOptions& options = {});

}  // namespace pointfair::tiles
