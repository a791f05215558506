#pragma once
// Plain reference implementations of the method, written straight from MATH.md with separate
// loops and no code shared with the library: brute-force neighbourhoods, the frame from an
// explicit covariance about the barycentre (Eigen's iterative solver), directional
// curvatures, the Weingarten map as a 3x3 tangent tensor (weights, then H, then W), the
// Laplacian with its cut-offs, feature classes and one Euler step.
//
// They are slow and simple on purpose: the tests compare the fast kernels against them. The
// larger ones are compiled once, in reference.cpp (Eigen's solvers cost seconds per file).
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "pointfair/types.hpp"

namespace pointfair::test::ref {

/// Squared distance summed in coordinate order x, y, z (the k-d tree's order, so ties and
/// near-ties compare the same way).
inline double distance2(const Vec3& a, const Vec3& b) {
  const double dx = a.x() - b.x(), dy = a.y() - b.y(), dz = a.z() - b.z();
  return dx * dx + dy * dy + dz * dz;
}

/// The k nearest other points of point `self` within distance eps (d^2 <= eps^2), ordered by
/// distance, ties by the smaller index. eps = +infinity: no bound.
std::vector<Index> neighbors(std::span<const Vec3> points, std::size_t self, int k,
                             double eps);

/// factor times the median (element n/2 of the sorted list) over all points of the distance
/// to the k-th nearest other point.
double auto_eps(std::span<const Vec3> points, int k, double factor);

struct Frame {
  Vec3 normal;
  Vec3 v1;  ///< tangent eigenvector of the largest eigenvalue
  Vec3 v2;
  double c1 = 0, c2 = 0, c0 = 0;
  Eigen::Matrix3d covariance;
};

/// PCA of {p} ∪ N about the barycentre: covariance (divided by the count) of the explicit
/// centred points, eigen-decomposed with the iterative solver.
Frame frame(const Vec3& p, std::span<const Index> nb, std::span<const Vec3> points);

/// Directional curvature, eq. (2).
inline double kappa(const Vec3& normal, const Vec3& p, const Vec3& q) {
  const Vec3 e = q - p;
  return 2.0 * normal.dot(e) / e.squaredNorm();
}

struct Weingarten {
  Eigen::Matrix3d map = Eigen::Matrix3d::Zero();  ///< sum over t t^T: a tensor of the tangent plane
  double mean = 0;
  double k1 = 0, k2 = 0;
};

/// MATH.md step 4 and 5: weights, normalisation to 2 pi, H, then W; eigenvalues in (v1, v2).
Weingarten weingarten(const Vec3& p, std::span<const Index> nb, std::span<const Vec3> points,
                      const Frame& f, bool paper_weights, double density_floor);

enum class Cut { None, Sharp, Continuous };

inline double cut_weight(double k, double lambda, Cut cut) {
  const double a = std::abs(k);
  if (cut == Cut::None || a < lambda) return 1.0;
  if (cut == Cut::Sharp) return 0.0;
  return lambda * lambda / (lambda * lambda + 10.0 * (a - lambda) * (a - lambda));
}

/// A_i = (1/|N|) sum_j g_ij (p_j - p_i).
inline Vec3 laplacian(const Vec3& p, std::span<const Index> nb, std::span<const Vec3> points,
                      const Vec3& normal, double lambda, Cut cut) {
  Vec3 a = Vec3::Zero();
  for (const Index j : nb) a += cut_weight(kappa(normal, p, points[j]), lambda, cut) * (points[j] - p);
  return a / static_cast<double>(nb.size());
}

/// 0 smooth, 1 edge, 2 corner; quotient_mode: edge quotient, else maximal curvature.
inline int feature_class(double k1, double k2, bool quotient_mode, double q, double threshold) {
  const double big = std::max(std::abs(k1), std::abs(k2));
  const double small = std::min(std::abs(k1), std::abs(k2));
  if (big < threshold || big == 0.0) return 0;
  if (quotient_mode) return small / big < q ? 1 : 2;
  return small >= threshold ? 2 : 1;
}

/// The robust plane (robust_frame.hpp) written out plainly: weighted PCA of p and its `seed`
/// nearest neighbours, then `iterations` passes of Tukey weights (bound times 1.4826 times the
/// median absolute distance, the median being element (m+1)/2 of the sorted distances of the
/// m+1 points) and weighted PCA, all with the iterative eigen solver.
struct Plane {
  Vec3 normal;
  Vec3 centroid;
};
Plane robust_plane(const Vec3& p, std::span<const Index> nb, std::span<const Vec3> points,
                   int seed, int iterations, double bound);

struct StepOptions {
  Cut cut = Cut::Sharp;
  /// The cut-off's curvatures from p's foot on its plane (CutoffOrigin::Plane).
  bool plane_origin = false;
  /// The robust plane (seed 6, 3 passes, bound 3) instead of the PCA plane.
  bool robust = false;
  /// With `robust`: > 0 keeps the PCA plane where its smallest eigenvalue c0 is at most this
  /// times (lambda (c0 + c1 + c2))^2 (RobustFrameParams::gate).
  double robust_gate = 0.0;
  double lambda = 1.0;
  double tau = 0.5;
  bool normal_only = false;
  /// Feature gating with the edge-quotient mode: smooth points use the isotropic Laplacian.
  bool gated = false;
  double quotient = 0.5;
  /// Threshold of the gating's classes: > 0 this turn over the distance to the farthest
  /// neighbour (FeatureScale::Spacing), 0 lambda (FeatureScale::Lambda).
  double feature_turn = 0.0;
  bool paper_weights = true;
  double density_floor = 0.05;
};

/// One Jacobi step: reads `points`, returns the new positions. neighbour lists given per point.
std::vector<Vec3> euler_step(std::span<const Vec3> points,
                             const std::vector<std::vector<Index>>& nbs, const StepOptions& o);

}  // namespace pointfair::test::ref
