// nearest_points (the samples of the automatic eps and k out of core) against one k-d tree
// query per point, bit for bit: on a noisy surface, on an integer grid (many equal
// distances), with exact duplicates (more than `want` of some points, of smaller and of
// larger index), for want from 1 to more than the cloud holds.
#include "pointfair/neighbors/nearest_points.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <numeric>
#include <vector>

#include "pointfair/common/params_error.hpp"
#include "pointfair/neighbors/kd_tree.hpp"
#include "support/clouds.hpp"

using namespace pointfair;

namespace {

void expect_like_kd_tree(const std::vector<Vec3>& points, int want) {
  std::vector<Index> queries(points.size());
  std::iota(queries.begin(), queries.end(), Index{0});
  const NearestPoints near = nearest_points(points, queries, want);
  const KdTree tree(points);
  std::vector<Index> idx(static_cast<std::size_t>(want));
  std::vector<double> d2(static_cast<std::size_t>(want));
  for (std::size_t r = 0; r < points.size(); ++r) {
    const int found = tree.nearest(points[r], want, std::numeric_limits<double>::infinity(), idx.data(), d2.data());
    ASSERT_EQ(near.counts[r], found) << "query " << r << ", want " << want;
    for (int j = 0; j < found; ++j) {
      ASSERT_EQ(near.indices_of(r)[static_cast<std::size_t>(j)], idx[static_cast<std::size_t>(j)])
          << "query " << r << ", slot " << j << ", want " << want;
      const double a = near.distances2_of(r)[static_cast<std::size_t>(j)], b = d2[static_cast<std::size_t>(j)];
      ASSERT_EQ(0, std::memcmp(&a, &b, sizeof(double))) << "query " << r << ", slot " << j;
    }
  }
}

TEST(NearestPointsTest, NoisySurfaceLikeTheKdTree) {
  const std::vector<Vec3> points = test::noisy_cube(3000, 0.01, 5);
  for (const int want : {1, 2, 17, 49, 129}) expect_like_kd_tree(points, want);
}

TEST(NearestPointsTest, IntegerGridTiesLikeTheKdTree) {
  const std::vector<Vec3> points = test::integer_grid(9, 3);
  for (const int want : {2, 7, 27}) expect_like_kd_tree(points, want);
}

TEST(NearestPointsTest, ExactDuplicatesLikeTheKdTree) {
  std::vector<Vec3> points = test::noisy_cube(1500, 0.01, 8);
  // 60 copies of point 11 after index 700 (more than `want` of smaller index for the last of
  // them), and 5 copies of point 900 before it.
  points.insert(points.begin() + 700, 60, points[11]);
  points.insert(points.begin() + 300, 5, points[960]);
  for (const int want : {2, 5, 6, 17, 49, 70}) expect_like_kd_tree(points, want);
}

TEST(NearestPointsTest, TinyCloudsAndQuerySubsets) {
  for (const std::size_t n : {1u, 2u, 3u, 10u}) {
    const std::vector<Vec3> points = test::noisy_cube(n, 0.01, 9);
    for (const int want : {1, 2, 4, 20}) expect_like_kd_tree(points, want);
  }
  const std::vector<Vec3> points = test::noisy_cube(500, 0.01, 10);
  const std::vector<Index> queries = {499, 3, 3, 250};
  const NearestPoints near = nearest_points(points, queries, 9);
  ASSERT_EQ(near.counts.size(), 4u);
  EXPECT_EQ(near.indices_of(0)[0], 499u);
  EXPECT_EQ(near.indices_of(1)[0], 3u);
  EXPECT_EQ(std::vector<Index>(near.indices_of(1).begin(), near.indices_of(1).end()),
            std::vector<Index>(near.indices_of(2).begin(), near.indices_of(2).end()));
  EXPECT_THROW(nearest_points(points, queries, 0), ParamError);
  EXPECT_THROW(nearest_points(points, std::vector<Index>{500}, 3), ParamError);
}

}  // namespace
