#pragma once
// Parameter errors: thrown by a stage's validate() before any work is done.
#include <stdexcept>
#include <string>

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

}  // namespace pointfair
