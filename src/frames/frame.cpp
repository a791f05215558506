#include "pointfair/frames/frame.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "covariance_normal.hpp"

namespace pointfair {

Frame frame_from_covariance(const Eigen::Matrix3d& covariance, const Vec3& centroid) {
  Frame f;
  f.centroid = centroid;
  const double scale = covariance.cwiseAbs().maxCoeff();
  if (!(scale > 0.0) || !std::isfinite(scale)) return f;
  // The closed-form solver is fast and accurate for a well-separated eigenvalue, but it loses
  // half the digits where two eigenvalues (nearly) coincide: errors ~ sqrt(eps) c1, so a line
  // (c2 = c0 = 0) came out with c2 ~ 1e-8 c1 and passed for a plane, and a symmetric ring got
  // c1 != c2. So only the eigenvector of the most separated eigenvalue is taken from it; the
  // other two are re-solved as the 2x2 block of the covariance in the plane orthogonal to it,
  // in closed form with hypot, which is accurate to a few ulps of c1.
  const Eigen::Matrix3d m = covariance / scale;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(m);
  const auto& values = solver.eigenvalues();  // ascending
  const auto& vectors = solver.eigenvectors();
  // Eigenpairs (larger first) of m restricted to the plane orthogonal to the unit vector
  // `axis`; `seed` is any vector not parallel to it.
  const auto solve_plane = [&m](const Vec3& axis, const Vec3& seed, Vec3& big, Vec3& small,
                                double& c_big, double& c_small) {
    const Vec3 u = (seed - seed.dot(axis) * axis).normalized();
    const Vec3 w = axis.cross(u);
    const double a = u.dot(m * u), b = u.dot(m * w), d = w.dot(m * w);
    const double half_trace = 0.5 * (a + d);
    const double radius = std::hypot(0.5 * (a - d), b);
    const double phi = 0.5 * std::atan2(2.0 * b, a - d);
    big = std::cos(phi) * u + std::sin(phi) * w;
    small = axis.cross(big);
    c_big = half_trace + radius;
    c_small = half_trace - radius;
  };
  double c1 = 0.0, c2 = 0.0, c0 = 0.0;
  if (values[2] - values[1] > values[1] - values[0]) {
    // c1 stands apart (a line-like or degenerate neighbourhood): t1 first.
    f.t1 = vectors.col(2).normalized();
    Vec3 t2, normal;
    solve_plane(f.t1, vectors.col(1), t2, normal, c2, c0);
    f.normal = normal;
    c1 = f.t1.dot(m * f.t1);
  } else {
    // c0 stands apart (a surface sample): the normal first.
    f.normal = vectors.col(0).normalized();
    Vec3 t1, t2;
    solve_plane(f.normal, vectors.col(2), t1, t2, c1, c2);
    f.t1 = t1;
    c0 = f.normal.dot(m * f.normal);
  }
  f.c1 = std::max(0.0, c1) * scale;
  f.c2 = std::min(std::max(0.0, c2) * scale, f.c1);
  f.c0 = std::min(std::max(0.0, c0) * scale, f.c2);
  // Right-handed and exactly orthogonal.
  f.t2 = f.normal.cross(f.t1).normalized();
  f.t1 = f.t2.cross(f.normal);
  // A plane needs two tangential directions with spread.
  f.valid = f.c2 > 1e-12 * f.c1;
  return f;
}

NormalEstimate normal_from_covariance(const Eigen::Matrix3d& covariance) {
  return detail::covariance_normal(covariance(0, 0), covariance(0, 1), covariance(0, 2),
                                   covariance(1, 1), covariance(1, 2), covariance(2, 2));
}

Frame compute_frame(const Vec3& p, std::span<const Index> neighbors, std::span<const Vec3> points) {
  // Sums of d = q - p over {p} ∪ N (d = 0 for p itself contributes nothing but the count).
  Vec3 sum = Vec3::Zero();
  Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
  for (const Index j : neighbors) {
    const Vec3 d = points[j] - p;
    sum += d;
    outer.noalias() += d * d.transpose();
  }
  const double n = static_cast<double>(neighbors.size() + 1);
  const Vec3 mean = sum / n;
  const Eigen::Matrix3d covariance = outer / n - mean * mean.transpose();
  Frame f = frame_from_covariance(covariance, p + mean);
  if (neighbors.size() < 2) f.valid = false;
  return f;
}

}  // namespace pointfair
