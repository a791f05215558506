#pragma once
// The body of normal_from_covariance (frame.hpp), inlined into the Euler step's kernels so that
// the covariance stays in registers and the AVX2 kernel compiles it with AVX encodings (the
// same operations, so the same bits). Internal: not installed.
#include <algorithm>
#include <cmath>
#include <cstddef>

#include "pointfair/frames/frame.hpp"

namespace pointfair::detail {

/// A symmetric 3x3 matrix by its upper triangle, and the coefficients of its characteristic
/// polynomial det(A - tI) = det - m2 t + tr t^2 - t^3 (m2: the sum of the principal 2x2 minors).
struct SymmetricCovariance {
  double a00 = 0.0, a01 = 0.0, a02 = 0.0, a11 = 0.0, a12 = 0.0, a22 = 0.0;
  double tr = 0.0, m2 = 0.0, det = 0.0;
};

[[gnu::always_inline]] inline SymmetricCovariance symmetric_covariance(double a00, double a01,
                                                                      double a02, double a11,
                                                                      double a12, double a22) {
  // The iteration and the normal below form products of up to four entries (slope^2 ~ trace^4,
  // the rows' cross products squared): far from 1 they overflow (coordinates around 1e40 gave
  // zero normals counted as valid) or underflow. A trace outside [2^-200, 2^200] is brought to
  // about 1 by a power of two, which is exact and changes no direction; within it, nothing
  // changes (the same bits as before).
  const double trace = a00 + a11 + a22;
  if (trace > 0.0 && std::isfinite(trace) && (trace > 0x1p200 || trace < 0x1p-200)) {
    const double scale = std::ldexp(1.0, -std::ilogb(trace));
    a00 *= scale;
    a01 *= scale;
    a02 *= scale;
    a11 *= scale;
    a12 *= scale;
    a22 *= scale;
  }
  SymmetricCovariance c{a00, a01, a02, a11, a12, a22};
  c.tr = a00 + a11 + a22;
  c.m2 = (a00 * a11 - a01 * a01) + (a00 * a22 - a02 * a02) + (a11 * a22 - a12 * a12);
  c.det = a00 * (a11 * a22 - a12 * a12) - a01 * (a01 * a22 - a12 * a02) +
          a02 * (a01 * a12 - a11 * a02);
  return c;
}

// The characteristic polynomial is positive, decreasing and convex left of the smallest
// eigenvalue c0 of a positive semi-definite A, so Newton's method from t = 0 climbs to c0
// without overshooting. No trigonometry (acos and two cos cost more than the whole
// iteration), no scaling (every test below is relative), and c0 comes out to a few ulps of
// itself, where the trigonometric form q + 2p cos(..) loses digits to cancellation when
// c0 << c1.
//
// Laguerre's method: for a polynomial with only real roots it converges monotonically to the
// nearest root from any start, cubically near it, and from far away it takes much larger
// steps than Newton's: two or three steps here where Newton's takes seven. A (nearly)
// repeated c0 converges slowly and is sent to the fallback anyway, so 64 steps bound the
// cost. With p = det(A - tI) of degree 3 the step is
//   3 p / (p' - sqrt(2 (2 p'^2 - 3 p p''))).
//
// One step of the iteration for `a` from c0; false once it has stopped (c0 is then final).
[[gnu::always_inline]] inline bool laguerre_step(const SymmetricCovariance& a, double& c0) {
  const double tr = a.tr, m2 = a.m2, det = a.det;
  const double f = ((tr - c0) * c0 - m2) * c0 + det;
  const double slope = (2.0 * tr - 3.0 * c0) * c0 - m2;
  const double bend = 2.0 * tr - 6.0 * c0;
  if (!(slope < 0.0)) return false;
  const double root = std::sqrt(std::max(0.0, 2.0 * (2.0 * slope * slope - 3.0 * f * bend)));
  const double next = c0 - 3.0 * f / (slope - root);
  if (!(next > c0)) return false;  // converged: rounding noise no longer moves it up
  c0 = next;
  return true;
}

/// The smallest eigenvalues c0 of `count` (at most L) matrices at once: the same iteration
/// as for one, each lane on its own, interleaved so that the lanes' long chains of dependent
/// divisions and square roots overlap. Every lane's result is the one-matrix result, to the bit.
template <std::size_t L>
[[gnu::always_inline]] inline void smallest_eigenvalues(const SymmetricCovariance* const* a,
                                                        std::size_t count, double* c0) {
  bool running[L];
  for (std::size_t l = 0; l < L; ++l) {
    c0[l] = 0.0;
    running[l] = l < count;
  }
  for (int iteration = 0; iteration < 64; ++iteration) {
    bool any = false;
    for (std::size_t l = 0; l < L; ++l) {
      if (running[l]) running[l] = laguerre_step(*a[l], c0[l]);
      any |= running[l];
    }
    if (!any) break;
  }
}

/// The normal of `a` given its smallest eigenvalue c0 (from smallest_eigenvalues), or the
/// fallback (frame_from_covariance) where that is not accurate.
[[gnu::always_inline]] inline NormalEstimate normal_from_smallest_eigenvalue(
    const SymmetricCovariance& a, double c0) {
  const auto fallback = [&a] {
    Eigen::Matrix3d covariance;
    covariance << a.a00, a.a01, a.a02, a.a01, a.a11, a.a12, a.a02, a.a12, a.a22;
    const Frame f = frame_from_covariance(covariance, Vec3::Zero());
    return NormalEstimate{f.normal, f.valid};
  };
  const double tr = a.tr, m2 = a.m2;
  if (!(tr > 0.0) || !std::isfinite(tr)) return fallback();
  // The other two eigenvalues: c1 + c2 = tr - c0 and c1 c2 = m2 - c0 (c1 + c2).
  const double s = tr - c0;
  const double product = m2 - c0 * s;
  const double root = std::sqrt(std::max(0.0, s * s - 4.0 * product));
  const double c1 = 0.5 * (s + root);
  const double c2 = 0.5 * (s - root);
  if (!(c2 - c0 > 1e-4 * c1) || !(c2 > 1e-6 * c1)) return fallback();
  // The rows of a - c0 I span the plane orthogonal to the normal: the largest cross product of
  // two of them is the most accurate normal direction.
  const Vec3 r0(a.a00 - c0, a.a01, a.a02);
  const Vec3 r1(a.a01, a.a11 - c0, a.a12);
  const Vec3 r2(a.a02, a.a12, a.a22 - c0);
  const Vec3 x01 = r0.cross(r1), x02 = r0.cross(r2), x12 = r1.cross(r2);
  const double n01 = x01.squaredNorm(), n02 = x02.squaredNorm(), n12 = x12.squaredNorm();
  const Vec3& best = n01 >= n02 ? (n01 >= n12 ? x01 : x12) : (n02 >= n12 ? x02 : x12);
  const double best_norm2 = std::max(n01, std::max(n02, n12));
  if (!(best_norm2 > 0.0)) return fallback();
  return NormalEstimate{best / std::sqrt(best_norm2), true};
}

/// normal_from_covariance of the symmetric matrix with upper triangle a00 a01 a02 / a11 a12 / a22.
[[gnu::always_inline]] inline NormalEstimate covariance_normal(double a00, double a01, double a02,
                                                              double a11, double a12, double a22) {
  const SymmetricCovariance a = symmetric_covariance(a00, a01, a02, a11, a12, a22);
  double c0 = 0.0;
  // (A matrix that goes to the fallback need not iterate.)
  const SymmetricCovariance* one = &a;
  if (a.tr > 0.0 && std::isfinite(a.tr)) smallest_eigenvalues<1>(&one, 1, &c0);
  return normal_from_smallest_eigenvalue(a, c0);
}

}  // namespace pointfair::detail
