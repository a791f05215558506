#include "pointfair/robust_frame.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "pointfair/params_error.hpp"

namespace pointfair {

void RobustFrameParams::validate() const {
  require(seed_neighbors >= 2 && seed_neighbors <= 1024,
          "robust seed neighbours must be in 2..1024, got " + std::to_string(seed_neighbors));
  require(iterations >= 0 && iterations <= 100,
          "robust iterations must be in 0..100, got " + std::to_string(iterations));
  require(inlier_bound > 0.0 && std::isfinite(inlier_bound),
          "robust inlier bound must be positive, got " + std::to_string(inlier_bound));
}

namespace {

// Weighted PCA of {0} ∪ offsets with weights w (w[0] belongs to the zero offset of p itself).
RobustPlane weighted_plane(std::span<const Vec3> offsets, std::span<const double> w) {
  RobustPlane plane;
  double total = w[0];
  Vec3 sum = Vec3::Zero();
  double xx = 0, xy = 0, xz = 0, yy = 0, yz = 0, zz = 0;
  int used = w[0] > 0.0 ? 1 : 0;
  for (std::size_t j = 0; j < offsets.size(); ++j) {
    const double wj = w[j + 1];
    if (wj <= 0.0) continue;
    const Vec3& v = offsets[j];
    total += wj;
    sum += wj * v;
    xx += wj * v.x() * v.x();
    xy += wj * v.x() * v.y();
    xz += wj * v.x() * v.z();
    yy += wj * v.y() * v.y();
    yz += wj * v.y() * v.z();
    zz += wj * v.z() * v.z();
    ++used;
  }
  if (used < 3 || !(total > 0.0)) return plane;
  plane.mean = sum / total;
  plane.covariance << xx, xy, xz, xy, yy, yz, xz, yz, zz;
  plane.covariance /= total;
  plane.covariance -= plane.mean * plane.mean.transpose();
  const NormalEstimate estimate = normal_from_covariance(plane.covariance);
  plane.normal = estimate.normal;
  plane.valid = estimate.valid;
  return plane;
}

}  // namespace

RobustPlane fit_robust_plane(std::span<const Vec3> offsets, const RobustFrameParams& params,
                             std::span<double> weights, std::span<double> scratch) {
  const std::size_t m = offsets.size();
  require(weights.size() == m + 1 && scratch.size() == m + 1,
          "fit_robust_plane: weights and scratch need one slot per point and one for p");
  const std::size_t seed = std::min<std::size_t>(m, static_cast<std::size_t>(params.seed_neighbors));
  for (std::size_t j = 0; j <= m; ++j) weights[j] = j <= seed ? 1.0 : 0.0;
  RobustPlane plane = weighted_plane(offsets, weights);
  if (!plane.valid) {
    // Too few or degenerate seed points: start from the whole neighbourhood.
    std::fill(weights.begin(), weights.end(), 1.0);
    plane = weighted_plane(offsets, weights);
  }
  for (int it = 0; it < params.iterations && plane.valid; ++it) {
    const Vec3& n = plane.normal;
    const double origin = n.dot(plane.mean);
    scratch[0] = std::abs(origin);
    for (std::size_t j = 0; j < m; ++j) scratch[j + 1] = std::abs(n.dot(offsets[j]) - origin);
    // The distances are kept in `weights` while the median is taken in place in `scratch`.
    for (std::size_t j = 0; j <= m; ++j) weights[j] = scratch[j];
    const auto mid = scratch.begin() + static_cast<std::ptrdiff_t>((m + 1) / 2);
    std::nth_element(scratch.begin(), mid, scratch.end());
    // The scale never falls below a tiny fraction of the neighbourhood's extent, so that an
    // exact plane (all distances 0) keeps every point.
    const double extent = std::sqrt(std::max(0.0, plane.covariance.trace()));
    const double bound = params.inlier_bound * std::max(1.4826 * *mid, 1e-9 * extent);
    for (std::size_t j = 0; j <= m; ++j) {
      const double u = weights[j] / bound;
      weights[j] = u < 1.0 ? (1.0 - u * u) * (1.0 - u * u) : 0.0;
    }
    const RobustPlane refit = weighted_plane(offsets, weights);
    if (!refit.valid) break;
    plane = refit;
  }
  if (m < 2) plane.valid = false;
  return plane;
}

Frame compute_robust_frame(const Vec3& p, std::span<const Index> neighbors,
                           std::span<const Vec3> points, const RobustFrameParams& params) {
  const std::size_t m = neighbors.size();
  std::vector<Vec3> offsets(m);
  for (std::size_t j = 0; j < m; ++j) offsets[j] = points[neighbors[j]] - p;
  std::vector<double> weights(m + 1), scratch(m + 1);
  const RobustPlane plane = fit_robust_plane(offsets, params, weights, scratch);
  if (!plane.valid) {
    Frame invalid;
    invalid.centroid = p;
    return invalid;
  }
  Frame f = frame_from_covariance(plane.covariance, p + plane.mean);
  // The frame's normal is the plane's (the two solvers agree to rounding; the step's fast path
  // reads the plane's).
  f.normal = plane.normal;
  f.t2 = f.normal.cross(f.t1).normalized();
  f.t1 = f.t2.cross(f.normal);
  f.valid = true;
  return f;
}

}  // namespace pointfair
