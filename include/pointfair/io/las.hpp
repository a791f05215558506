#pragma once
// ASPRS LAS point files, versions 1.0 to 1.4, point data record formats 0 to 10, and LAZ
// (LAS with LASzip-compressed records) for point formats 0 to 3 and 6 to 8 (docs/laz.md).
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "pointfair/io/point_chunks.hpp"
#include "pointfair/io/point_table.hpp"

namespace pointfair::io {

/// Reads a LAS file. Positions are offset + scale * (the stored int32 X, Y, Z); the scale and
/// offset are kept in table.quantization, and the version, point format, header ids, Extra
/// Bytes descriptors and all other (E)VLRs in table.las, so write_las reproduces the file's
/// integers and fields exactly.
///
/// Every standard field of the point format becomes an attribute, in record order, with the
/// type of the specification (names and types in README "Formats"): intensity, return_number,
/// number_of_returns, scan_direction_flag, edge_of_flight_line, classification, synthetic,
/// key_point, withheld, overlap (formats 6-10), scanner_channel (6-10), scan_angle_rank
/// (0-5: int8 degrees, as stored) or scan_angle (6-10: int16 in units of 0.006 degrees, as
/// stored), user_data, point_source_id, gps_time, red, green, blue, nir, wave_packet_index,
/// wave_data_offset (uint64 held as a double), wave_packet_size, return_point_location, x_t,
/// y_t, z_t. Extra bytes become attributes after them: one per value described by the Extra
/// Bytes VLR (stored values: the descriptor's scale and offset are not applied; arrays give
/// name_0, name_1, ...; names are reduced to letters, digits and '_' and made unique), then
/// one uint8 "extra_byte_<k>" per undescribed byte.
///
/// A LAZ file (the compression bit and a LASzip VLR; the name does not matter) is read the
/// same way, its records decompressed a chunk at a time; the LASzip VLR is not kept in
/// table.las. LAZ of the wave packet formats (4, 5, 9, 10) is refused.
///
/// Throws IoError "<file>: <problem>" for a file that is not LAS, is LAZ that cannot be
/// decoded (an unsupported format, compressor or item version; a truncated or corrupt
/// chunk: "LAZ chunk <k> of <n> ..."), is truncated, has inconsistent sizes or offsets (checked against the
/// file size before anything is allocated), an unknown version or point format, a record
/// length too small for its format, an unusable scale or offset, or a non-finite position.
PointTable read_las(const std::filesystem::path& file, const ReadOptions& options = {});

/// read_las a chunk at a time: the header and VLRs are read when the reader opens (schema()
/// has the quantization and LAS metadata, every chunk too), count() is the header's point
/// count, and the EVLRs are added to schema().las once the last point has been read.
std::unique_ptr<PointChunkReader> open_las_reader(const std::filesystem::path& file,
                                                  const ReadOptions& options = {});

/// A coordinate system as LAS files store it (ASPRS LAS 1.4 R15, section 2.5): an OGC WKT
/// record for LAS 1.4's point formats 6-10, GeoTIFF keys for formats 0-5. Plain data: the
/// CLI fills it from an EPSG code through PROJ.
struct LasCoordinateSystem {
  /// OGC WKT (version 1), written as the record LASF_Projection 2112.
  std::string wkt{};
  /// GeoTIFF keys (key id, value), each stored in the key directory (LASF_Projection 34735)
  /// with TIFF tag location 0: e.g. {1024, 1} (a projected model), {3072, 2056} (its EPSG
  /// code), {4096, 5728} (a vertical one). Empty: the system cannot be written as GeoTIFF keys.
  std::vector<std::pair<std::uint16_t, std::uint16_t>> geo_keys{};
};

/// What write_las chooses, beyond what the table says of itself.
struct LasWriteOptions {
  /// 2 (LAS 1.2, point formats 0-3) or 4 (LAS 1.4, formats 6-10); 0: table.las's version and
  /// format, else the rule of write_las. A table read from LAS is converted by field name:
  /// into 1.2, format 0-3 by gps_time and colours, and a value beyond the narrower field
  /// (classification above 31, return numbers above 7) is an error naming the point (no
  /// silent clipping; the same check holds for every bit field whenever a version is given);
  /// 1.4's overlap and scanner_channel, and every other attribute without a field, go to
  /// the extra bytes (a 1.2 reader skips them); wave packets cannot go to 1.2. Into 1.4, the
  /// smallest of formats 6-10 that holds the fields.
  int version_minor = 0;
  /// The scale of the stored integers on x, y, z; empty: table.quantization's, else
  /// las_quantization_for's.
  std::optional<Vec3> scale{};
  /// The offset of the stored integers; empty: as the scale.
  std::optional<Vec3> offset{};
  /// Replaces every coordinate system record of the source (LASF_Projection 2111, 2112,
  /// 34735-34737); empty: the source's records are kept, a table from elsewhere has none.
  std::optional<LasCoordinateSystem> crs{};
  /// Points per LAZ chunk when the file name ends in .laz (each chunk is compressed on its
  /// own; a reader holds one at a time). 50000 is LASzip's default.
  std::uint32_t laz_chunk_size = 50000;
};

/// Writes `table` atomically (see write_file_atomically) as a LAS file; as LAZ when `file`
/// ends in .laz (case-insensitively), in chunks of options.laz_chunk_size points. LAZ output
/// holds point formats 0-3 and 6-8: a table that needs wave packets (4, 5, 9, 10) is
/// refused for .laz.
///
/// Version and point format: options.version_minor's when given, else those of table.las
/// when present (a table read from LAS); otherwise LAS 1.2, which every reader takes, when every attribute is one of intensity,
/// the scan direction and edge flags, synthetic, key_point, withheld, user_data,
/// point_source_id, gps_time, red, green, blue (format 0; 1 with gps_time, 2 with colours,
/// 3 with both); else LAS 1.4 with the smallest of formats 6-10 that holds the table's
/// standard attributes: 6, 7 with red/green/blue, 8 with nir, 9 with wave packet fields, 10
/// with wave packets and colour (1.4 formats are the only ones with 16 returns, the overlap
/// flag, 256 classes and described extra bytes).
///
/// Positions: quantized with options.scale and options.offset where given, else with
/// table.quantization when present, else las_quantization_for the bounding box.
///
/// Attributes named like a standard field of the format fill that field (converted to the
/// field's type: rounded, and saturated to its range or bit width; uint8 red, green, blue and
/// nir are scaled by 257 to the 16 bits of LAS colours); a field without an
/// attribute is 0 (return_number and number_of_returns: 1). scan_angle_rank and scan_angle
/// convert into each other when only the other one exists. Every other attribute goes to
/// the extra bytes, described by an Extra Bytes VLR (the source's descriptors are reused
/// when the extra attributes are still exactly the ones read).
///
/// Throws IoError "<file>: <problem>" for a non-finite position, a position outside the
/// int32 range of the quantization, an invalid table.las (version/format), an attribute
/// name too long for an extra bytes descriptor (32 characters), or a write failure.
void write_las(const std::filesystem::path& file, const PointTable& table, const LasWriteOptions& options = {});

/// The integer grid write_las chooses for positions within [lo, hi] when the table has no
/// quantization: offset = lo rounded down to a whole unit on each axis; one scale for all
/// three, the largest power of ten that puts a million steps or more across the largest
/// extent above the offset, at most 1e-3 (a millimetre for metres: a 1 km tile gets 1e-3, a
/// 100 m one 1e-4, a unit object 1e-6) and at least 1e-9, coarser only where the extent would
/// not fit in int32. A streaming writer given it in its schema writes the same
/// bytes as write_las without holding the points.
PositionQuantization las_quantization_for(const Vec3& lo, const Vec3& hi);

/// write_las a chunk at a time, with the quantization and LAS metadata of `schema` and
/// `options`: with a quantization (a table read from LAS, a container imported from one, or
/// both options.scale and options.offset) the records stream and the header is completed by
/// finish() (the same bytes as write_las). Without one the grid depends on the bounds of
/// every point, so the chunks are kept in memory until finish().
std::unique_ptr<PointChunkWriter> open_las_writer(const std::filesystem::path& file, const PointTable& schema,
                                                  std::uint64_t count, const LasWriteOptions& options = {});

}  // namespace pointfair::io
