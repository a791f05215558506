#include "pointfair/frames/robust_frame.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "pointfair/common/params_error.hpp"
#include "robust_plane_fit.hpp"

namespace pointfair {

void RobustFrameParams::validate() const {
  require(seed_neighbors >= 2 && seed_neighbors <= 1024,
          "robust seed neighbours must be in 2..1024, got " + std::to_string(seed_neighbors));
  require(iterations >= 0 && iterations <= 100,
          "robust iterations must be in 0..100, got " + std::to_string(iterations));
  require(inlier_bound > 0.0 && std::isfinite(inlier_bound),
          "robust inlier bound must be positive, got " + std::to_string(inlier_bound));
  require(gate >= 0.0 && std::isfinite(gate), "robust gate must be >= 0 (0 = everywhere), got " + std::to_string(gate));
}

RobustPlane fit_robust_plane(std::span<const Vec3> offsets, const RobustFrameParams& params,
                             std::span<double> weights, std::span<double> scratch) {
  const std::size_t m = offsets.size();
  require(weights.size() == m + 1 && scratch.size() == m + 1,
          "fit_robust_plane: weights and scratch need one slot per point and one for p");
  // The step's kernels run the same code for four points at a time (robust_plane_fit.hpp).
  RobustPlane plane;
  detail::fit_robust_planes<1>(&offsets, 1, params, &weights, &scratch, &plane);
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
