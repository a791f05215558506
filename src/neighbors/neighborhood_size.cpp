#include "pointfair/neighbors/neighborhood_size.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>
#include <vector>

#include <Eigen/Eigenvalues>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/neighbors/nearest_points.hpp"

namespace pointfair {

std::size_t noise_sample_stride(std::size_t n) { return std::max<std::size_t>(1, n / kNoiseSamples); }

double noise_ratio(std::vector<ProbePoint>& probe, bool whole_cloud) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  std::sort(probe.begin(), probe.end(), [](const ProbePoint& a, const ProbePoint& b) {
    if (a.d2 != b.d2) return a.d2 < b.d2;
    if (a.p.x() != b.p.x()) return a.p.x() < b.p.x();
    if (a.p.y() != b.p.y()) return a.p.y() < b.p.y();
    return a.p.z() < b.p.z();
  });
  std::size_t m = probe.size();
  if (!whole_cloud)
    while (m > 0 && probe[m - 1].d2 == probe.back().d2) --m;
  if (m < 8) return kNaN;
  const double r = std::sqrt(probe[m - 1].d2);
  if (!(r > 0.0)) return kNaN;
  const Vec3 origin = probe[0].p;
  Vec3 mean = Vec3::Zero();
  for (std::size_t j = 0; j < m; ++j) mean += probe[j].p - origin;
  mean /= static_cast<double>(m);
  Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
  for (std::size_t j = 0; j < m; ++j) {
    const Vec3 d = probe[j].p - origin - mean;
    c += d * d.transpose();
  }
  c /= static_cast<double>(m);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(c, Eigen::EigenvaluesOnly);
  const double sigma = std::sqrt(std::max(0.0, eigen.eigenvalues()[0]));
  const double spacing = r * std::sqrt(std::numbers::pi / static_cast<double>(m - 1));
  return sigma / spacing;
}

int k_for_noise_ratio(double g) {
  if (!std::isfinite(g)) return kAutoKMin;
  const double k = std::round(64.0 * g * g);
  return static_cast<int>(std::clamp(k, static_cast<double>(kAutoKMin), static_cast<double>(kAutoKMax)));
}

double cloud_noise_ratio(std::span<const double> ratios) {
  std::vector<double> finite;
  finite.reserve(ratios.size());
  for (const double g : ratios)
    if (std::isfinite(g)) finite.push_back(g);
  if (finite.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto quartile = finite.begin() + static_cast<std::ptrdiff_t>((finite.size() - 1) / 4);
  std::nth_element(finite.begin(), quartile, finite.end());
  return *quartile;
}

NoiseEstimate estimate_noise(std::span<const Vec3> points) {
  const std::size_t n = points.size();
  if (n < 8) return {};
  require_finite(points, "automatic k");
  const std::size_t stride = noise_sample_stride(n);
  const std::size_t samples = (n + stride - 1) / stride;
  const int want = static_cast<int>(std::min<std::size_t>(kNoiseProbePoints, n));
  std::vector<Index> queries(samples);
  for (std::size_t s = 0; s < samples; ++s) queries[s] = static_cast<Index>(s * stride);
  // Each sample's nearest points as a k-d tree gives them, through the cell grid: no tree
  // over the whole cloud for a few thousand samples.
  const NearestPoints nearest = nearest_points(points, queries, want);
  std::vector<double> ratios(samples), nearest_d2(samples);
  parallel_for(samples, [&](std::size_t begin, std::size_t end) {
    std::vector<ProbePoint> probe;
    for (std::size_t s = begin; s < end; ++s) {
      const std::span<const Index> idx = nearest.indices_of(s);
      const std::span<const double> d2 = nearest.distances2_of(s);
      probe.clear();
      for (std::size_t j = 0; j < idx.size(); ++j) probe.push_back({d2[j], points[idx[j]]});
      ratios[s] = noise_ratio(probe, probe.size() == n);
      // The nearest other point: the smallest distance of a point other than the sample.
      double closest = std::numeric_limits<double>::infinity();
      for (std::size_t j = 0; j < idx.size(); ++j)
        if (idx[j] != queries[s]) closest = std::min(closest, d2[j]);
      nearest_d2[s] = closest;
    }
  }, 64);
  return noise_estimate_of(ratios, std::move(nearest_d2));
}

NoiseEstimate noise_estimate_of(std::span<const double> ratios, std::vector<double> nearest_d2) {
  NoiseEstimate estimate;
  estimate.ratio = cloud_noise_ratio(ratios);
  if (nearest_d2.empty()) return estimate;
  const auto middle = nearest_d2.begin() + static_cast<std::ptrdiff_t>(nearest_d2.size() / 2);
  std::nth_element(nearest_d2.begin(), middle, nearest_d2.end());
  estimate.spacing = std::isfinite(*middle) ? std::sqrt(*middle) : 0.0;
  return estimate;
}

int automatic_k(std::span<const Vec3> points) { return k_for_noise_ratio(estimate_noise(points).ratio); }

}  // namespace pointfair
