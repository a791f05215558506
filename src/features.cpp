#include "pointfair/features.hpp"

#include <cmath>
#include <string>

#include "pointfair/params_error.hpp"

namespace pointfair {

void FeatureParams::validate() const {
  require(quotient >= 0.0 && quotient <= 1.0,
          "edge quotient Q must be in [0, 1], got " + std::to_string(quotient));
  require(threshold >= 0.0 && std::isfinite(threshold),
          "feature threshold must be >= 0 (0 = lambda), got " + std::to_string(threshold));
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

}  // namespace pointfair
