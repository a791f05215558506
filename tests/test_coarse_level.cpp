// SmoothParams::coarse: a flow on every ratio-th point before the flow on every point. Under
// heavy noise it removes at least as much noise as the flow alone in a handful of fine steps;
// it is bit-identical across thread counts; tiny clouds and light noise skip it; its
// parameters are checked.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/neighbors/coarse_sample.hpp"
#include "pointfair/neighbors/neighborhood_size.hpp"
#include "pointfair/smooth.hpp"
#include "support/checks.hpp"
#include "support/clouds.hpp"

namespace pointfair {
namespace {

// A unit sphere under heavy noise: 2% of the diagonal, several sample spacings.
std::vector<Vec3> heavy_noise_sphere(std::size_t n) {
  std::vector<Vec3> points = sample_sphere(n, 1.0, 11).points;
  add_noise(points, 0.02 * bounding_box_diagonal(points), 12);
  return points;
}

TEST(CoarseLevel, RemovesHeavyNoiseInAFewFineSteps) {
  const std::vector<Vec3> input = heavy_noise_sphere(12000);
  std::vector<Vec3> plain = input, coarse = input;
  SmoothParams without;
  without.coarse.reset();
  const SmoothReport plain_report = smooth(plain, without);
  SmoothParams params;  // the coarse level is on by default
  ASSERT_TRUE(params.coarse);
  // From 1.5 sample spacings (this sphere's 1.58; the default 2 takes a larger cloud).
  params.coarse->min_noise_ratio = 1.5;
  const SmoothReport coarse_report = smooth(coarse, params);
  ASSERT_EQ(coarse_report.coarse_levels.size(), 1u);
  // One finish pass after it (CoarseLevelParams::finish_passes), two without.
  EXPECT_EQ(coarse_report.finish_passes, 1);
  EXPECT_EQ(plain_report.finish_passes, 2);
  // Every second point of each cell: half the cloud, and half a point more a cell of odd count.
  const CoarseCells cells =
      coarse_cells(morton_grid(input), CoarseLevelParams{}.cell_spacings * estimate_noise(input).spacing);
  EXPECT_EQ(coarse_report.coarse_levels[0].points, coarse_sample(input, cells, 2).size());
  EXPECT_GE(coarse_report.coarse_levels[0].points, input.size() / 2);
  EXPECT_LT(coarse_report.coarse_levels[0].points, input.size() * 11 / 20);
  EXPECT_GT(coarse_report.coarse_levels[0].steps, 0);
  EXPECT_EQ(coarse_report.steps, CoarseLevelParams{}.fine_steps);
  EXPECT_GT(plain_report.steps, coarse_report.steps);
  // At least as close to the sphere as the flow alone (measured: about 7% closer).
  EXPECT_LT(test::unit_sphere_rms(coarse), test::unit_sphere_rms(input) / 3.0);
  EXPECT_LE(test::unit_sphere_rms(coarse), 1.02 * test::unit_sphere_rms(plain)) << test::unit_sphere_rms(plain);
  // The placement keeps each input point's place on the surface as the flow alone does: it
  // moves along the normal, so its direction from the centre turns as little (the coarse
  // level's points slide, the input's do not).
  const auto mean_turn = [&](const std::vector<Vec3>& out) {
    double turn = 0.0;
    for (std::size_t i = 0; i < input.size(); ++i)
      turn += std::acos(std::min(1.0, input[i].normalized().dot(out[i].normalized())));
    return turn / static_cast<double>(input.size());
  };
  EXPECT_LT(mean_turn(coarse), 1.1 * mean_turn(plain)) << mean_turn(plain);
}

TEST(CoarseLevel, BitIdenticalAcrossThreadCounts) {
  const std::vector<Vec3> input = heavy_noise_sphere(6000);
  SmoothParams params;
  params.coarse =
      CoarseLevelParams{.ratio = 3, .fine_steps = 4, .interpolation_k = 6, .levels = 2, .min_noise_ratio = 0.0};
  std::vector<Vec3> one = input, two = input;
  set_thread_count(1);
  ASSERT_EQ(smooth(one, params).coarse_levels.size(), 2u);
  set_thread_count(2);
  smooth(two, params);
  set_thread_count(0);
  EXPECT_EQ(one, two);
}

TEST(CoarseLevel, ATinyCloudSkipsItAndBadParametersAreRefused) {
  std::vector<Vec3> tiny = heavy_noise_sphere(120);  // 60 coarse points: too few
  SmoothParams params;
  params.coarse = CoarseLevelParams{.min_noise_ratio = 0.0};
  const SmoothReport tiny_report = smooth(tiny, params);
  EXPECT_TRUE(tiny_report.coarse_levels.empty());
  params.coarse = CoarseLevelParams{};
  // Light noise needs no coarse level: the flow as without it.
  std::vector<Vec3> light = sample_sphere(4000, 1.0, 21).points, plain;
  add_noise(light, 0.001 * bounding_box_diagonal(light), 22);
  plain = light;
  const SmoothReport light_report = smooth(light, params);
  EXPECT_TRUE(light_report.coarse_levels.empty());
  EXPECT_EQ(light_report.finish_passes, 2);
  SmoothParams without = params;
  without.coarse.reset();
  smooth(plain, without);
  EXPECT_EQ(light, plain);
  // Neighbourhoods from a reference cloud leave it out.
  std::vector<Vec3> heavy = heavy_noise_sphere(6000), reference = heavy, alone = heavy;
  SmoothOptions from_reference;
  from_reference.neighbor_reference = reference;
  params.coarse->min_noise_ratio = 0.0;
  ASSERT_FALSE(smooth(alone, params).coarse_levels.empty());
  EXPECT_TRUE(smooth(heavy, params, from_reference).coarse_levels.empty());
  std::vector<Vec3> cloud = heavy_noise_sphere(1000);
  for (const CoarseLevelParams bad : {CoarseLevelParams{.ratio = 1}, CoarseLevelParams{.fine_steps = -1},
                                      CoarseLevelParams{.interpolation_k = 0}, CoarseLevelParams{.interpolation_k = 65},
                                      CoarseLevelParams{.levels = 0}, CoarseLevelParams{.min_noise_ratio = -1},
                                      CoarseLevelParams{.cell_spacings = 0}, CoarseLevelParams{.finish_passes = -1}}) {
    params.coarse = bad;
    EXPECT_THROW(smooth(cloud, params), ParamError);
  }
}

}  // namespace
}  // namespace pointfair
