#pragma once
// Plain reference implementations of the method, written straight from MATH.md with separate
// loops and no code shared with the library: brute-force neighbourhoods, the frame from an
// explicit covariance about the barycentre (Eigen's iterative solver), directional
// curvatures, the Weingarten map as a 3x3 tangent tensor (weights, then H, then W), the
// Laplacian with its cut-offs, feature classes and one Euler step.
//
// They are slow and simple on purpose: the tests compare the fast kernels against them.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <span>
#include <vector>

#include <Eigen/Eigenvalues>

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
inline std::vector<Index> neighbors(std::span<const Vec3> points, std::size_t self, int k,
                                    double eps) {
  const double bound2 = std::isinf(eps) ? eps : eps * eps;
  std::vector<std::pair<double, Index>> candidates;
  for (std::size_t j = 0; j < points.size(); ++j) {
    if (j == self) continue;
    const double d2 = distance2(points[self], points[j]);
    if (d2 <= bound2) candidates.emplace_back(d2, static_cast<Index>(j));
  }
  std::sort(candidates.begin(), candidates.end());
  std::vector<Index> result;
  for (std::size_t j = 0; j < candidates.size() && j < static_cast<std::size_t>(k); ++j)
    result.push_back(candidates[j].second);
  return result;
}

/// factor times the median (element n/2 of the sorted list) over all points of the distance
/// to the k-th nearest other point.
inline double auto_eps(std::span<const Vec3> points, int k, double factor) {
  std::vector<double> kth;
  for (std::size_t i = 0; i < points.size(); ++i) {
    std::vector<double> d;
    for (std::size_t j = 0; j < points.size(); ++j)
      if (j != i) d.push_back(std::sqrt(distance2(points[i], points[j])));
    std::sort(d.begin(), d.end());
    kth.push_back(d[std::min<std::size_t>(static_cast<std::size_t>(k), d.size()) - 1]);
  }
  std::sort(kth.begin(), kth.end());
  return factor * kth[kth.size() / 2];
}

struct Frame {
  Vec3 normal;
  Vec3 v1;  ///< tangent eigenvector of the largest eigenvalue
  Vec3 v2;
  double c1 = 0, c2 = 0, c0 = 0;
  Eigen::Matrix3d covariance;
};

/// PCA of {p} ∪ N about the barycentre: covariance (divided by the count) of the explicit
/// centred points, eigen-decomposed with the iterative solver.
inline Frame frame(const Vec3& p, std::span<const Index> nb, std::span<const Vec3> points) {
  std::vector<Vec3> set{p};
  for (const Index j : nb) set.push_back(points[j]);
  Vec3 centroid = Vec3::Zero();
  for (const Vec3& q : set) centroid += q;
  centroid /= static_cast<double>(set.size());
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  for (const Vec3& q : set) m += (q - centroid) * (q - centroid).transpose();
  m /= static_cast<double>(set.size());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(m);
  Frame f;
  f.covariance = m;
  f.normal = solver.eigenvectors().col(0);
  f.v2 = solver.eigenvectors().col(1);
  f.v1 = solver.eigenvectors().col(2);
  f.c0 = solver.eigenvalues()[0];
  f.c2 = solver.eigenvalues()[1];
  f.c1 = solver.eigenvalues()[2];
  return f;
}

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
inline Weingarten weingarten(const Vec3& p, std::span<const Index> nb, std::span<const Vec3> points,
                             const Frame& f, bool paper_weights, double density_floor) {
  const std::size_t n = nb.size();
  std::vector<Vec3> t(n);
  std::vector<double> kap(n), w(n);
  for (std::size_t j = 0; j < n; ++j) {
    const Vec3 e = points[nb[j]] - p;
    t[j] = (e - f.normal.dot(e) * f.normal).normalized();
    kap[j] = kappa(f.normal, p, points[nb[j]]);
  }
  for (std::size_t j = 0; j < n; ++j) {
    if (!paper_weights) {
      w[j] = 1.0;
      continue;
    }
    const double delta = 2.0 * t[j].dot(f.covariance * t[j]) - 0.5 * (f.c1 + f.c2);
    const double clamped = std::max(delta, density_floor * (f.c1 + f.c2));
    w[j] = (points[nb[j]] - p).norm() / clamped;
  }
  double total = 0;
  for (const double x : w) total += x;
  for (double& x : w) x *= 2.0 * std::numbers::pi / total;
  Weingarten result;
  for (std::size_t j = 0; j < n; ++j) result.mean += w[j] * kap[j];
  result.mean /= 2.0 * std::numbers::pi;
  for (std::size_t j = 0; j < n; ++j)
    result.map += w[j] * (2.0 * kap[j] - result.mean) * t[j] * t[j].transpose();
  result.map /= std::numbers::pi;
  Eigen::Matrix<double, 3, 2> basis;
  basis << f.v1, f.v2;
  const Eigen::Matrix2d in_plane = basis.transpose() * result.map * basis;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> solver(in_plane);
  result.k2 = solver.eigenvalues()[0];
  result.k1 = solver.eigenvalues()[1];
  return result;
}

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

struct StepOptions {
  Cut cut = Cut::Sharp;
  double lambda = 1.0;
  double tau = 0.5;
  bool normal_only = false;
  /// Feature gating with the edge-quotient mode: smooth points use the isotropic Laplacian.
  bool gated = false;
  double quotient = 0.5;
  bool paper_weights = true;
  double density_floor = 0.05;
};

/// One Jacobi step: reads `points`, returns the new positions. neighbour lists given per point.
inline std::vector<Vec3> euler_step(std::span<const Vec3> points,
                                    const std::vector<std::vector<Index>>& nbs,
                                    const StepOptions& o) {
  std::vector<Vec3> next(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vec3& p = points[i];
    const Frame f = frame(p, nbs[i], points);
    Cut cut = o.cut;
    if (o.gated) {
      const Weingarten w = weingarten(p, nbs[i], points, f, o.paper_weights, o.density_floor);
      if (feature_class(w.k1, w.k2, true, o.quotient, o.lambda) == 0) cut = Cut::None;
    }
    const Vec3 a = laplacian(p, nbs[i], points, f.normal, o.lambda, cut);
    next[i] = o.normal_only ? Vec3(p + o.tau * a.dot(f.normal) * f.normal) : Vec3(p + o.tau * a);
  }
  return next;
}

}  // namespace pointfair::test::ref
