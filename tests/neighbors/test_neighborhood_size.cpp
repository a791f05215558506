// The automatic neighbourhood size (neighborhood_size.hpp): the noise ratio of a sample's
// neighbourhood, its median over the cloud, and the k it picks; smooth() uses it by default.
#include "pointfair/neighbors/neighborhood_size.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "pointfair/neighbors/kd_tree.hpp"
#include "pointfair/smooth.hpp"
#include "support/clouds.hpp"

namespace pointfair {
namespace {

// `count` points uniform on the square [-1, 1]^2 of z = 0, each moved by Gaussian noise of
// `sigma` spacings along z (the spacing of the square: 2 / sqrt(count)).
std::vector<Vec3> noisy_plane(std::size_t count, double sigma, std::uint64_t seed) {
  std::vector<Vec3> points = test::random_plane(count, 1.0, seed);
  const double spacing = 2.0 / std::sqrt(static_cast<double>(count));
  std::mt19937_64 engine(seed + 1);
  std::normal_distribution<double> normal(0.0, sigma * spacing);
  for (Vec3& p : points) p.z() = normal(engine);
  return points;
}

// The probe of point 0 of `points`: its `m` nearest by brute force, in index order.
std::vector<ProbePoint> probe_of(const std::vector<Vec3>& points, std::size_t m) {
  std::vector<ProbePoint> all;
  for (const Vec3& p : points) all.push_back({(p - points[0]).squaredNorm(), p});
  std::stable_sort(all.begin(), all.end(), [](const ProbePoint& a, const ProbePoint& b) { return a.d2 < b.d2; });
  all.resize(std::min(m, all.size()));
  return all;
}

TEST(NoiseRatio, IsZeroOnACleanPlaneAndTheNoiseOverTheSpacingOnANoisyOne) {
  const std::vector<Vec3> clean = noisy_plane(20000, 0.0, 3);
  std::vector<ProbePoint> probe = probe_of(clean, kNoiseProbePoints);
  EXPECT_EQ(noise_ratio(probe, false), 0.0);
  // Noise well below the disc of 128 points (radius about 6.4 spacings): the ratio measures it.
  for (const double sigma : {0.25, 0.5, 1.0}) {
    std::vector<double> ratios;
    const std::vector<Vec3> noisy = noisy_plane(20000, sigma, 5);
    for (std::size_t s = 0; s < noisy.size(); s += 97) {
      std::vector<Vec3> shifted = noisy;
      std::swap(shifted[0], shifted[s]);
      std::vector<ProbePoint> p = probe_of(shifted, kNoiseProbePoints);
      ratios.push_back(noise_ratio(p, false));
    }
    const double g = cloud_noise_ratio(ratios);
    EXPECT_GT(g, 0.7 * sigma) << "sigma " << sigma;
    EXPECT_LT(g, 1.2 * sigma) << "sigma " << sigma;
  }
}

TEST(NoiseRatio, DependsOnTheSetAloneAndLeavesOutTiesWithTheFarthest) {
  const std::vector<Vec3> noisy = noisy_plane(2000, 1.0, 7);
  std::vector<ProbePoint> probe = probe_of(noisy, 60);
  std::vector<ProbePoint> shuffled = probe;
  std::shuffle(shuffled.begin(), shuffled.end(), std::mt19937_64(1));
  const double a = noise_ratio(probe, false), b = noise_ratio(shuffled, false);
  EXPECT_EQ(std::bit_cast<std::uint64_t>(a), std::bit_cast<std::uint64_t>(b));
  // A point at the farthest distance (another of its ties may be missing) is left out: the
  // same as without it; counted when the probe is the whole cloud.
  std::vector<ProbePoint> shorter(probe.begin(), probe.end() - 1);
  std::vector<ProbePoint> tied = shorter;
  tied.push_back({shorter.back().d2, Vec3(9.0, 9.0, 9.0)});
  const double without_last = noise_ratio(shorter, false);  // drops its own farthest
  std::vector<ProbePoint> reference(shorter.begin(), shorter.end() - 1);
  EXPECT_EQ(noise_ratio(tied, false), noise_ratio(reference, true));
  EXPECT_EQ(without_last, noise_ratio(reference, true));
  EXPECT_NE(noise_ratio(tied, true), noise_ratio(reference, true));
}

TEST(NoiseRatio, NaNWithoutEnoughPointsOrExtent) {
  std::vector<ProbePoint> few(7, ProbePoint{1.0, Vec3(1.0, 0.0, 0.0)});
  EXPECT_TRUE(std::isnan(noise_ratio(few, true)));
  std::vector<ProbePoint> stack(20, ProbePoint{0.0, Vec3(1.0, 2.0, 3.0)});
  EXPECT_TRUE(std::isnan(noise_ratio(stack, true)));
}

TEST(AutomaticK, MapsTheRatioTo16Through48) {
  EXPECT_EQ(k_for_noise_ratio(0.0), kAutoKMin);
  EXPECT_EQ(k_for_noise_ratio(0.5), 16);
  EXPECT_EQ(k_for_noise_ratio(0.75), 36);
  EXPECT_EQ(k_for_noise_ratio(1.0), kAutoKMax);
  EXPECT_EQ(k_for_noise_ratio(5.0), kAutoKMax);
  EXPECT_EQ(k_for_noise_ratio(std::numeric_limits<double>::quiet_NaN()), kAutoKMin);
  // The lower quartile of the finite ones.
  const double ratios[] = {std::nan(""), 0.2, 0.9, std::nan(""), 0.4, 0.3, 0.7};
  EXPECT_EQ(cloud_noise_ratio(ratios), 0.3);
}

TEST(AutomaticK, SmallUnderLightNoiseLargeUnderHeavyNoise) {
  EXPECT_EQ(automatic_k(noisy_plane(20000, 0.0, 11)), 16);
  EXPECT_EQ(automatic_k(noisy_plane(20000, 0.3, 11)), 16);
  const int middle = automatic_k(noisy_plane(20000, 0.75, 11));
  EXPECT_GT(middle, 16);
  EXPECT_LT(middle, 48);
  EXPECT_EQ(automatic_k(noisy_plane(20000, 2.0, 11)), 48);
  // A coarse sample of a cube with light noise (0.16 spacings): the discs that reach over
  // its edges do not count as noise.
  EXPECT_EQ(automatic_k(test::noisy_cube(6000, 0.01 / std::sqrt(12.0), 41)), 16);
  // Tiny and degenerate clouds: the smallest k.
  EXPECT_EQ(automatic_k(std::vector<Vec3>(5, Vec3::Zero())), 16);
  EXPECT_EQ(automatic_k(std::vector<Vec3>(500, Vec3(1.0, 1.0, 1.0))), 16);
}

// automatic_k's formula with each sample's probe from one k-d tree query (the reference).
int automatic_k_through_tree(const std::vector<Vec3>& points) {
  const std::size_t n = points.size();
  if (n < 8) return kAutoKMin;
  const KdTree tree(points);
  const std::size_t stride = noise_sample_stride(n);
  const int want = static_cast<int>(std::min<std::size_t>(kNoiseProbePoints, n));
  std::vector<double> ratios;
  std::vector<Index> idx(static_cast<std::size_t>(want));
  std::vector<double> d2(static_cast<std::size_t>(want));
  for (std::size_t s = 0; s * stride < n; ++s) {
    const int found = tree.nearest(points[s * stride], want, std::numeric_limits<double>::infinity(), idx.data(),
                                   d2.data());
    std::vector<ProbePoint> probe;
    for (int j = 0; j < found; ++j) probe.push_back({d2[static_cast<std::size_t>(j)], points[idx[static_cast<std::size_t>(j)]]});
    ratios.push_back(noise_ratio(probe, probe.size() == n));
  }
  return k_for_noise_ratio(cloud_noise_ratio(ratios));
}

TEST(AutomaticK, TheSameAsThroughAKdTree) {
  // Clouds whose k falls between the clamps (where every ratio counts), a cube with its
  // edges, and stacks of duplicates (the probe's ties).
  for (const double sigma : {0.6, 0.75, 0.85}) {
    const std::vector<Vec3> plane = noisy_plane(30000, sigma, 17);
    const int k = automatic_k(plane);
    EXPECT_EQ(k, automatic_k_through_tree(plane)) << "sigma " << sigma;
  }
  const std::vector<Vec3> cube = test::noisy_cube(12000, 0.02, 43);
  EXPECT_EQ(automatic_k(cube), automatic_k_through_tree(cube));
  std::vector<Vec3> stacks = noisy_plane(3000, 0.8, 19);
  for (std::size_t i = 0; i < 3000; ++i) stacks.push_back(stacks[i % 200]);
  EXPECT_EQ(automatic_k(stacks), automatic_k_through_tree(stacks));
}

TEST(AutomaticK, SmoothUsesItUnlessKIsGivenOrThePaperIsAsked) {
  const std::vector<Vec3> input = noisy_plane(4000, 2.0, 13);
  SmoothParams params;
  params.finish.reset();  // the flow alone
  params.steps = 2;
  std::vector<Vec3> automatic = input;
  const SmoothReport a = smooth(automatic, params);
  EXPECT_EQ(a.k, automatic_k(input));
  EXPECT_EQ(a.k, 48);
  EXPECT_EQ(a.neighborhoods.stride, 48);
  // The same as asking for that k.
  params.neighbors.k = a.k;
  std::vector<Vec3> fixed = input;
  smooth(fixed, params);
  EXPECT_EQ(fixed, automatic);
  params.neighbors.k = 16;
  std::vector<Vec3> given = input;
  EXPECT_EQ(smooth(given, params).k, 16);
  EXPECT_EQ(SmoothParams{}.neighbors.k, 0);
  EXPECT_EQ(paper_smooth_params().neighbors.k, 16);
  SmoothParams eight;
  eight.finish.reset();  // the flow alone
  eight.neighbors.k = 8;
  EXPECT_EQ(paper_smooth_params(eight).neighbors.k, 8);
}

}  // namespace
}  // namespace pointfair
