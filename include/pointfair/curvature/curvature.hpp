#pragma once
// Directional curvatures and the density-weighted Weingarten map of Lange & Polthier (2005),
// Section 3, eqs. (2) and (4), read as fixed in MATH.md:
//   kappa_ij = 2 <n_i, p_j - p_i> / |p_j - p_i|^2                                    (2)
//   delta_ij = 2 t_ij^T M_i t_ij - (c1 + c2) / 2, clamped below at floor * (c1 + c2)
//   w_ij ∝ |p_j - p_i| / delta_ij, normalised so that sum_j w_ij = 2 pi
//   H_i = (1 / 2 pi) sum_j w_ij kappa_ij
//   W_i = (1 / pi) sum_j w_ij (2 kappa_ij - H_i) t_ij t_ij^T                          (4)
// Principal curvatures and directions are the eigenpairs of W_i on the tangent plane.
//
// Differs from the paper: the density is clamped (it turns negative when c1 > 3 c2), and the
// weights are normalised to the full circle instead of by 4 pi / |N_i|, which makes
// trace W_i = 2 H_i = k1 + k2 for any sampling. Uniform weights are offered as an option.
#include <span>

#include "pointfair/frames/frame.hpp"
#include "pointfair/types.hpp"

namespace pointfair {

enum class AngularWeights {
  Paper,    ///< w_ij ∝ |p_j - p_i| / delta_ij, the paper's density-weighted Riemann sum
  Uniform,  ///< w_ij = 2 pi / |N_i|
};

struct WeingartenParams {
  AngularWeights weights = AngularWeights::Paper;
  /// Lower clamp of the directional density delta_ij as a fraction of c1 + c2 (> 0).
  double density_floor = 0.05;

  void validate() const;
};

/// Principal curvatures k1 >= k2 (1/length, signed with respect to the frame's normal), their
/// unit directions d1, d2 (tangent, orthogonal), and the mean curvature H = (k1 + k2) / 2.
struct Curvature {
  double k1 = 0.0;
  double k2 = 0.0;
  Vec3 d1 = Vec3::UnitX();
  Vec3 d2 = Vec3::UnitY();
  double mean = 0.0;
  bool valid = false;

  /// The larger principal curvature in absolute value.
  double max_abs() const;
  /// The smaller principal curvature in absolute value.
  double min_abs() const;
};

/// Directional curvature (eq. 2) in direction d = p_j - p_i; 0 for d = 0.
inline double directional_curvature(const Vec3& normal, const Vec3& d) {
  const double len2 = d.squaredNorm();
  return len2 > 0.0 ? 2.0 * normal.dot(d) / len2 : 0.0;
}

/// Weingarten map W_i (eq. 4) of point p with frame `frame` as a 2x2 matrix in the basis
/// (frame.t1, frame.t2), and H_i. Neighbours whose tangential part vanishes are skipped.
struct WeingartenMap {
  Eigen::Matrix2d map = Eigen::Matrix2d::Zero();
  double mean = 0.0;
  bool valid = false;
};
WeingartenMap weingarten_map(const Vec3& p, const Frame& frame, std::span<const Index> neighbors,
                             std::span<const Vec3> points, const WeingartenParams& params = {});

/// Eigen-decomposition of a Weingarten map into principal curvatures and directions.
Curvature principal_curvatures(const WeingartenMap& w, const Frame& frame);

/// Both steps: the curvature of point p.
Curvature compute_curvature(const Vec3& p, const Frame& frame, std::span<const Index> neighbors,
                            std::span<const Vec3> points, const WeingartenParams& params = {});

}  // namespace pointfair
