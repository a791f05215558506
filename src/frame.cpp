#include "pointfair/frame.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

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
  const auto fallback = [&covariance] {
    const Frame f = frame_from_covariance(covariance, Vec3::Zero());
    return NormalEstimate{f.normal, f.valid};
  };
  const double a00 = covariance(0, 0), a01 = covariance(0, 1), a02 = covariance(0, 2);
  const double a11 = covariance(1, 1), a12 = covariance(1, 2), a22 = covariance(2, 2);
  // The characteristic polynomial det(A - tI) = det - m2 t + tr t^2 - t^3 (m2: the sum of the
  // principal 2x2 minors) is positive, decreasing and convex left of the smallest eigenvalue
  // c0 of a positive semi-definite A, so Newton's method from t = 0 climbs to c0 without
  // overshooting. No trigonometry (acos and two cos cost more than the whole iteration), no
  // scaling (every test below is relative), and c0 comes out to a few ulps of itself, where
  // the trigonometric form q + 2p cos(..) loses digits to cancellation when c0 << c1.
  const double tr = a00 + a11 + a22;
  if (!(tr > 0.0) || !std::isfinite(tr)) return fallback();
  const double m2 = (a00 * a11 - a01 * a01) + (a00 * a22 - a02 * a02) + (a11 * a22 - a12 * a12);
  const double det = a00 * (a11 * a22 - a12 * a12) - a01 * (a01 * a22 - a12 * a02) +
                     a02 * (a01 * a12 - a11 * a02);
  double c0 = 0.0;
  // Laguerre's method: for a polynomial with only real roots it converges monotonically to
  // the nearest root from any start, cubically near it, and from far away it takes much
  // larger steps than Newton's: two or three steps here where Newton's takes seven. A
  // (nearly) repeated c0 converges slowly and is sent to the fallback below anyway, so 64
  // steps bound the cost. With p = det(A - tI) of degree 3 the step is
  //   3 p / (p' - sqrt(2 (2 p'^2 - 3 p p''))).
  for (int iteration = 0; iteration < 64; ++iteration) {
    const double f = ((tr - c0) * c0 - m2) * c0 + det;
    const double slope = (2.0 * tr - 3.0 * c0) * c0 - m2;
    const double bend = 2.0 * tr - 6.0 * c0;
    if (!(slope < 0.0)) break;
    const double root = std::sqrt(std::max(0.0, 2.0 * (2.0 * slope * slope - 3.0 * f * bend)));
    const double next = c0 - 3.0 * f / (slope - root);
    if (!(next > c0)) break;  // converged: rounding noise no longer moves it up
    c0 = next;
  }
  // The other two eigenvalues: c1 + c2 = tr - c0 and c1 c2 = m2 - c0 (c1 + c2).
  const double s = tr - c0;
  const double product = m2 - c0 * s;
  const double root = std::sqrt(std::max(0.0, s * s - 4.0 * product));
  const double c1 = 0.5 * (s + root);
  const double c2 = 0.5 * (s - root);
  if (!(c2 - c0 > 1e-4 * c1) || !(c2 > 1e-6 * c1)) return fallback();
  // The rows of a - c0 I span the plane orthogonal to the normal: the largest cross product of
  // two of them is the most accurate normal direction.
  const Vec3 r0(a00 - c0, a01, a02);
  const Vec3 r1(a01, a11 - c0, a12);
  const Vec3 r2(a02, a12, a22 - c0);
  const Vec3 x01 = r0.cross(r1), x02 = r0.cross(r2), x12 = r1.cross(r2);
  const double n01 = x01.squaredNorm(), n02 = x02.squaredNorm(), n12 = x12.squaredNorm();
  const Vec3& best = n01 >= n02 ? (n01 >= n12 ? x01 : x12) : (n02 >= n12 ? x02 : x12);
  const double best_norm2 = std::max(n01, std::max(n02, n12));
  if (!(best_norm2 > 0.0)) return fallback();
  return NormalEstimate{best / std::sqrt(best_norm2), true};
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
