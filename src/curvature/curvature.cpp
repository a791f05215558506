#include "pointfair/curvature/curvature.hpp"

#include <cmath>
#include <numbers>
#include <string>

#include "pointfair/common/params_error.hpp"

namespace pointfair {

void WeingartenParams::validate() const {
  require(density_floor > 0.0 && density_floor <= 1.0,
          "density floor must be in (0, 1], got " + std::to_string(density_floor));
}

double Curvature::max_abs() const { return std::max(std::abs(k1), std::abs(k2)); }
double Curvature::min_abs() const { return std::min(std::abs(k1), std::abs(k2)); }

WeingartenMap weingarten_map(const Vec3& p, const Frame& frame, std::span<const Index> neighbors,
                             std::span<const Vec3> points, const WeingartenParams& params) {
  WeingartenMap result;
  if (!frame.valid) return result;
  const double trace = frame.c1 + frame.c2;
  const double floor = params.density_floor * trace;
  // First pass: raw weights, sum of weights, weighted kappa (H needs the normalised weights,
  // and W needs H, so the terms are accumulated separately and combined at the end:
  //   W = (1/pi) s (2 S_kt - H S_t) with S_kt = sum w kappa t t^T, S_t = sum w t t^T,
  //   s = 2 pi / sum w the normalisation, H = s sum w kappa / (2 pi).)
  double sum_w = 0.0;
  double sum_wk = 0.0;
  Eigen::Matrix2d s_kt = Eigen::Matrix2d::Zero();
  Eigen::Matrix2d s_t = Eigen::Matrix2d::Zero();
  for (const Index j : neighbors) {
    const Vec3 d = points[j] - p;
    const double x = d.dot(frame.t1);
    const double y = d.dot(frame.t2);
    const double tangential = std::sqrt(x * x + y * y);
    if (!(tangential > 0.0)) continue;
    const double tx = x / tangential;
    const double ty = y / tangential;
    const double len2 = d.squaredNorm();
    const double kappa = 2.0 * frame.normal.dot(d) / len2;
    double w = 1.0;
    if (params.weights == AngularWeights::Paper) {
      const double delta = 2.0 * (frame.c1 * tx * tx + frame.c2 * ty * ty) - 0.5 * trace;
      w = std::sqrt(len2) / std::max(delta, floor);
    }
    Eigen::Matrix2d tt;
    tt << tx * tx, tx * ty, tx * ty, ty * ty;
    sum_w += w;
    sum_wk += w * kappa;
    s_kt += (w * kappa) * tt;
    s_t += w * tt;
  }
  // Weights that overflow (a density floor near the smallest double, e.g. 1e-310, under a
  // direction of zero density) leave no usable map: the point is degenerate, never NaN.
  if (!(sum_w > 0.0) || !std::isfinite(sum_w) || !std::isfinite(sum_wk)) return result;
  const double two_pi = 2.0 * std::numbers::pi;
  const double s = two_pi / sum_w;
  result.mean = s * sum_wk / two_pi;
  result.map = (s / std::numbers::pi) * (2.0 * s_kt - result.mean * s_t);
  if (!std::isfinite(result.mean) || !result.map.allFinite()) return WeingartenMap{};
  result.valid = true;
  return result;
}

Curvature principal_curvatures(const WeingartenMap& w, const Frame& frame) {
  Curvature c;
  if (!w.valid) return c;
  // Closed-form eigenpairs of the symmetric 2x2 matrix [a b; b d].
  const double a = w.map(0, 0);
  const double b = 0.5 * (w.map(0, 1) + w.map(1, 0));
  const double d = w.map(1, 1);
  const double half_trace = 0.5 * (a + d);
  const double radius = std::hypot(0.5 * (a - d), b);
  c.k1 = half_trace + radius;
  c.k2 = half_trace - radius;
  c.mean = 0.5 * (c.k1 + c.k2);
  // Angle of the first eigenvector: tan(2 phi) = 2b / (a - d).
  const double phi = 0.5 * std::atan2(2.0 * b, a - d);
  c.d1 = std::cos(phi) * frame.t1 + std::sin(phi) * frame.t2;
  c.d2 = frame.normal.cross(c.d1);
  c.valid = true;
  return c;
}

Curvature compute_curvature(const Vec3& p, const Frame& frame, std::span<const Index> neighbors,
                            std::span<const Vec3> points, const WeingartenParams& params) {
  return principal_curvatures(weingarten_map(p, frame, neighbors, points, params), frame);
}

}  // namespace pointfair
