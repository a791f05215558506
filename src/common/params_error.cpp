#include "pointfair/common/params_error.hpp"

#include <cmath>
#include <sstream>

namespace pointfair {

void require_finite(std::span<const Vec3> points, std::string_view what) {
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vec3& p = points[i];
    if (std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z())) continue;
    std::ostringstream message;
    message << what << ": point " << i << " has a non-finite coordinate (" << p.x() << ", "
            << p.y() << ", " << p.z() << ")";
    throw ParamError(message.str());
  }
}

}  // namespace pointfair
