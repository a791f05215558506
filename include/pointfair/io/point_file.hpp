#pragma once
// Point files of any supported format, chosen by the file extension.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>

#include "pointfair/io/las.hpp"
#include "pointfair/io/ply.hpp"
#include "pointfair/io/point_chunks.hpp"
#include "pointfair/io/point_table.hpp"

namespace pointfair::io {

struct WriteOptions {
  /// PLY encoding; empty: the source's (PointTable::ply), else binary little endian.
  std::optional<PlyEncoding> ply_encoding;
  /// LAS version, scale, offset and coordinate system (LasWriteOptions); other formats
  /// ignore them (the CLI refuses them for other outputs).
  LasWriteOptions las{};
  /// When not empty, write_points refuses to write onto this file (see require_distinct).
  std::filesystem::path input;
};

/// The point file formats, as named by a file's extension.
enum class PointFormat { Ply, Las, Text };

/// The format of `file` by its extension, case-insensitively: .ply; .las and .laz (LAS with
/// compressed records); .xyz .txt .pts .csv .asc. Empty for any other.
std::optional<PointFormat> point_format_of(const std::filesystem::path& file);

/// True if the extension (case-insensitive) is one read_points/write_points handle:
/// .ply, .las, .laz, .xyz, .txt, .pts, .csv or .asc.
bool is_supported_point_file(const std::filesystem::path& file);

/// Reads `file` with read_ply (.ply), read_las (.las and .laz) or read_xyz (.xyz .txt .pts .csv .asc), case-insensitively.
/// Throws IoError "<file>: <problem>": "unknown file extension '.foo' (expected ...)",
/// "... files are not supported by this build yet" for .h5/.hdf5,
/// "cannot open: No such file or directory", or any error of the format's reader.
PointTable read_points(const std::filesystem::path& file, const ReadOptions& options = {});

/// Writes `table` with write_ply (using options.ply_encoding), write_las or write_xyz, by
/// extension (.laz: write_las compresses the records, see docs/laz.md).
/// Throws IoError as read_points for the extension, "output would overwrite the input" when
/// `file` is options.input, or any error of the format's writer.
void write_points(const std::filesystem::path& file, const PointTable& table,
                  const WriteOptions& options = {});

/// The chunk reader of `file`'s format (open_ply_reader, open_las_reader or open_xyz_reader), by extension as
/// read_points. Throws IoError as read_points.
std::unique_ptr<PointChunkReader> open_point_reader(const std::filesystem::path& file,
                                                    const ReadOptions& options = {});

/// Number of points of `file` (of a folder: of its point files together, point_folder.hpp):
/// the count its header declares (PLY, LAS), or a pass over a text file. Throws IoError as open_point_reader and the format's reader.
std::uint64_t count_points(const std::filesystem::path& file);

/// The chunk writer of `file`'s format (open_ply_writer, open_las_writer or open_xyz_writer), by extension as
/// write_points, for `count` points with the attributes of `schema`. Throws IoError as
/// write_points.
std::unique_ptr<PointChunkWriter> open_point_writer(const std::filesystem::path& file,
                                                    const PointTable& schema, std::uint64_t count,
                                                    const WriteOptions& options = {});

}  // namespace pointfair::io
