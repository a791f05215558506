#pragma once
// The HDF5 scan container (layout in the README, "Out-of-core runs and the HDF5 container"):
// positions and every input attribute as datasets with rows grouped by spatial tile, each
// point's original index, and the tile table. Plain HDF5: h5dump, h5ls and h5py read it.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "pointfair/io/point_table.hpp"
#include "pointfair/smooth.hpp"
#include "pointfair/tiles/hdf5_file.hpp"
#include "pointfair/tiles/tiling.hpp"

namespace pointfair::tiles {

/// Object paths of the container.
namespace layout {
inline constexpr const char* format_name = "pointfair-scan";
inline constexpr std::int64_t format_version = 1;
inline constexpr const char* points = "/points";
inline constexpr const char* positions = "/points/positions";
inline constexpr const char* original_index = "/points/original_index";
inline constexpr const char* attributes = "/points/attributes";
/// A LAS source's VLRs and EVLRs (table, names, payload), Extra Bytes descriptors, GUID.
inline constexpr const char* las_records = "/points/las_records";
/// A text or PLY source's layout (io::encode_source_layout), bytes: kept by an export.
inline constexpr const char* source_layout = "/points/source_layout";
inline constexpr const char* tiles = "/tiles";
inline constexpr const char* tile_offsets = "/tiles/offsets";
inline constexpr const char* tile_bounds = "/tiles/bounds";
inline constexpr const char* run = "/run";
inline constexpr const char* run_state = "/run/state";
inline constexpr const char* run_eps = "/run/eps";
inline constexpr const char* run_step_log = "/run/step_log";
inline constexpr const char* neighbor_rows = "/run/neighbors/rows";
inline constexpr const char* neighbor_counts = "/run/neighbors/counts";
inline constexpr const char* neighbor_local = "/run/neighbors/local";
inline constexpr const char* neighbor_halo_counts = "/run/neighbors/halo_counts";
inline constexpr const char* run_attributes = "/run/attributes";
}  // namespace layout

struct ImportOptions {
  TilingParams tiling;
  /// Rows per HDF5 chunk of the per-point datasets (capped at the point count).
  std::uint64_t chunk_rows = 65536;
  /// Deflate level with shuffle (0: none). Compression costs time on every tile read.
  int deflate = 0;
  /// Recorded in the file's metadata.
  std::string source_name;
  std::uint64_t source_size = 0;
  /// io::file_digest of the source, recorded when not empty (attribute "source_digest"): an
  /// out-of-core run resumed from a point file checks it against the file it is given.
  std::string source_digest;
};

/// Writes `table` as a container at `file`, atomically (a temporary name, renamed when
/// complete). Throws IoError naming the file and dataset, ParamError on bad tiling params.
void write_container(const std::filesystem::path& file, const io::PointTable& table,
                     const ImportOptions& options = {});

/// The LAS quantization (scale, offset) and format of `table` (when it has them) as
/// attributes of /points/positions and /points, and its text or PLY layout as
/// layout::source_layout, written after /points/positions exists.
void write_source_format(h5::File& file, const io::PointTable& table);
/// Reads them back into `table` (nothing when the container has none). Throws IoError for
/// values out of range.
void read_source_format(const h5::File& file, io::PointTable& table);

struct TileTable {
  std::vector<std::uint64_t> offsets;
  std::vector<Box> bounds;
  std::size_t size() const { return bounds.size(); }
  std::uint64_t rows(std::size_t t) const { return offsets[t + 1] - offsets[t]; }
};

/// The bounds of every point of the table's tiles (the box of their bounds; empty tiles add
/// nothing).
Box cloud_bounds(const TileTable& tiles);

/// Checks the format marker and reads the tile table. Throws IoError for a file that is not
/// a pointfair container or whose tile table is inconsistent.
TileTable read_tile_table(const h5::File& file);

/// True for a container's file name: .h5 or .hdf5 (case-insensitive).
bool is_container_path(const std::filesystem::path& path);

/// Number of points of a container.
std::uint64_t point_count(const h5::File& file);

struct ReadContainerOptions {
  /// Rows in the input's point order (true) or in the container's tile order.
  bool original_order = true;
  /// With a smoothing run in the file: its final positions instead of the input's. Throws
  /// IoError if the run is unfinished.
  bool result_positions = true;
};

/// Reads a whole container into memory: positions and every input attribute.
io::PointTable read_container(const std::filesystem::path& file,
                              const ReadContainerOptions& options = {});

/// True when the file holds a finished smoothing run (see smooth_out_of_core).
bool has_finished_run(const h5::File& file);

/// The per-point results of a finished run (normals, curvatures, feature classes), in the
/// input's point order or the tile order. Throws IoError when the run has none.
PointAttributes read_run_attributes(const std::filesystem::path& file, bool original_order = true);

}  // namespace pointfair::tiles
