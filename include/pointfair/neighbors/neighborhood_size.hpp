#pragma once
// The automatic neighbourhood size: k chosen from the input's noise relative to its sample
// spacing. Under light noise (a scanner's: about half the spacing) the flow is best with small
// neighbourhoods that resolve the edges; under noise of several spacings a 16-point
// neighbourhood is a ball inside the noisy layer, its plane and curvatures are noise, and the
// flow needs neighbourhoods wide enough to see the surface through the layer. Measured with the
// quality benchmark's models (README, Quality).
#include <limits>
#include <span>
#include <vector>

#include "pointfair/types.hpp"

namespace pointfair {

/// Nearest points (the sample itself included) queried for each sample's noise ratio; those
/// tied with the farthest of them are left out (noise_ratio).
inline constexpr int kNoiseProbePoints = 129;
/// Samples: the points with index s * noise_sample_stride(n).
inline constexpr std::size_t kNoiseSamples = 4096;
/// The range of the automatic k.
inline constexpr int kAutoKMin = 16;
inline constexpr int kAutoKMax = 48;

std::size_t noise_sample_stride(std::size_t n);

/// A point near a sample, with its squared distance to the sample.
struct ProbePoint {
  double d2;
  Vec3 p;
};

/// The noise of one sample's neighbourhood over its sample spacing: sqrt(smallest eigenvalue of
/// the covariance of the m points kept) over the spacing sqrt(pi r^2 / (m - 1)) of points on a
/// disc of radius r, the distance to the farthest kept. `probe`: the sample's nearest points
/// (itself included), in any order; `whole_cloud`: they are every point of the cloud, else the
/// ones tied with the farthest are left out (which of the tied points a search returns depends
/// on the indices). Summed in the order (d2, x, y, z), so that the result depends on the set
/// alone: the tiled smoother, with other indices, measures the same bits. NaN when fewer than 8
/// points are kept or r = 0 (the median skips it). A clean surface scores about 0 (a curved one
/// a little more), noise of sigma along every axis about sigma over the spacing until the noisy
/// layer is thicker than the disc.
double noise_ratio(std::vector<ProbePoint>& probe, bool whole_cloud);

/// k for a cloud's noise ratio g: 64 g^2 rounded, within [kAutoKMin, kAutoKMax] (16 up to
/// g = 0.5, 48 from g = 0.87); NaN (no usable sample) gives kAutoKMin.
int k_for_noise_ratio(double g);

/// The noise ratio of a cloud from its samples' ratios: their lower quartile (element
/// (m - 1) / 4 of the m finite ones, sorted); NaN if none. Not the median: where a sample's
/// disc reaches over a sharp edge its ratio measures the edge, and in a coarse sample of an
/// edged model (a 6,000-point cube) most discs do: its median scores 0.67 at a true 0.16, its
/// lower quartile 0.16. On the quality benchmark's models the quartile is 0.92 of the median.
double cloud_noise_ratio(std::span<const double> ratios);

/// What the samples say about a cloud: its noise ratio (cloud_noise_ratio of the samples,
/// each measured on its kNoiseProbePoints nearest points, fewer in a smaller cloud) and its
/// sample spacing (the median over the samples of the distance to the nearest other point;
/// 0 when every sample has a duplicate). NaN ratio and 0 spacing for fewer than 8 points.
struct NoiseEstimate {
  double ratio = std::numeric_limits<double>::quiet_NaN();
  double spacing = 0.0;
};
NoiseEstimate estimate_noise(std::span<const Vec3> points);
/// The estimate from its samples' noise ratios (noise_ratio; NaN where not usable) and squared
/// distances to their nearest other point: cloud_noise_ratio of the ratios, the square root
/// of the distances' median (0 when it is not finite). The out-of-core run gathers the same.
NoiseEstimate noise_estimate_of(std::span<const double> ratios, std::vector<double> nearest_d2);

/// The automatic k of a cloud: k_for_noise_ratio of estimate_noise(points).ratio.
/// Deterministic: the same for any thread count, and the tiled smoother measures the same
/// samples with the same neighbours.
int automatic_k(std::span<const Vec3> points);

}  // namespace pointfair
