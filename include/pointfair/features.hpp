#pragma once
// Feature detection from principal curvatures, Lange & Polthier (2005), Section 5:
//   edge quotient: q = |k_min| / |k_max| < Q with |k_max| >= threshold marks an edge;
//   maximal curvature: |k_max| >= threshold marks a feature.
// In both modes a point whose two principal curvatures both reach the threshold (and, for the
// quotient mode, q >= Q) is a corner. The paper's third test (some |kappa_ij| > T) is left
// out: the paper reports that it works poorly.
#include <cstdint>

#include "pointfair/curvature.hpp"

namespace pointfair {

enum class FeatureMode { None, EdgeQuotient, MaxCurvature };
enum class FeatureClass : std::uint8_t { Smooth = 0, Edge = 1, Corner = 2 };

struct FeatureParams {
  FeatureMode mode = FeatureMode::EdgeQuotient;
  /// Edge quotient threshold Q in [0, 1].
  double quotient = 0.5;
  /// Curvature threshold (1/length). 0 uses the flow's lambda.
  double threshold = 0.0;

  void validate() const;
};

/// Class of a point with curvature `c`; `threshold` is the resolved curvature threshold.
FeatureClass classify_feature(const Curvature& c, FeatureMode mode, double quotient,
                              double threshold);

}  // namespace pointfair
