#include "pointfair/euler_step.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <limits>
#include <cmath>
#include <string>
#include <vector>

#include "pointfair/parallel.hpp"
#include "pointfair/params_error.hpp"

namespace pointfair {

void FlowParams::validate() const {
  require(lambda >= 0.0 && std::isfinite(lambda),
          "lambda must be >= 0 (0 = automatic), got " + std::to_string(lambda));
  require(lambda_auto_factor > 0.0 && std::isfinite(lambda_auto_factor),
          "lambda auto factor must be positive, got " + std::to_string(lambda_auto_factor));
  require(tau > 0.0 && tau <= 1.0, "tau must be in (0, 1], got " + std::to_string(tau));
  features.validate();
  weingarten.validate();
}

PointState evaluate_point(const Vec3& p, std::span<const Index> neighbors,
                          std::span<const Vec3> points, const FlowParams& params, double lambda,
                          bool with_curvature) {
  PointState s;
  if (neighbors.empty()) return s;
  s.frame = compute_frame(p, neighbors, points);
  const bool needs_frame = params.flow == Flow::Anisotropic || params.constrain_normal ||
                           params.feature_gated || with_curvature;
  if (needs_frame && !s.frame.valid) return s;
  s.valid = true;

  const bool gated = params.feature_gated && params.features.mode != FeatureMode::None;
  if (with_curvature || gated) {
    s.curvature = compute_curvature(p, s.frame, neighbors, points, params.weingarten);
    const double threshold = params.features.threshold > 0.0 ? params.features.threshold : lambda;
    s.feature = classify_feature(s.curvature, params.features.mode, params.features.quotient,
                                 threshold);
  }
  Flow flow = params.flow;
  if (gated && s.feature == FeatureClass::Smooth) flow = Flow::Isotropic;
  // CutoffOrigin::Plane: the foot of p on the PCA plane, at height <n, c - p> along n.
  const double origin_height = params.cutoff_origin == CutoffOrigin::Plane
                                   ? s.frame.normal.dot(s.frame.centroid - p)
                                   : 0.0;
  s.laplacian = laplacian(p, s.frame.normal, neighbors, points,
                          {flow, params.cutoff, lambda, origin_height});
  s.displacement = params.constrain_normal
                       ? Vec3(params.tau * s.laplacian.dot(s.frame.normal) * s.frame.normal)
                       : Vec3(params.tau * s.laplacian);
  return s;
}

namespace {

// The step's hot path: one pass gathers the neighbour offsets into a small local array, the
// covariance comes from that array, and the cut-off pass reads it again from cache. Same
// formulas as evaluate_point (which the tests hold it against); evaluate_point is used where
// the curvature is needed (feature gating) or the neighbourhood is unusually large.
constexpr std::size_t kLocalNeighbors = 64;

struct Displacement {
  Vec3 value = Vec3::Zero();
  bool valid = false;
};

Displacement fast_displacement(const Vec3& p, std::span<const Index> neighbors,
                               std::span<const Vec3> points, const FlowParams& params,
                               double lambda) {
  Displacement out;
  const std::size_t m = neighbors.size();
  if (m == 0) return out;
  std::array<Vec3, kLocalNeighbors> d;
  Vec3 sum = Vec3::Zero();
  for (std::size_t j = 0; j < m; ++j) {
    d[j] = points[neighbors[j]] - p;
    sum += d[j];
  }
  const double inv_m = 1.0 / static_cast<double>(m);
  if (params.flow == Flow::Isotropic && !params.constrain_normal) {
    // The umbrella operator needs no frame.
    out.value = params.tau * (sum * inv_m);
    out.valid = true;
    return out;
  }
  double xx = 0, xy = 0, xz = 0, yy = 0, yz = 0, zz = 0;
  for (std::size_t j = 0; j < m; ++j) {
    const Vec3& v = d[j];
    xx += v.x() * v.x();
    xy += v.x() * v.y();
    xz += v.x() * v.z();
    yy += v.y() * v.y();
    yz += v.y() * v.z();
    zz += v.z() * v.z();
  }
  const double count = static_cast<double>(m + 1);
  const Vec3 mean = sum / count;
  Eigen::Matrix3d covariance;
  covariance << xx / count, xy / count, xz / count,  //
      xy / count, yy / count, yz / count,            //
      xz / count, yz / count, zz / count;
  covariance -= mean * mean.transpose();
  const NormalEstimate estimate = normal_from_covariance(covariance);
  if (!estimate.valid || m < 2) return out;
  const Vec3& n = estimate.normal;
  Vec3 a = Vec3::Zero();
  if (params.flow == Flow::Isotropic) {
    a = sum;
  } else {
    // The origin of the cut-off's curvatures relative to p (CutoffOrigin): p itself, or its
    // foot on the PCA plane through the barycentre p + mean.
    const Vec3 shift = params.cutoff_origin == CutoffOrigin::Plane ? Vec3(n.dot(mean) * n)
                                                                   : Vec3(Vec3::Zero());
    for (std::size_t j = 0; j < m; ++j) {
      // |kappa| < lambda  <=>  2 |<n, d>| < lambda |d|^2: the kept neighbours need no division.
      const Vec3 e = d[j] - shift;
      const double len2 = e.squaredNorm();
      const double twice_nd = 2.0 * std::abs(n.dot(e));
      if (twice_nd < lambda * len2 || len2 == 0.0) {
        a += d[j];
      } else if (params.cutoff == Cutoff::Continuous) {
        a += cutoff_weight(twice_nd / len2, lambda, Cutoff::Continuous) * d[j];
      }
    }
  }
  a *= inv_m;
  out.value = params.constrain_normal ? Vec3(params.tau * a.dot(n) * n) : Vec3(params.tau * a);
  out.valid = true;
  return out;
}

}  // namespace

StepStats euler_step(std::span<const Vec3> current, const Neighborhoods& neighborhoods,
                     std::span<const Index> rows, const FlowParams& params, double lambda,
                     std::span<Vec3> next) {
  const std::size_t n = neighborhoods.size();
  require(next.size() == n, "euler_step: next must hold one position per neighbourhood row");
  require(rows.empty() || rows.size() == n, "euler_step: rows must match the neighbourhoods");
  require(!rows.empty() || current.size() == n, "euler_step: one neighbourhood row per point");
  std::atomic<std::size_t> degenerate_total{0};
  const bool use_fast_path = !(params.feature_gated && params.features.mode != FeatureMode::None);
  parallel_for(n, [&](std::size_t begin, std::size_t end) {
    std::size_t degenerate = 0;
    for (std::size_t r = begin; r < end; ++r) {
      const Vec3& p = current[rows.empty() ? r : rows[r]];
      const auto nb = neighborhoods.of(r);
      if (use_fast_path && nb.size() <= kLocalNeighbors) {
        const Displacement d = fast_displacement(p, nb, current, params, lambda);
        if (!d.valid) ++degenerate;
        next[r] = p + d.value;
      } else {
        const PointState s = evaluate_point(p, nb, current, params, lambda, false);
        if (!s.valid) ++degenerate;
        next[r] = p + s.displacement;
      }
    }
    degenerate_total.fetch_add(degenerate, std::memory_order_relaxed);
  }, 2048);
  return StepStats{degenerate_total.load()};
}

double auto_lambda(std::span<const Vec3> points, const Neighborhoods& neighborhoods, double factor,
                   std::span<const Index> row_of) {
  const std::size_t n = neighborhoods.size();
  if (n == 0) return 1.0;
  // An evenly strided sample of about 8192 points: the median of that many values is within
  // about 1% of the full one, and measuring it before every step then costs a few percent of
  // a step on large clouds. The sample depends only on n, so it is the same for any tiling.
  const std::size_t stride = std::max<std::size_t>(1, n / 8192);
  const std::size_t samples = (n + stride - 1) / stride;
  std::vector<double> medians(samples, -1.0);
  parallel_for(samples, [&](std::size_t begin, std::size_t end) {
    for (std::size_t s = begin; s < end; ++s) {
      const std::size_t i = row_of.empty() ? s * stride : row_of[s * stride];
      medians[s] = median_abs_curvature(points[i], neighborhoods.of(i), points);
    }
  }, 256);
  return lambda_from_medians(std::move(medians), factor);
}

double median_abs_curvature(const Vec3& p, std::span<const Index> neighbors, std::span<const Vec3> points) {
  const Frame f = compute_frame(p, neighbors, points);
  if (!f.valid) return -1.0;
  std::vector<double> kappas(neighbors.size());
  for (std::size_t j = 0; j < neighbors.size(); ++j)
    kappas[j] = std::abs(directional_curvature(f.normal, points[neighbors[j]] - p));
  const auto mid = kappas.begin() + static_cast<std::ptrdiff_t>(kappas.size() / 2);
  std::nth_element(kappas.begin(), mid, kappas.end());
  return *mid;
}

double lambda_from_medians(std::vector<double> medians, double factor) {
  std::erase_if(medians, [](double m) { return m < 0.0; });
  if (medians.empty()) return 1.0;
  auto mid = medians.begin() + static_cast<std::ptrdiff_t>(medians.size() / 2);
  std::nth_element(medians.begin(), mid, medians.end());
  // A flat cloud has median 0: no neighbour is then cut off (the flow is isotropic).
  const double m = *mid;
  return m > 0.0 ? factor * m : std::numeric_limits<double>::max();
}

double resolve_lambda(std::span<const Vec3> points, const Neighborhoods& neighborhoods,
                      const FlowParams& params) {
  params.validate();
  return params.lambda > 0.0 ? params.lambda
                             : auto_lambda(points, neighborhoods, params.lambda_auto_factor);
}

}  // namespace pointfair
