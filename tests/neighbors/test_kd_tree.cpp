// KdTree::nearest against a brute-force oracle: canonical order (distance, then smaller index),
// the radius bound, duplicates and exact ties.
#include "pointfair/neighbors/kd_tree.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <utility>
#include <vector>

#include "support/clouds.hpp"
#include "support/reference.hpp"

namespace pointfair {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The k nearest points of `query` among all points (itself included), canonical order.
std::vector<std::pair<double, Index>> brute_nearest(std::span<const Vec3> points, const Vec3& query,
                                                    int k, double max_d2) {
  std::vector<std::pair<double, Index>> all;
  for (std::size_t j = 0; j < points.size(); ++j) {
    const double d2 = test::ref::distance2(query, points[j]);
    if (d2 <= max_d2) all.emplace_back(d2, static_cast<Index>(j));
  }
  std::sort(all.begin(), all.end());
  if (all.size() > static_cast<std::size_t>(k)) all.resize(static_cast<std::size_t>(k));
  return all;
}

void expect_matches_oracle(const KdTree& tree, std::span<const Vec3> points, const Vec3& query,
                           int k, double max_d2) {
  std::vector<Index> idx(static_cast<std::size_t>(k));
  std::vector<double> d2(static_cast<std::size_t>(k));
  const int found = tree.nearest(query, k, max_d2, idx.data(), d2.data());
  const auto expected = brute_nearest(points, query, k, max_d2);
  ASSERT_EQ(static_cast<std::size_t>(found), expected.size()) << "k=" << k << " max_d2=" << max_d2;
  for (std::size_t j = 0; j < expected.size(); ++j) {
    EXPECT_EQ(idx[j], expected[j].second) << "slot " << j << " k=" << k;
    // Same formula, same summation order: the squared distances agree exactly.
    EXPECT_EQ(d2[j], expected[j].first) << "slot " << j;
  }
}

TEST(KdTree, NearestMatchesBruteForceWithDuplicates) {
  std::vector<Vec3> points = test::random_box(1500, -1.0, 1.0, 11);
  // Duplicates: copies of earlier points appended (same coordinates, larger indices), and a
  // cluster of one point repeated many times.
  for (std::size_t i = 0; i < 300; i += 3) points.push_back(points[i]);
  for (int i = 0; i < 40; ++i) points.push_back(points[7]);
  const KdTree tree(points);
  test::Uniform u(12);
  for (const int k : {1, 5, 16, 41, 64}) {
    for (std::size_t q = 0; q < points.size(); q += 37) {
      expect_matches_oracle(tree, points, points[q], k, kInf);
      expect_matches_oracle(tree, points, points[q], k, 0.01);
    }
    // Queries off the cloud.
    for (int q = 0; q < 20; ++q) {
      const Vec3 query(u.in(-1.2, 1.2), u.in(-1.2, 1.2), u.in(-1.2, 1.2));
      expect_matches_oracle(tree, points, query, k, kInf);
      expect_matches_oracle(tree, points, query, k, 0.02);
    }
  }
  // The heavy duplicate cluster: 41 coincident points, smallest indices first.
  expect_matches_oracle(tree, points, points[7], 30, kInf);
}

TEST(KdTree, StackOfDuplicatesTiedWithTheWorstSpreadOverLeaves) {
  // 81 coincident points (more than a leaf holds) at the k-th distance of nearby queries: the
  // tree's summed node bounds may round above the tied distance, which must not prune the
  // leaves holding the stack's smaller indices.
  std::vector<Vec3> points = test::random_box(1500, 0.0, 1.0, 8);
  for (std::size_t i = 0; i < 300; i += 3) points.push_back(points[i]);
  for (int i = 0; i < 80; ++i) points.push_back(points[17]);
  const KdTree tree(points);
  for (const int k : {17, 65})
    for (std::size_t q = 0; q < points.size(); ++q) expect_matches_oracle(tree, points, points[q], k, kInf);
}

TEST(KdTree, TiesOnIntegerGridBrokenBySmallerIndex) {
  // Shells around an interior grid point: 6 at distance 1, 12 at sqrt 2, 8 at sqrt 3; every k
  // that cuts through a shell must keep the smallest indices of that shell.
  const std::vector<Vec3> points = test::integer_grid(7, 5);
  const KdTree tree(points);
  for (const int k : {1, 4, 7, 10, 19, 23, 27, 40}) {
    for (std::size_t q = 0; q < points.size(); ++q) expect_matches_oracle(tree, points, points[q], k, kInf);
  }
  // Half-integer queries: 8 grid points at exactly the same distance.
  for (const int k : {1, 3, 8, 9}) expect_matches_oracle(tree, points, Vec3(2.5, 3.5, 1.5), k, kInf);
}

TEST(KdTree, RadiusBoundIsInclusive) {
  // On the integer grid the first shell lies at squared distance exactly 1.
  const std::vector<Vec3> points = test::integer_grid(5, 9);
  const KdTree tree(points);
  std::vector<Index> idx(32);
  std::vector<double> d2(32);
  for (std::size_t q = 0; q < points.size(); ++q) {
    const Vec3& p = points[q];
    int interior_axes = 0;
    for (int a = 0; a < 3; ++a) interior_axes += (p[a] > 0.0) + (p[a] < 4.0);
    const int found = tree.nearest(p, 32, 1.0, idx.data(), d2.data());
    // The point itself plus one neighbour per open side.
    EXPECT_EQ(found, 1 + interior_axes);
    expect_matches_oracle(tree, points, p, 32, 1.0);
    // Just below 1 only the point itself remains.
    EXPECT_EQ(tree.nearest(p, 32, std::nextafter(1.0, 0.0), idx.data(), d2.data()), 1);
  }
}

TEST(KdTree, SmallAndEmptyInputs) {
  const std::vector<Vec3> three = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 2, 0)};
  const KdTree tree(three);
  std::vector<Index> idx(8);
  std::vector<double> d2(8);
  EXPECT_EQ(tree.nearest(Vec3(0, 0, 0), 8, kInf, idx.data(), d2.data()), 3);
  EXPECT_EQ(idx[0], 0u);
  EXPECT_EQ(idx[1], 1u);
  EXPECT_EQ(idx[2], 2u);
  EXPECT_EQ(d2[2], 4.0);
  EXPECT_EQ(tree.nearest(Vec3(0, 0, 0), 0, kInf, idx.data(), d2.data()), 0);
  EXPECT_EQ(tree.points().size(), 3u);
  EXPECT_EQ(tree.points().data(), three.data());  // a view, not a copy

  const std::vector<Vec3> none;
  const KdTree empty(none);
  EXPECT_EQ(empty.nearest(Vec3(0, 0, 0), 4, kInf, idx.data(), d2.data()), 0);
}

TEST(KdTree, LeafOrderIsAPermutation) {
  for (const std::size_t n : {0u, 1u, 17u, 3000u}) {
    const std::vector<Vec3> points = test::random_box(n, -1.0, 1.0, 8);
    const KdTree tree(points);
    const auto order = tree.leaf_order();
    ASSERT_EQ(order.size(), n);
    std::vector<Index> sorted(order.begin(), order.end());
    std::sort(sorted.begin(), sorted.end());
    for (std::size_t i = 0; i < n; ++i) EXPECT_EQ(sorted[i], i);
  }
}

TEST(KdTree, MovedTreeKeepsWorking) {
  const std::vector<Vec3> points = test::random_box(500, 0.0, 1.0, 3);
  KdTree first(points);
  KdTree moved(std::move(first));
  expect_matches_oracle(moved, points, points[10], 12, kInf);
  KdTree assigned(points);
  assigned = std::move(moved);
  expect_matches_oracle(assigned, points, points[20], 12, kInf);
}

}  // namespace
}  // namespace pointfair
