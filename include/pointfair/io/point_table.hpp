#pragma once
// A point cloud as read from or written to a file: positions plus named per-point attributes.
#include <cstddef>
#include <functional>
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

/// Positions plus named attributes, in file order. Attributes keep the order in which they
/// appear in the file; writers emit them in that order after x, y, z.
struct PointTable {
  std::vector<Vec3> positions;
  /// Storage type of x, y, z in the source file (Float32 or Float64); writers use it.
  ScalarType position_type = ScalarType::Float64;
  std::vector<Attribute> attributes;

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
