#include "pointfair/flow/laplacian.hpp"

#include <cmath>

#include "pointfair/curvature/curvature.hpp"

namespace pointfair {

Vec3 laplacian(const Vec3& p, const Vec3& normal, std::span<const Index> neighbors,
               std::span<const Vec3> points, const LaplacianParams& params) {
  if (neighbors.empty()) return Vec3::Zero();
  Vec3 sum = Vec3::Zero();
  if (params.flow == Flow::Isotropic) {
    for (const Index j : neighbors) sum += points[j] - p;
  } else {
    const Vec3 shift = params.origin_height * normal;
    for (const Index j : neighbors) {
      const Vec3 d = points[j] - p;
      const double g = cutoff_weight(std::abs(directional_curvature(normal, d - shift)),
                                     params.lambda, params.cutoff);
      sum += g * d;
    }
  }
  return sum / static_cast<double>(neighbors.size());
}

}  // namespace pointfair
