#pragma once
// A point cloud as read from or written to a file: positions plus named per-point attributes.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "pointfair/types.hpp"

namespace pointfair::io {

/// Storage type of a property in a file. Values are held as double in memory, which
/// represents every one of these types exactly, and written back in the same type.
enum class ScalarType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

/// Size in bytes of one value of `type`.
std::size_t scalar_size(ScalarType type);
/// PLY name of `type` ("char", "uchar", ..., "float", "double").
std::string_view scalar_name(ScalarType type);

/// One per-point attribute: `values.size()` equals the number of points.
struct Attribute {
  std::string name;
  ScalarType type = ScalarType::Float64;
  std::vector<double> values;
};

/// The integer grid of positions in a LAS file: x = offset.x() + scale.x() * X for the stored
/// int32 X (same for y, z). Kept with a table read from LAS so that writing it back as LAS
/// stores the same integers.
struct PositionQuantization {
  Vec3 scale = Vec3::Constant(0.001);
  Vec3 offset = Vec3::Zero();
};

/// One LAS variable length record, kept opaque (e.g. the coordinate system) and written back.
struct LasRecord {
  std::string user_id;      // at most 16 characters
  std::uint16_t record_id = 0;
  std::string description;  // at most 32 characters
  std::string data;         // the payload bytes
  bool extended = false;    // read from an EVLR (LAS 1.4), whose payload may exceed 65535 bytes
};

/// What a LAS file said about itself beyond the points, so that write_las reproduces it.
struct LasMetadata {
  int version_minor = 4;      // LAS 1.<version_minor>, 0..4
  int point_format = 6;       // point data record format, 0..10
  std::uint16_t file_source_id = 0;
  std::uint16_t global_encoding = 0;  // bit 0: GPS time is adjusted standard GPS time
  std::string project_guid = std::string(16, '\0');  // 16 raw bytes
  std::string system_identifier;
  /// Payload of the Extra Bytes VLR ("LASF_Spec", 4), reused when the table's extra
  /// attributes still match it, so descriptions, scales and no-data values survive.
  std::string extra_bytes_descriptors;
  /// Every other VLR and EVLR, in file order.
  std::vector<LasRecord> records;
};

/// How a PLY file is encoded.
enum class PlyEncoding { Ascii, BinaryLittleEndian, BinaryBigEndian };

/// One column of a text point file, as the reader saw it.
struct TextColumn {
  /// The attribute fed by this column, or "x", "y", "z" for a coordinate.
  std::string name;
  /// 0, 1, 2 for the x, y, z column; -1 for an attribute.
  int axis = -1;
  /// The header field as written (quotes kept); empty for a file without a header.
  std::string header;
  /// Digits after the decimal point of the first row's value when it was written in plain
  /// fixed notation ("12.500" gives 3, "7" gives 0); -1 otherwise (an exponent, "nan").
  /// The writer prints a value with this many digits when that text reads back as the same
  /// double, so unchanged values come back as the same text.
  int decimals = -1;
};

/// The layout of a text point file, kept by read_xyz so that write_xyz reproduces it.
struct TextLayout {
  /// The first content line named the columns. Without it the names were guessed
  /// (field_3, or nx ny nz for 6 columns) and say nothing of what the columns hold.
  bool header = false;
  /// The text between the first two fields of the first data row: " ", "\t", ",", ", ", ";"...
  std::string separator = " ";
  /// "\r\n" when the first line ended so, else "\n".
  std::string line_end = "\n";
  /// The file opened with a line holding the point count (as many .pts files do).
  bool count_line = false;
  /// Every column of the file, in file order.
  std::vector<TextColumn> columns;
};

/// What a PLY file said about itself beyond the vertex values, so that write_ply keeps it.
struct PlyLayout {
  PlyEncoding encoding = PlyEncoding::BinaryLittleEndian;
  /// The header's "comment ..." and "obj_info ..." lines, as written, in order.
  std::vector<std::string> header_lines;
  /// The vertex properties in file order, x, y and z included.
  std::vector<std::string> properties;
};

/// Positions plus named attributes, in file order. Attributes keep the order in which they
/// appear in the file; writers emit them in that order after x, y, z.
struct PointTable {
  std::vector<Vec3> positions;
  /// Storage type of x, y, z in the source file (Float32 or Float64); writers use it.
  ScalarType position_type = ScalarType::Float64;
  std::vector<Attribute> attributes;
  /// The integer grid of the positions when the source stored them quantized (LAS); writers
  /// of quantized formats reuse it. Empty for float sources (PLY, XYZ).
  std::optional<PositionQuantization> quantization;
  /// Header fields, point format and records of a LAS source; write_las keeps them. Empty
  /// for other sources.
  std::optional<LasMetadata> las;
  /// Columns, header, separator and number format of a text source; write_xyz keeps them.
  std::optional<TextLayout> text;
  /// Encoding, comments and property order of a PLY source; write_ply keeps them.
  std::optional<PlyLayout> ply;

  std::size_t size() const { return positions.size(); }
  /// The attribute called `name`, or nullptr.
  const Attribute* find(std::string_view name) const;
  Attribute* find(std::string_view name);
  /// Adds the attribute, or replaces the values and type of an existing one of that name.
  Attribute& set(std::string name, ScalarType type, std::vector<double> values);
};

/// A file could not be read or written. `what()` is one line: "<file>: <problem>".
class IoError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct ReadOptions {
  /// Called with a one-line message for recoverable oddities (e.g. "faces ignored").
  std::function<void(const std::string&)> on_warning;
};

}  // namespace pointfair::io
