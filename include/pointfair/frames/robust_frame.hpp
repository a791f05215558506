#pragma once
// A tangent plane that does not straddle a sharp edge (beyond the paper).
//
// The PCA plane of Lange & Polthier (2005), eq. (1), fits {p_i} ∪ N_i as a whole, so near a
// sharp edge it lies between the two faces: its normal is wrong on both, and the directional
// curvatures the cut-off reads from it are then large toward both faces. The robust plane
// starts from the PCA plane of p_i and its few nearest neighbours (on p_i's own face unless
// p_i sits on the crease) and refits it by iteratively reweighted PCA with Tukey's biweight of
// each point's distance to the current plane, in units of a robust scale (1.4826 times the
// median absolute distance). Points of another face become outliers with weight 0; on a smooth
// patch every point keeps a weight near 1 and the plane is close to the PCA plane.
#include <span>

#include "pointfair/frames/frame.hpp"
#include "pointfair/types.hpp"

namespace pointfair {

struct RobustFrameParams {
  /// Nearest neighbours (the point itself not counted) of the seed plane; at least 2.
  /// 4, 6 and 10 measured alike on fandisk (README, Quality).
  int seed_neighbors = 6;
  /// Reweighting passes after the seed (0: the seed plane itself).
  int iterations = 3;
  /// Tukey's bound in units of the robust scale: points farther from the plane get weight 0.
  double inlier_bound = 3.0;
  /// Where the robust plane is fitted (dimensionless, >= 0; 0: at every point). With a gate G,
  /// a point keeps the PCA plane of itself and its neighbours unless that plane is ambiguous:
  /// its covariance's smallest eigenvalue c0 exceeds G (lambda tr)^2, tr the covariance's trace
  /// and lambda the step's noise gauge: the automatic lambda as measured (before
  /// FlowParams::lambda_auto_factor), or a fixed lambda (needs_robust_plane). Under noise alone c0 grows
  /// as sigma^2 and lambda tr as sigma, so the ratio stays near a constant whatever the noise
  /// level; across a crease or a tight bend c0 grows with the neighbourhood's extent instead.
  double gate = 0.0;

  void validate() const;
};

/// Whether a point needs the robust plane under `gate` (RobustFrameParams::gate): its PCA
/// covariance has smallest eigenvalue over trace `smallest_over_trace` (scale-free) and trace
/// `trace`, the step's noise gauge is `lambda`. True with no gate, and where the ratio is not a
/// number (a degenerate neighbourhood: the robust fit decides as it did without a gate).
inline bool needs_robust_plane(double smallest_over_trace, double trace, double lambda, double gate) {
  if (gate == 0.0) return true;
  // c0 > G lambda^2 tr^2, divided by tr.
  return !(smallest_over_trace <= gate * (lambda * lambda) * trace);
}

/// The fitted plane: unit normal (sign arbitrary), the weighted barycentre relative to p, and
/// the weighted covariance about it (divided by the total weight).
struct RobustPlane {
  Vec3 normal = Vec3::UnitZ();
  Vec3 mean = Vec3::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  bool valid = false;
};

/// Robust plane of a point p from the offsets q_j - p of its neighbours, nearest first (as the
/// neighbourhoods keep them); p itself is the zero offset and takes part. `weights` (size
/// offsets + 1) receives the final weight in [0, 1] of p (slot 0) and of each neighbour;
/// `scratch` is work space of the same size. Invalid when fewer than 3 points keep a weight or
/// they do not span a plane.
RobustPlane fit_robust_plane(std::span<const Vec3> offsets, const RobustFrameParams& params,
                             std::span<double> weights, std::span<double> scratch);

/// The robust plane of p as a full frame (tangents, eigenvalues; the centroid is the weighted
/// barycentre), for the slow path and the attributes. Indices refer to `points`.
Frame compute_robust_frame(const Vec3& p, std::span<const Index> neighbors,
                           std::span<const Vec3> points, const RobustFrameParams& params);

}  // namespace pointfair
