#pragma once
// The body of fit_robust_plane (robust_frame.hpp) for up to L points at once: each point runs
// exactly the one-point algorithm (seed plane, whole-neighbourhood fallback, reweighting
// passes), and the normals of all points that need one in the same round come from one
// interleaved iteration (detail::smallest_eigenvalues), so that their long chains of
// dependent square roots and divisions overlap. Every point's plane and weights are the
// one-point result, to the bit. Inlined into the Euler step's kernels; internal: not installed.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <span>

#include "common/select_kth.hpp"
#include "covariance_normal.hpp"
#include "pointfair/frames/robust_frame.hpp"

namespace pointfair::detail {

/// Weighted mean and covariance of {0} ∪ offsets with weights w (w[0] belongs to the zero
/// offset of p itself) into `plane` (normal not set, plane.valid false); false when fewer than
/// 3 points have a positive weight or the total is not positive (`plane` is then left as it was).
[[gnu::always_inline]] inline bool weighted_moments(std::span<const Vec3> offsets,
                                                    std::span<const double> w, RobustPlane& plane) {
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
  if (used < 3 || !(total > 0.0)) return false;
  plane.mean = sum / total;
  plane.covariance << xx, xy, xz, xy, yy, yz, xz, yz, zz;
  plane.covariance /= total;
  plane.covariance -= plane.mean * plane.mean.transpose();
  plane.valid = false;
  return true;
}

/// Tukey's biweight of each residual (absolute values) into `weights`: 0 beyond `inlier_bound`
/// times the robust scale, 1.4826 times the median residual (the element at size / 2 in
/// order), or `floor` when that is larger. `scratch` (the same size) is work space for the
/// median; `weights` may be `residuals` itself.
[[gnu::always_inline]] inline void biweights(std::span<const double> residuals, double inlier_bound, double floor,
                                             std::span<double> weights, std::span<double> scratch) {
  const std::size_t count = residuals.size();
  const double median = select_kth(residuals, count / 2, scratch);
  const double bound = inlier_bound * std::max(1.4826 * median, floor);
  for (std::size_t j = 0; j < count; ++j) {
    const double u = residuals[j] / bound;
    weights[j] = u < 1.0 ? (1.0 - u * u) * (1.0 - u * u) : 0.0;
  }
}

/// Tukey weights of p (slot 0) and its neighbours from their distances to `plane`; `scratch`
/// is work space for the median.
[[gnu::always_inline]] inline void tukey_weights(std::span<const Vec3> offsets, const RobustPlane& plane,
                                                 const RobustFrameParams& params,
                                                 std::span<double> weights, std::span<double> scratch) {
  const std::size_t m = offsets.size();
  const Vec3& n = plane.normal;
  const double origin = n.dot(plane.mean);
  weights[0] = std::abs(origin);
  for (std::size_t j = 0; j < m; ++j) weights[j + 1] = std::abs(n.dot(offsets[j]) - origin);
  // The scale never falls below a tiny fraction of the neighbourhood's extent, so that an
  // exact plane (all distances 0) keeps every point.
  const double extent = std::sqrt(std::max(0.0, plane.covariance.trace()));
  const std::span<double> distances = weights.first(m + 1);
  biweights(distances, params.inlier_bound, 1e-9 * extent, distances, scratch);
}

/// fit_robust_plane of `count` <= L points: offsets[l], weights[l], scratch[l] as there (sizes
/// already checked), the planes into planes[l].
template <std::size_t L>
[[gnu::always_inline]] inline void fit_robust_planes(const std::span<const Vec3>* offsets,
                                                     std::size_t count,
                                                     const RobustFrameParams& params,
                                                     const std::span<double>* weights,
                                                     const std::span<double>* scratch,
                                                     RobustPlane* planes) {
  // Per point: the accepted plane, the candidate being fitted and what it is for.
  enum class Stage { Seed, Whole, Pass, Done };
  Stage stage[L];
  RobustPlane candidate[L];
  bool fitted[L];  // the candidate's moments exist and it waits for its normal
  int pass[L];
  // Starts lane l's next reweighting pass, or ends it.
  const auto next_pass = [&](std::size_t l) {
    if (pass[l] < params.iterations && planes[l].valid) {
      tukey_weights(offsets[l], planes[l], params, weights[l], scratch[l]);
      candidate[l] = RobustPlane{};
      fitted[l] = weighted_moments(offsets[l], weights[l], candidate[l]);
      stage[l] = Stage::Pass;
    } else {
      stage[l] = Stage::Done;
    }
  };
  for (std::size_t l = 0; l < count; ++l) {
    const std::size_t m = offsets[l].size();
    const std::size_t seed = std::min<std::size_t>(m, static_cast<std::size_t>(params.seed_neighbors));
    for (std::size_t j = 0; j <= m; ++j) weights[l][j] = j <= seed ? 1.0 : 0.0;
    planes[l] = RobustPlane{};
    candidate[l] = RobustPlane{};
    fitted[l] = weighted_moments(offsets[l], weights[l], candidate[l]);
    stage[l] = Stage::Seed;
    pass[l] = 0;
  }
  while (true) {
    // The normals of every fitted candidate, their iterations interleaved.
    const SymmetricCovariance* covariances[L] = {};
    SymmetricCovariance coefficients[L];
    std::size_t lane_of[L] = {};
    std::size_t waiting = 0;
    for (std::size_t l = 0; l < count; ++l) {
      if (stage[l] == Stage::Done || !fitted[l]) continue;
      const Eigen::Matrix3d& c = candidate[l].covariance;
      coefficients[waiting] = symmetric_covariance(c(0, 0), c(0, 1), c(0, 2), c(1, 1), c(1, 2), c(2, 2));
      covariances[waiting] = &coefficients[waiting];
      lane_of[waiting] = l;
      ++waiting;
    }
    double c0[L];
    smallest_eigenvalues<L>(covariances, waiting, c0);
    for (std::size_t i = 0; i < waiting; ++i) {
      const std::size_t l = lane_of[i];
      const NormalEstimate estimate = normal_from_smallest_eigenvalue(coefficients[i], c0[i]);
      candidate[l].normal = estimate.normal;
      candidate[l].valid = estimate.valid;
    }
    bool any = false;
    for (std::size_t l = 0; l < count; ++l) {
      switch (stage[l]) {
        case Stage::Seed:
          if (candidate[l].valid) {
            planes[l] = candidate[l];
            next_pass(l);
          } else {
            // Too few or degenerate seed points: start from the whole neighbourhood.
            std::fill(weights[l].begin(), weights[l].end(), 1.0);
            candidate[l] = RobustPlane{};
            fitted[l] = weighted_moments(offsets[l], weights[l], candidate[l]);
            stage[l] = Stage::Whole;
          }
          break;
        case Stage::Whole:
          planes[l] = candidate[l];
          next_pass(l);
          break;
        case Stage::Pass:
          if (!candidate[l].valid) {
            stage[l] = Stage::Done;
          } else {
            planes[l] = candidate[l];
            ++pass[l];
            next_pass(l);
          }
          break;
        case Stage::Done:
          break;
      }
      any |= stage[l] != Stage::Done;
    }
    if (!any) break;
  }
  for (std::size_t l = 0; l < count; ++l)
    if (offsets[l].size() < 2) planes[l].valid = false;
}

}  // namespace pointfair::detail
