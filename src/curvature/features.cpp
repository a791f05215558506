#include "pointfair/curvature/features.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "pointfair/common/params_error.hpp"

namespace pointfair {

void FeatureParams::validate() const {
  require(quotient >= 0.0 && quotient <= 1.0,
          "edge quotient Q must be in [0, 1], got " + std::to_string(quotient));
  require(threshold >= 0.0 && std::isfinite(threshold),
          "feature threshold must be >= 0 (0 = chosen by its scale), got " + std::to_string(threshold));
  require(turn >= 0.0 && std::isfinite(turn),
          "feature turn must be >= 0 radians, got " + std::to_string(turn));
}

FeatureClass classify_feature(const Curvature& c, FeatureMode mode, double quotient,
                              double threshold) {
  if (mode == FeatureMode::None || !c.valid) return FeatureClass::Smooth;
  const double kmax = c.max_abs();
  const double kmin = c.min_abs();
  if (!(kmax >= threshold) || kmax == 0.0) return FeatureClass::Smooth;
  if (mode == FeatureMode::EdgeQuotient)
    return kmin / kmax < quotient ? FeatureClass::Edge : FeatureClass::Corner;
  return kmin >= threshold ? FeatureClass::Corner : FeatureClass::Edge;
}

double neighborhood_radius(const Vec3& p, std::span<const Index> neighbors, std::span<const Vec3> points) {
  // The largest squared distance, then one square root: the same bits in any list order.
  double r2 = 0.0;
  for (const Index j : neighbors) r2 = std::max(r2, (points[j] - p).squaredNorm());
  return std::sqrt(r2);
}

double feature_threshold(const FeatureParams& params, double lambda, double radius) {
  if (params.threshold > 0.0) return params.threshold;
  if (params.scale == FeatureScale::Lambda) return lambda;
  return radius > 0.0 ? params.turn / radius : std::numeric_limits<double>::infinity();
}

}  // namespace pointfair
