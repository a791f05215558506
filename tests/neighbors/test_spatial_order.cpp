// Morton reordering and relabelled neighbourhoods: smooth() runs on a reordered copy, which
// must not change a single bit of the result.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <vector>

#include "pointfair/flow/euler_step.hpp"
#include "pointfair/flow/shrink_compensation.hpp"
#include "pointfair/neighbors/spatial_order.hpp"
#include "pointfair/shapes/shapes.hpp"
#include "pointfair/smooth.hpp"

namespace pointfair {
namespace {

std::vector<Vec3> noisy_cube(std::size_t n, std::uint64_t seed) {
  std::vector<Vec3> points = sample_mesh(cube_mesh(), n, seed).points;
  add_noise(points, 0.01, seed + 1);
  return points;
}

bool same_bits(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3)) == 0;
}

TEST(SpatialOrder, IsAPermutationAndLocal) {
  const auto points = noisy_cube(5000, 3);
  const auto order = spatial_order(points);
  std::vector<Index> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  std::vector<Index> expected(points.size());
  std::iota(expected.begin(), expected.end(), Index{0});
  EXPECT_EQ(sorted, expected);
  // Consecutive points in Morton order are much closer than consecutive input points.
  double ordered_gap = 0, input_gap = 0;
  for (std::size_t s = 1; s < points.size(); ++s) {
    ordered_gap += (points[order[s]] - points[order[s - 1]]).norm();
    input_gap += (points[s] - points[s - 1]).norm();
  }
  EXPECT_LT(ordered_gap, 0.2 * input_gap);
  const auto inverse = inverse_permutation(order);
  for (std::size_t s = 0; s < order.size(); ++s) EXPECT_EQ(inverse[order[s]], s);
  EXPECT_TRUE(same_bits(scatter(gather(points, order), order), points));
}

// Non-finite coordinates (refused by smooth(), but spatial_order is public): still a
// permutation, with no undefined float-to-integer conversion (checked under UBSan).
TEST(SpatialOrder, NonFiniteCoordinatesStillGiveAPermutation) {
  std::vector<Vec3> points = {Vec3(0, 0, 0), Vec3(1, 2, 3), Vec3(2, 1, 0), Vec3(3, 3, 3)};
  points[1].y() = std::numeric_limits<double>::quiet_NaN();
  points[3].x() = std::numeric_limits<double>::infinity();
  std::vector<Index> order = spatial_order(points);
  std::sort(order.begin(), order.end());
  EXPECT_EQ(order, (std::vector<Index>{0, 1, 2, 3}));
}

TEST(SpatialOrder, PermutedNeighbourhoodsNameTheSamePoints) {
  const auto points = noisy_cube(3000, 5);
  const Neighborhoods nb = build_neighborhoods(points, {.k = 12});
  const auto order = spatial_order(points);
  const auto inverse = inverse_permutation(order);
  const Neighborhoods p = permute_neighborhoods(nb, order, inverse);
  const auto moved = gather(points, order);
  for (std::size_t s = 0; s < order.size(); ++s) {
    const auto a = nb.of(order[s]);
    const auto b = p.of(s);
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t j = 0; j < a.size(); ++j) EXPECT_EQ(points[a[j]], moved[b[j]]);
  }
  // And back again.
  const Neighborhoods back = permute_neighborhoods(p, inverse, order);
  EXPECT_EQ(back.indices, nb.indices);
  EXPECT_EQ(back.counts, nb.counts);
  // In place, both ways.
  Neighborhoods in_place = nb;
  permute_neighborhoods_in_place(in_place, order, inverse);
  EXPECT_EQ(in_place.indices, p.indices);
  EXPECT_EQ(in_place.counts, p.counts);
  permute_neighborhoods_in_place(in_place, inverse, order);
  EXPECT_EQ(in_place.indices, nb.indices);
  // Built directly in the new order.
  const Neighborhoods direct = build_reordered_neighborhoods(points, {.k = 12}, order, inverse);
  EXPECT_EQ(direct.indices, p.indices);
  EXPECT_EQ(direct.counts, p.counts);
  std::vector<Vec3> values = points;
  permute_in_place(values, order);
  EXPECT_TRUE(same_bits(values, moved));
}

// A run stopped by an exception from the progress callback leaves the last completed step,
// in the caller's order.
TEST(SpatialOrder, StoppedRunLeavesLastCompletedStep) {
  const auto input = noisy_cube(3000, 13);
  SmoothParams params;
  params.finish.reset();  // the flow alone
  params.steps = 10;
  std::vector<Vec3> stopped = input;
  SmoothOptions options;
  options.progress = [](SmoothStage, std::size_t done, std::size_t) {
    if (done == 3) throw std::runtime_error("stop");
  };
  EXPECT_THROW(smooth(stopped, params, options), std::runtime_error);
  std::vector<Vec3> three = input;
  params.steps = 3;
  smooth(three, params);
  EXPECT_TRUE(same_bits(stopped, three));
}

// smooth() (reordered internally) against plain Euler steps in the input order.
TEST(SpatialOrder, SmoothIsBitIdenticalToStepsInInputOrder) {
  const auto input = noisy_cube(4000, 9);
  for (const bool every_step : {false, true}) {
    SmoothParams params;
    params.finish.reset();  // the flow alone
    params.neighbors.k = 16;  // the hand-driven steps below build their own lists
    params.steps = 6;
    params.lambda_every_step = every_step;
    std::vector<Vec3> smoothed = input;
    const SmoothReport report = smooth(smoothed, params);

    std::vector<Vec3> current = input, updated(input.size()), next(input.size());
    const Neighborhoods nb = build_neighborhoods(input, params.neighbors);
    double lambda = resolve_lambda(current, nb, params.flow);
    for (int step = 0; step < params.steps; ++step) {
      if (every_step && step > 0) lambda = resolve_lambda(current, nb, params.flow);
      euler_step(current, nb, {}, params.flow, lambda, updated);
      compensate_shrinkage(current, updated, nb, {}, params.shrink_compensation, next);
      current.swap(next);
    }
    EXPECT_TRUE(same_bits(smoothed, current)) << "every_step " << every_step;
    EXPECT_EQ(report.lambda, lambda);
    EXPECT_EQ(report.neighborhoods.indices, nb.indices);
  }
}

}  // namespace
}  // namespace pointfair
