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
