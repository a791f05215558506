// Bodies of the larger reference implementations declared in reference.hpp.
#include "support/reference.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

#include <Eigen/Eigenvalues>

namespace pointfair::test::ref {

std::vector<Index> neighbors(std::span<const Vec3> points, std::size_t self, int k,
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

double auto_eps(std::span<const Vec3> points, int k, double factor) {
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

Frame frame(const Vec3& p, std::span<const Index> nb, std::span<const Vec3> points) {
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

Weingarten weingarten(const Vec3& p, std::span<const Index> nb, std::span<const Vec3> points,
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

Plane robust_plane(const Vec3& p, std::span<const Index> nb, std::span<const Vec3> points,
                   int seed, int iterations, double bound) {
  std::vector<Vec3> set{p};
  for (const Index j : nb) set.push_back(points[j]);
  std::vector<double> w(set.size(), 0.0);
  for (std::size_t j = 0; j < set.size() && j <= static_cast<std::size_t>(seed); ++j) w[j] = 1.0;
  const auto fit = [&set](const std::vector<double>& weights) {
    double total = 0.0;
    Vec3 centroid = Vec3::Zero();
    for (std::size_t j = 0; j < set.size(); ++j) {
      total += weights[j];
      centroid += weights[j] * set[j];
    }
    centroid /= total;
    Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
    for (std::size_t j = 0; j < set.size(); ++j)
      m += weights[j] * (set[j] - centroid) * (set[j] - centroid).transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(m / total);
    return Plane{solver.eigenvectors().col(0), centroid};
  };
  Plane plane = fit(w);
  for (int it = 0; it < iterations; ++it) {
    std::vector<double> distance(set.size());
    for (std::size_t j = 0; j < set.size(); ++j) distance[j] = std::abs(plane.normal.dot(set[j] - plane.centroid));
    std::vector<double> sorted = distance;
    std::sort(sorted.begin(), sorted.end());
    const double scale = 1.4826 * sorted[set.size() / 2];
    for (std::size_t j = 0; j < set.size(); ++j) {
      const double u = distance[j] / (bound * scale);
      w[j] = u < 1.0 ? (1.0 - u * u) * (1.0 - u * u) : 0.0;
    }
    plane = fit(w);
  }
  return plane;
}

std::vector<Vec3> euler_step(std::span<const Vec3> points,
                             const std::vector<std::vector<Index>>& nbs, const StepOptions& o) {
  std::vector<Vec3> next(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vec3& p = points[i];
    Frame f = frame(p, nbs[i], points);
    Vec3 origin = p;
    const double trace = f.c0 + f.c1 + f.c2;
    const bool pca_kept = o.robust_gate > 0.0 && f.c0 <= o.robust_gate * (o.lambda * trace) * (o.lambda * trace);
    if (o.robust && !pca_kept) {
      const Plane plane = robust_plane(p, nbs[i], points, 6, 3, 3.0);
      f.normal = plane.normal;
      if (o.plane_origin) origin = p + f.normal.dot(plane.centroid - p) * f.normal;
    } else if (o.plane_origin) {
      Vec3 centroid = p;
      for (const Index j : nbs[i]) centroid += points[j];
      centroid /= static_cast<double>(nbs[i].size() + 1);
      origin = p + f.normal.dot(centroid - p) * f.normal;
    }
    Cut cut = o.cut;
    if (o.gated) {
      const Weingarten w = weingarten(p, nbs[i], points, f, o.paper_weights, o.density_floor);
      double radius2 = 0.0;
      for (const Index j : nbs[i]) radius2 = std::max(radius2, distance2(points[j], p));
      const double threshold = o.feature_turn > 0.0 ? o.feature_turn / std::sqrt(radius2) : o.lambda;
      if (feature_class(w.k1, w.k2, true, o.quotient, threshold) == 0) cut = Cut::None;
    }
    // The cut-off reads kappa from `origin`; the motion is still toward p_j - p.
    Vec3 a = Vec3::Zero();
    for (const Index j : nbs[i])
      a += cut_weight(kappa(f.normal, origin, points[j]), o.lambda, cut) * (points[j] - p);
    a /= static_cast<double>(nbs[i].size());
    next[i] = o.normal_only ? Vec3(p + o.tau * a.dot(f.normal) * f.normal) : Vec3(p + o.tau * a);
  }
  return next;
}

}  // namespace pointfair::test::ref
