#pragma once
// Feature detection from principal curvatures, Lange & Polthier (2005), Section 5:
//   edge quotient: q = |k_min| / |k_max| < Q with |k_max| >= threshold marks an edge;
//   maximal curvature: |k_max| >= threshold marks a feature.
// In both modes a point whose two principal curvatures both reach the threshold (and, for the
// quotient mode, q >= Q) is a corner. The paper's third test (some |kappa_ij| > T) is left
// out: the paper reports that it works poorly.
//
// Differs from the paper: the paper leaves the threshold to the user. Ours defaults to one in
// units of each point's own neighbourhood (FeatureScale::Spacing, docs/features.md): a point
// is a feature where the surface turns by more than `turn` radians over its neighbourhood
// radius, whatever the rest of the cloud looks like. The flow's lambda (the cloud's median
// |kappa_ij|) stays available as FeatureScale::Lambda; on a mostly flat cloud that median is
// the residual noise, and the noise itself then reads as edges.
#include <cstdint>
#include <span>

#include "pointfair/curvature/curvature.hpp"
#include "pointfair/types.hpp"

namespace pointfair {

enum class FeatureMode { None, EdgeQuotient, MaxCurvature };
enum class FeatureClass : std::uint8_t { Smooth = 0, Edge = 1, Corner = 2 };

/// Where a threshold of 0 (FeatureParams::threshold) comes from.
enum class FeatureScale {
  /// turn / r_i, r_i the distance from point i to its farthest neighbour: a length scale of
  /// the sampling, not of the cloud's curvature, so flat regions and noise do not move it.
  Spacing,
  /// The flow's lambda (FlowParams::lambda, automatic or given): relative to the median
  /// |kappa_ij| of the cloud. The reading of the paper's threshold before the spacing rule.
  Lambda,
};

struct FeatureParams {
  FeatureMode mode = FeatureMode::EdgeQuotient;
  /// Edge quotient threshold Q in [0, 1].
  double quotient = 0.5;
  /// Curvature threshold (1/length) of every point. 0: chosen per point by `scale`.
  double threshold = 0.0;
  FeatureScale scale = FeatureScale::Spacing;
  /// FeatureScale::Spacing: the normal turn (radians) over one neighbourhood radius that makes
  /// a feature, threshold turn / r_i. 0 makes every curved point a feature.
  double turn = 0.25;

  void validate() const;
};

/// Class of a point with curvature `c`; `threshold` is the resolved curvature threshold.
FeatureClass classify_feature(const Curvature& c, FeatureMode mode, double quotient,
                              double threshold);

/// Distance (length) from p to its farthest neighbour; 0 without neighbours.
double neighborhood_radius(const Vec3& p, std::span<const Index> neighbors, std::span<const Vec3> points);

/// The curvature threshold (1/length) of a point whose neighbourhood radius is `radius`:
/// params.threshold when > 0, else lambda (FeatureScale::Lambda) or params.turn / radius
/// (FeatureScale::Spacing; +infinity for radius 0: a point without extent is no feature).
double feature_threshold(const FeatureParams& params, double lambda, double radius);

}  // namespace pointfair
