#pragma once
// Parameter errors: thrown by a stage's validate() before any work is done.
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>

#include "pointfair/types.hpp"

namespace pointfair {

/// A parameter is out of its range. what() names the parameter and the allowed range.
class ParamError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// Throws ParamError(message) unless `condition` holds.
inline void require(bool condition, const std::string& message) {
  if (!condition) throw ParamError(message);
}

/// Throws ParamError "<what>: point i has a non-finite coordinate (x, y, z)" for the first
/// point with a NaN or infinite coordinate. Readers reject such files with an IoError; this
/// guards the library's own entry points.
void require_finite(std::span<const Vec3> points, std::string_view what);

}  // namespace pointfair
