// Spatial tiles: a partition with bounded tile sizes and bounds that hold their points.
#include "pointfair/tiles/tiling.hpp"

#include <algorithm>

#include "pointfair/common/params_error.hpp"
#include "tiles_test_util.hpp"

using namespace pointfair;
using namespace pointfair::tiles;

namespace {

void expect_partition(const Tiling& t, std::span<const Vec3> points) {
  ASSERT_EQ(t.offsets.size(), t.tile_count() + 1);
  EXPECT_EQ(t.offsets.back(), points.size());
  std::vector<std::uint64_t> sorted = t.order;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t i = 0; i < sorted.size(); ++i) ASSERT_EQ(sorted[i], i);
  for (std::size_t tile = 0; tile < t.tile_count(); ++tile) {
    for (std::uint64_t r = t.offsets[tile]; r < t.offsets[tile + 1]; ++r) {
      const Vec3& p = points[t.order[r]];
      for (int c = 0; c < 3; ++c) {
        EXPECT_GE(p[c], t.bounds[tile][static_cast<std::size_t>(c)]);
        EXPECT_LE(p[c], t.bounds[tile][static_cast<std::size_t>(c) + 3]);
      }
    }
  }
}

TEST(Tiling, KdTilesAreBoundedAndPartition) {
  const auto cloud = test::noisy_cube(5000, 3);
  const Tiling t = make_tiling(cloud.positions, {.max_tile_points = 300});
  expect_partition(t, cloud.positions);
  for (std::size_t i = 0; i < t.tile_count(); ++i) {
    EXPECT_LE(t.offsets[i + 1] - t.offsets[i], 300u);
    EXPECT_GE(t.offsets[i + 1] - t.offsets[i], 150u);
  }
}

TEST(Tiling, GridKeepsEmptyTiles) {
  const auto cloud = test::noisy_cube(2000, 4);
  const Tiling t = make_tiling(cloud.positions, {.cell_size = 0.25});
  expect_partition(t, cloud.positions);
  std::size_t empty = 0;
  for (std::size_t i = 0; i < t.tile_count(); ++i) empty += t.offsets[i + 1] == t.offsets[i];
  EXPECT_GT(empty, 0u);  // the inside of the cube
  const Box none = bounds_of({});
  EXPECT_FALSE(intersects(none, 1e9, t.bounds[0]));
}

TEST(Tiling, EmptyCloudAndBadParameters) {
  const Tiling t = make_tiling({}, {});
  EXPECT_EQ(t.tile_count(), 1u);
  EXPECT_EQ(t.offsets, (std::vector<std::uint64_t>{0, 0}));
  EXPECT_THROW(make_tiling({}, {.max_tile_points = 0}), ParamError);
  EXPECT_THROW(make_tiling({}, {.cell_size = -1.0}), ParamError);
  const std::vector<Vec3> far{Vec3(0, 0, 0), Vec3(1e6, 1e6, 1e6)};
  EXPECT_THROW(make_tiling(far, {.cell_size = 1e-3}), ParamError);
}

}  // namespace
