#pragma once
// PCA tangent frames, Lange & Polthier (2005), Section 2.2, eq. (1): the covariance M_i of
// {p_i} ∪ N_i about its barycentre; the normal is the eigenvector of the smallest eigenvalue.
//
// Differs from the paper: the covariance is accumulated relative to p_i (not to the origin),
// so clouds far from the origin (e.g. UTM coordinates) keep full precision.
#include <span>

#include "pointfair/types.hpp"

namespace pointfair {

/// A tangent frame. normal, t1, t2 are orthonormal; c1 >= c2 >= c0 >= 0 are the eigenvalues
/// of the covariance (divided by the number of points) belonging to t1, t2 and normal.
/// The normal's sign is arbitrary (PCA); nothing in the flow depends on it.
struct Frame {
  Vec3 normal = Vec3::UnitZ();
  Vec3 t1 = Vec3::UnitX();
  Vec3 t2 = Vec3::UnitY();
  Vec3 centroid = Vec3::Zero();
  double c1 = 0.0;
  double c2 = 0.0;
  double c0 = 0.0;
  /// False when the points do not span a plane (fewer than 3, or all on a line/at a point).
  bool valid = false;
};

/// Frame of point `p` with its neighbours `neighbors` (indices into `points`).
Frame compute_frame(const Vec3& p, std::span<const Index> neighbors, std::span<const Vec3> points);

/// The normal alone, for the Euler step's hot path: the unit eigenvector of the smallest
/// eigenvalue c0 of `covariance` (symmetric positive semi-definite), with c0 found by Newton's
/// method on the characteristic polynomial and the vector as the largest cross product of two
/// rows of (covariance - c0 I). Where the eigenvalues are too close for that to be accurate
/// (relative gap c2 - c0 below 1e-4 c1, or c2 below 1e-6 c1) it falls back to
/// frame_from_covariance, so `valid` always agrees with it.
struct NormalEstimate {
  Vec3 normal = Vec3::UnitZ();
  bool valid = false;
};
NormalEstimate normal_from_covariance(const Eigen::Matrix3d& covariance);

/// Frame from a covariance about the barycentre (already divided by the point count) and the
/// barycentre. Exposed for tests and for callers that accumulate the covariance themselves.
Frame frame_from_covariance(const Eigen::Matrix3d& covariance, const Vec3& centroid);

}  // namespace pointfair
