// eps-k neighbourhoods against a brute-force oracle: identical canonical lists (distance, ties
// by smaller index), self excluded, the eps bound, counts, the automatic eps, and the
// queries-subset overload.
#include "pointfair/neighbors/neighborhoods.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numeric>
#include <vector>

#include "pointfair/common/params_error.hpp"
#include "pointfair/neighbors/kd_tree.hpp"
#include "support/checks.hpp"
#include "support/clouds.hpp"
#include "support/reference.hpp"

namespace pointfair {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// A random cloud with duplicates: copies of earlier points and a stack of coincident points.
std::vector<Vec3> cloud_with_duplicates() {
  std::vector<Vec3> points = test::random_box(1200, -1.0, 1.0, 21);
  for (std::size_t i = 0; i < 200; i += 4) points.push_back(points[i]);
  for (int i = 0; i < 25; ++i) points.push_back(points[3]);
  return points;
}

void expect_matches_oracle(std::span<const Vec3> points, const Neighborhoods& n, int k, double eps) {
  ASSERT_EQ(n.size(), points.size());
  ASSERT_EQ(n.stride, k);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto expected = test::ref::neighbors(points, i, k, eps);
    const auto row = n.of(i);
    ASSERT_EQ(row.size(), expected.size()) << "point " << i;
    for (std::size_t j = 0; j < row.size(); ++j) {
      EXPECT_EQ(row[j], expected[j]) << "point " << i << " slot " << j;
      EXPECT_NE(row[j], i) << "the point itself is not its own neighbour";
      if (!std::isinf(eps)) {
        EXPECT_LE(test::ref::distance2(points[i], points[row[j]]), eps * eps);
      }
    }
  }
}

TEST(Neighborhoods, FixedEpsMatchesBruteForceWithDuplicates) {
  const std::vector<Vec3> points = cloud_with_duplicates();
  for (const int k : {1, 8, 16, 30}) {
    for (const double eps : {0.15, 0.3}) {
      NeighborParams params;
      params.k = k;
      params.eps = eps;
      const Neighborhoods n = build_neighborhoods(points, params);
      EXPECT_EQ(n.eps, eps);
      expect_matches_oracle(points, n, k, eps);
    }
  }
}

TEST(Neighborhoods, InfiniteEpsIsPlainKNearest) {
  const std::vector<Vec3> points = cloud_with_duplicates();
  NeighborParams params;
  params.k = 12;
  params.eps = kInf;
  const Neighborhoods n = build_neighborhoods(points, params);
  EXPECT_TRUE(std::isinf(n.eps));
  expect_matches_oracle(points, n, 12, kInf);
  for (std::size_t i = 0; i < n.size(); ++i) EXPECT_EQ(n.counts[i], 12);
}

TEST(Neighborhoods, GridTiesBrokenBySmallerIndex) {
  const std::vector<Vec3> points = test::integer_grid(8, 17);
  for (const int k : {3, 6, 10, 20}) {
    NeighborParams params;
    params.k = k;
    params.eps = kInf;
    expect_matches_oracle(points, build_neighborhoods(points, params), k, kInf);
    // eps exactly 1: only the axis neighbours (squared distance exactly 1) qualify.
    params.eps = 1.0;
    const Neighborhoods unit = build_neighborhoods(points, params);
    expect_matches_oracle(points, unit, k, 1.0);
    for (std::size_t i = 0; i < unit.size(); ++i) EXPECT_LE(unit.counts[i], std::min(k, 6));
  }
}

TEST(Neighborhoods, SelfExcludedAmongCoincidentPoints) {
  // 20 copies of one point: each row holds the other 19 copies... up to k, smallest index first.
  std::vector<Vec3> points(20, Vec3(0.5, -0.25, 2.0));
  points.emplace_back(10.0, 0.0, 0.0);
  NeighborParams params;
  params.k = 8;
  params.eps = 1.0;
  const Neighborhoods n = build_neighborhoods(points, params);
  for (std::size_t i = 0; i < 20; ++i) {
    std::vector<Index> expected;
    for (Index j = 0; j < 20 && expected.size() < 8; ++j)
      if (j != i) expected.push_back(j);
    const auto row = n.of(i);
    EXPECT_EQ(std::vector<Index>(row.begin(), row.end()), expected) << "point " << i;
  }
  EXPECT_EQ(n.counts[20], 0) << "the far point has no neighbour within eps";
}

TEST(Neighborhoods, AutoEpsIsFactorTimesMedianKthDistance) {
  const std::vector<Vec3> points = cloud_with_duplicates();
  const KdTree tree(points);
  for (const int k : {4, 16}) {
    const double median_kth = test::ref::auto_eps(points, k, 1.0);
    for (const double factor : {1.0, 2.0, 0.5}) {
      NeighborParams params;
      params.k = k;
      params.eps_auto_factor = factor;
      const double expected = factor * median_kth;
      EXPECT_EQ(resolve_eps(points, tree, params), expected);
      const Neighborhoods n = build_neighborhoods(points, params);
      EXPECT_EQ(n.eps, expected);
      expect_matches_oracle(points, n, k, expected);
    }
  }
}

