// The coarse level's sample: every ratio-th point in Morton order within each cell. Each cell
// gives its share, the sample depends on the points and not on their rows, and a tile with the
// cells around it draws the whole cloud's sample of its own points (what lets tiles draw it).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <map>
#include <numeric>
#include <random>
#include <vector>

#include "pointfair/neighbors/coarse_sample.hpp"
#include "pointfair/neighbors/neighborhood_size.hpp"
#include "support/clouds.hpp"

namespace pointfair {
namespace {

std::vector<Vec3> positions_of(const std::vector<Vec3>& points, const std::vector<Index>& rows) {
  std::vector<Vec3> out;
  for (const Index r : rows) out.push_back(points[r]);
  std::sort(out.begin(), out.end(), [](const Vec3& a, const Vec3& b) {
    return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
  });
  return out;
}

CoarseCells cells_of(const std::vector<Vec3>& points, double spacings) {
  return coarse_cells(morton_grid(points), spacings * estimate_noise(points).spacing);
}

TEST(CoarseSample, CellsAreThePowerOfTwoAtMostTheEdge) {
  const MortonGrid grid = morton_grid(Vec3(0, 0, 0), Vec3(2, 1, 1));
  for (const double edge : {1e-5, 0.01, 0.3, 1.5}) {
    const CoarseCells cells = coarse_cells(grid, edge);
    EXPECT_LE(cells.edge(), edge) << edge;
    EXPECT_GT(cells.edge(), edge / 2) << edge;
  }
  // Below one quantum: one quantum; none given: the whole grid in one cell.
  EXPECT_EQ(coarse_cells(grid, 1e-9).bits, 0);
  EXPECT_EQ(coarse_cells(grid, 0.0).bits, 21);
  EXPECT_EQ(coarse_cells(grid, std::numeric_limits<double>::quiet_NaN()).bits, 21);
}

TEST(CoarseSample, EveryCellGivesItsShare) {
  const std::vector<Vec3> points = test::noisy_cube(6000, 0.01, 3);
  const CoarseCells cells = cells_of(points, 8.0);
  ASSERT_LT(cells.bits, 21);
  for (const int ratio : {1, 2, 3}) {
    const std::vector<Index> sample = coarse_sample(points, cells, ratio);
    ASSERT_TRUE(std::is_sorted(sample.begin(), sample.end()));
    ASSERT_TRUE(std::adjacent_find(sample.begin(), sample.end()) == sample.end());
    std::map<std::uint64_t, std::size_t> in_cell, drawn;
    for (const Vec3& p : points) ++in_cell[cells.cell_of(p)];
    for (const Index i : sample) ++drawn[cells.cell_of(points[i])];
    EXPECT_GT(in_cell.size(), 50u);
    for (const auto& [cell, m] : in_cell)
      EXPECT_EQ(drawn[cell], (m + static_cast<std::size_t>(ratio) - 1) / static_cast<std::size_t>(ratio)) << ratio;
  }
}

TEST(CoarseSample, DependsOnThePointsNotTheirRows) {
  const std::vector<Vec3> points = test::noisy_cube(4000, 0.01, 5);
  std::vector<Index> rows(points.size());
  std::iota(rows.begin(), rows.end(), Index{0});
  std::shuffle(rows.begin(), rows.end(), std::mt19937_64(7));
  std::vector<Vec3> shuffled(points.size());
  for (std::size_t r = 0; r < rows.size(); ++r) shuffled[r] = points[rows[r]];
  const CoarseCells cells = cells_of(points, 8.0);
  EXPECT_EQ(positions_of(points, coarse_sample(points, cells, 2)),
            positions_of(shuffled, coarse_sample(shuffled, cells, 2)));
}

TEST(CoarseSample, ATileWithTheCellsAroundItDrawsTheCloudsSample) {
  const std::vector<Vec3> points = test::noisy_cube(8000, 0.01, 9);
  const CoarseCells cells = cells_of(points, 4.0);
  ASSERT_LT(cells.edge(), 0.2);
  // The tile: x below 0.1; its halo: the points within one cell's edge beyond it, which holds
  // every point that shares a cell with a point of the tile.
  const double cut = 0.1;
  std::vector<Vec3> local;
  std::vector<char> in_tile;
  for (const Vec3& p : points)
    if (p.x() < cut + cells.edge()) {
      local.push_back(p);
      in_tile.push_back(p.x() < cut);
    }
  ASSERT_LT(local.size(), points.size());
  std::vector<Index> tile_rows, whole_rows;
  for (const Index i : coarse_sample(local, cells, 2))
    if (in_tile[i]) tile_rows.push_back(i);
  for (const Index i : coarse_sample(points, cells, 2))
    if (points[i].x() < cut) whole_rows.push_back(i);
  EXPECT_GT(tile_rows.size(), 1000u);
  EXPECT_EQ(positions_of(local, tile_rows), positions_of(points, whole_rows));
  // Without the halo the cells cut by the tile's border rank other points first.
  std::vector<Vec3> bare;
  for (const Vec3& p : points)
    if (p.x() < cut) bare.push_back(p);
  EXPECT_NE(positions_of(bare, coarse_sample(bare, cells, 2)), positions_of(points, whole_rows));
}

}  // namespace
}  // namespace pointfair
