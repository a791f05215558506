#pragma once
// Stanford PLY (format 1.0) point files.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>

#include "pointfair/io/point_chunks.hpp"
#include "pointfair/io/point_table.hpp"

namespace pointfair::io {

/// Reads the "vertex" element of a PLY file (ascii, binary_little_endian or
/// binary_big_endian). x, y, z (float or double) become positions; every other vertex
/// property becomes an Attribute of the same type, in file order. Other elements (faces,
/// edges, ...) are skipped with one warning each ("<file>: 12 faces ignored"), as are bytes
/// after a binary body.
/// Throws IoError "<file>: <problem>" for an unreadable, malformed or truncated file, a list
/// property in the vertex element, or a non-finite coordinate. Header counts are checked
/// against the file size before anything is allocated.
PointTable read_ply(const std::filesystem::path& file, const ReadOptions& options = {});

/// read_ply a chunk at a time: the header (and any element before the vertices) is read
/// when the reader opens; count() is the header's vertex count. Same errors and warnings.
std::unique_ptr<PointChunkReader> open_ply_reader(const std::filesystem::path& file,
                                                  const ReadOptions& options = {});

/// Writes `table` atomically (see write_file_atomically) as a PLY file: x, y, z stored as
/// float when table.position_type is Float32 and as double otherwise, every attribute in its
/// own type (integers rounded and saturated to the type's range). ASCII numbers read back
/// exactly. A table read from PLY (table.ply) keeps its source's encoding (unless `encoding`
/// is given), its comment and obj_info lines and its vertex property order; attributes the
/// source did not have follow in table order. Otherwise: binary little endian, x y z, then
/// the attributes in table order. Other elements of the source (faces...) are not kept.
/// Throws IoError "<file>: <problem>" for a non-finite position, an attribute whose size
/// differs from the number of points, an attribute name that cannot appear in a PLY header
/// (empty, whitespace, duplicate, x/y/z) or a write failure.
void write_ply(const std::filesystem::path& file, const PointTable& table,
               std::optional<PlyEncoding> encoding = std::nullopt);

/// write_ply a chunk at a time: the header declares `count` points, of the position type
/// and attributes of `schema` (its values are ignored). Names are checked when it opens;
/// each chunk's positions when it is written (indices in errors count from the file's first
/// point).
std::unique_ptr<PointChunkWriter> open_ply_writer(const std::filesystem::path& file,
                                                  const PointTable& schema, std::uint64_t count,
                                                  std::optional<PlyEncoding> encoding = std::nullopt);

}  // namespace pointfair::io