TEST(Neighborhoods, ResolveEpsHonoursExplicitValueAndDegenerateClouds) {
  const std::vector<Vec3> points = test::random_box(100, 0.0, 1.0, 4);
  const KdTree tree(points);
  NeighborParams params;
  params.eps = 0.125;
  EXPECT_EQ(resolve_eps(points, tree, params), 0.125);
  // All points coincident: no spacing to measure, no bound.
  const std::vector<Vec3> same(10, Vec3(1, 2, 3));
  const KdTree same_tree(same);
  EXPECT_TRUE(std::isinf(resolve_eps(same, same_tree, NeighborParams{})));
  // A single point.
  const std::vector<Vec3> one(1, Vec3(1, 2, 3));
  const KdTree one_tree(one);
  EXPECT_TRUE(std::isinf(resolve_eps(one, one_tree, NeighborParams{})));
  const Neighborhoods n = build_neighborhoods(one, NeighborParams{});
  ASSERT_EQ(n.size(), 1u);
  EXPECT_EQ(n.counts[0], 0);
}

TEST(Neighborhoods, QueriesSubsetEqualsFullRows) {
  const std::vector<Vec3> points = cloud_with_duplicates();
  NeighborParams params;
  params.k = 16;
  const Neighborhoods full = build_neighborhoods(points, params);
  const KdTree tree(points);
  std::vector<Index> queries;
  for (Index i = 0; i < points.size(); i += 7) queries.push_back(i);
  queries.push_back(3);  // a duplicate-stack point, and out of order
  const Neighborhoods part = build_neighborhoods(tree, queries, params.k, full.eps);
  ASSERT_EQ(part.size(), queries.size());
  EXPECT_EQ(part.eps, full.eps);
  for (std::size_t r = 0; r < queries.size(); ++r) {
    const auto a = part.of(r);
    const auto b = full.of(queries[r]);
    EXPECT_EQ(std::vector<Index>(a.begin(), a.end()), std::vector<Index>(b.begin(), b.end()))
        << "query " << queries[r];
  }
}

TEST(Neighborhoods, EpsBoundLimitsCounts) {
  // Points on a line with spacing 1: with eps = 2.5 an interior point has 4 neighbours.
  std::vector<Vec3> points;
  for (int i = 0; i < 10; ++i) points.emplace_back(i, 0, 0);
  NeighborParams params;
  params.k = 16;
  params.eps = 2.5;
  const Neighborhoods n = build_neighborhoods(points, params);
  const std::vector<std::uint16_t> expected = {2, 3, 4, 4, 4, 4, 4, 4, 3, 2};
  EXPECT_EQ(n.counts, expected);
  const auto row = n.of(5);
  EXPECT_EQ(std::vector<Index>(row.begin(), row.end()), (std::vector<Index>{4, 6, 3, 7}));
  EXPECT_EQ(n.indices.size(), points.size() * 16u);
}

TEST(Neighborhoods, ValidateRejectsBadParameters) {
  const auto bad = [](auto mutate) {
    NeighborParams p;
    mutate(p);
    return p;
  };
  EXPECT_NO_THROW(NeighborParams{}.validate());
  EXPECT_THROW(bad([](NeighborParams& p) { p.k = 0; }).validate(), ParamError);
  EXPECT_THROW(bad([](NeighborParams& p) { p.k = -3; }).validate(), ParamError);
  EXPECT_THROW(bad([](NeighborParams& p) { p.k = 1025; }).validate(), ParamError);
  EXPECT_NO_THROW(bad([](NeighborParams& p) { p.k = 1024; }).validate());
  EXPECT_THROW(bad([](NeighborParams& p) { p.eps = -1e-9; }).validate(), ParamError);
  EXPECT_THROW(bad([](NeighborParams& p) { p.eps = std::nan(""); }).validate(), ParamError);
  EXPECT_NO_THROW(bad([](NeighborParams& p) { p.eps = kInf; }).validate());
  EXPECT_THROW(bad([](NeighborParams& p) { p.eps_auto_factor = 0.0; }).validate(), ParamError);
  EXPECT_THROW(bad([](NeighborParams& p) { p.eps_auto_factor = kInf; }).validate(), ParamError);

  const std::vector<Vec3> points = test::random_box(50, 0.0, 1.0, 1);
  EXPECT_THROW(build_neighborhoods(points, bad([](NeighborParams& p) { p.k = 0; })), ParamError);
  const KdTree tree(points);
  const std::vector<Index> queries = {0, 1};
  EXPECT_THROW(build_neighborhoods(tree, queries, 0, 1.0), ParamError);
  EXPECT_THROW(build_neighborhoods(tree, queries, 8, 0.0), ParamError);
  EXPECT_THROW(build_neighborhoods(tree, queries, 8, -1.0), ParamError);
}

}  // namespace
}  // namespace pointfair
