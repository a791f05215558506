// The cell-grid k-nearest search against the brute-force oracle and the k-d tree path: the
// same lists bit for bit (canonical order, ties by the smaller index, self excluded, the eps
// bound d^2 <= eps^2, short rows), on random clouds, surfaces with edges, duplicates, lattice
// ties and degenerate clouds (identical, collinear, coplanar, far from the origin, tiny, empty,
// one far outlier), for any thread count.
#include "pointfair/neighbors/knn_grid.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numeric>
#include <string>
#include <vector>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/neighbors/kd_tree.hpp"
#include "pointfair/neighbors/neighborhoods.hpp"
#include "support/clouds.hpp"
#include "support/reference.hpp"

namespace pointfair {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::vector<Index> every_index(std::size_t n) {
  std::vector<Index> all(n);
  std::iota(all.begin(), all.end(), Index{0});
  return all;
}

std::vector<Index> row(const Neighborhoods& nb, std::size_t r) {
  const auto span = nb.of(r);
  return {span.begin(), span.end()};
}

// Every row equals the k-d tree path's row; every `oracle_stride`-th row also the oracle's.
void expect_exact(std::span<const Vec3> points, const Neighborhoods& nb, int k, double eps,
                  std::size_t oracle_stride = 1, const std::string& what = "") {
  ASSERT_EQ(nb.size(), points.size()) << what;
  ASSERT_EQ(nb.stride, k) << what;
  EXPECT_EQ(nb.eps, eps) << what;
  const KdTree tree(points);
  const std::vector<Index> all = every_index(points.size());
  const Neighborhoods kd = build_neighborhoods_kd_tree(tree, all, k, eps);
  EXPECT_EQ(nb.counts, kd.counts) << what;
  EXPECT_EQ(nb.indices, kd.indices) << what << " (unused slots are 0 in both)";
  for (std::size_t i = 0; i < points.size(); i += oracle_stride) {
    ASSERT_EQ(row(nb, i), test::ref::neighbors(points, i, k, eps)) << what << " point " << i;
  }
}

void expect_grid_exact(std::span<const Vec3> points, int k, double eps,
                       std::size_t oracle_stride = 1, const std::string& what = "") {
  const CellGrid grid = build_cell_grid(points, k, eps);
  EXPECT_LE(grid.keys.size(), std::max<std::size_t>(points.size(), 1)) << "at most one cell a point";
  for (int a = 0; a < 3; ++a) EXPECT_LE(grid.dims[a], std::int64_t{1} << 21);
  expect_exact(points, grid_neighborhoods(grid, k, eps), k, eps, oracle_stride,
               what + " k=" + std::to_string(k) + " eps=" + std::to_string(eps));
}

std::vector<Vec3> cube_surface(std::size_t n, double noise, std::uint64_t seed) {
  std::vector<Vec3> points = sample_mesh(cube_mesh(), n, seed).points;
  if (noise > 0) add_noise(points, noise * bounding_box_diagonal(points), seed + 1);
  return points;
}

TEST(KnnGrid, RandomCloudMatchesTreeAndOracle) {
  const std::vector<Vec3> points = test::random_box(3000, -1.0, 1.0, 5);
  for (const int k : {1, 2, 16, 64})
    for (const double eps : {kInf, 0.08, 0.2}) expect_grid_exact(points, k, eps, 11, "box");
}

TEST(KnnGrid, SurfaceWithEdgesMatchesTreeAndOracle) {
  for (const double noise : {0.0, 0.005}) {
    const std::vector<Vec3> points = cube_surface(4000, noise, 3);
    // 200: the finish's lists, more candidates than the rank sort takes.
    for (const int k : {1, 2, 16, 64, 200})
      for (const double eps : {kInf, 0.05}) expect_grid_exact(points, k, eps, 13, "cube surface");
  }
}

TEST(KnnGrid, DuplicatesAndStacksLargerThanK) {
  std::vector<Vec3> points = test::random_box(1500, 0.0, 1.0, 8);
  for (std::size_t i = 0; i < 300; i += 3) points.push_back(points[i]);
  // A stack of 80 coincident points: more than k + 1 copies, so a copy's nearest k + 1 points
  // need not include itself.
  for (int i = 0; i < 80; ++i) points.push_back(points[17]);
  for (const int k : {1, 2, 16, 64, 200})
    for (const double eps : {kInf, 0.1}) expect_grid_exact(points, k, eps, 7, "duplicates");
}

TEST(KnnGrid, LatticeTiesBrokenBySmallerIndex) {
  // Shuffled integer lattice: many points at exactly equal distances, and eps exactly on them.
  const std::vector<Vec3> points = test::integer_grid(12, 4);
  for (const int k : {1, 2, 16, 64, 200})
    for (const double eps : {kInf, 1.0, std::sqrt(2.0), 2.0})
      expect_grid_exact(points, k, eps, 5, "lattice");
  // The same lattice scaled by a non-power of two (inexact squared distances) and far away.
  std::vector<Vec3> far = points;
  for (Vec3& p : far) p = p * 0.3 + Vec3(512345.0, 4123456.0, 321.0);
  for (const int k : {6, 16}) expect_grid_exact(far, k, kInf, 5, "far lattice");
}

TEST(KnnGrid, DegenerateClouds) {
  // All points identical: more points than the grid will search in one block.
  expect_grid_exact(std::vector<Vec3>(3000, Vec3(1.0, -2.0, 3.0)), 16, kInf, 97, "identical");
  expect_grid_exact(std::vector<Vec3>(50, Vec3(1.0, -2.0, 3.0)), 16, 0.5, 1, "identical small");
  // Collinear.
  std::vector<Vec3> line;
  for (int i = 0; i < 2000; ++i) line.emplace_back(0.001 * i, 0.002 * i, -0.001 * i);
  for (const int k : {2, 16}) expect_grid_exact(line, k, kInf, 9, "collinear");
  // Coplanar, and the same plane at UTM-like coordinates.
  std::vector<Vec3> plane = test::random_plane(3000, 50.0, 9);
  for (const int k : {2, 16}) expect_grid_exact(plane, k, kInf, 9, "coplanar");
  for (Vec3& p : plane) p += Vec3(654321.25, 5432109.5, 87.0);
  for (const int k : {2, 16}) {
    expect_grid_exact(plane, k, kInf, 9, "utm plane");
    expect_grid_exact(plane, k, 2.0, 9, "utm plane, eps");
  }
}

TEST(KnnGrid, TinyAndEmptyClouds) {
  for (const std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{2}, std::size_t{5}, std::size_t{17}}) {
    const std::vector<Vec3> points = test::random_box(n, 0.0, 1.0, 40 + n);
    for (const int k : {1, 16, 64})
      for (const double eps : {kInf, 0.5}) expect_grid_exact(points, k, eps, 1, "tiny");
  }
}

TEST(KnnGrid, FarOutlierNeitherCostsMemoryNorChangesTheLists) {
  std::vector<Vec3> points = cube_surface(5000, 0.002, 12);
  points.emplace_back(3.0e9, -1.0e9, 2.0e9);  // one point very far away
  points.emplace_back(-4.0e8, 1.0, 1.0);
  for (const int k : {1, 16}) {
    const CellGrid grid = build_cell_grid(points, k, kInf);
    // The cells still fit the cloud: the far points are clamped into the border cells.
    EXPECT_LT(grid.cell, 0.2);
    expect_grid_exact(points, k, kInf, 23, "outlier");
    expect_grid_exact(points, k, 0.1, 23, "outlier, eps");
  }
  // Many far points: more than a scan would answer, so the fallback builds a k-d tree.
  std::vector<Vec3> spread = cube_surface(3000, 0.0, 13);
  for (int i = 0; i < 100; ++i) spread.emplace_back(1e7 + 1e5 * i, -3e6 * i, 5e5);
  expect_grid_exact(spread, 16, kInf, 17, "many outliers");
}

// Points 10 to 25 cells off the surface, and a cluster denser than a block's budget: the first
// search leaves them, the wide blocks settle them (before any k-d tree), and the lists stay exact.
TEST(KnnGrid, PointsFarOffTheSurfaceAndDenseClustersStayExact) {
  std::vector<Vec3> points = cube_surface(8000, 0.002, 21);
  const double cell = build_cell_grid(points, 16, kInf).cell;
  for (int i = 0; i < 60; ++i) {
    const double off = (10.0 + 0.25 * i) * cell;  // beyond 3 rings, within the wide ones
    const double t = -0.8 + 0.027 * i;
    points.emplace_back(i % 3 == 0 ? 1.0 + off : t, i % 3 == 1 ? -1.0 - off : t, i % 3 == 2 ? 1.0 + off : 0.5 * t);
  }
  for (int i = 0; i < 2500; ++i)  // a cluster far denser than the surface, more than a block holds
    points.emplace_back(0.3 + 1e-5 * (i % 17), -1.0 + 1e-5 * (i % 13), 0.2 + 1e-5 * (i % 11));
  for (const int k : {8, 16}) {
    expect_grid_exact(points, k, kInf, 61, "far points");
    expect_grid_exact(points, k, 0.5, 61, "far points, eps");
  }
}

TEST(KnnGrid, QueriesSubsetWithTreeEqualsFullRows) {
  const std::vector<Vec3> points = cube_surface(4000, 0.003, 21);
  const KdTree tree(points);
  std::vector<Index> queries;
  for (Index i = 0; i < points.size(); i += 5) queries.push_back(i);
  queries.push_back(3);  // out of order and repeated
  queries.push_back(3);
  for (const double eps : {kInf, 0.04}) {
    const CellGrid grid = build_cell_grid(points, 16, eps);
    const Neighborhoods full = grid_neighborhoods(grid, 16, eps);
    const Neighborhoods part = grid_neighborhoods(grid, queries, 16, eps, &tree);
    const Neighborhoods kd = build_neighborhoods_kd_tree(tree, queries, 16, eps);
    ASSERT_EQ(part.size(), queries.size());
    EXPECT_EQ(part.indices, kd.indices);
    EXPECT_EQ(part.counts, kd.counts);
    for (std::size_t r = 0; r < queries.size(); ++r) EXPECT_EQ(row(part, r), row(full, queries[r]));
    // The public tile overload takes the same path.
    const Neighborhoods tiles = build_neighborhoods(tree, queries, 16, eps);
    EXPECT_EQ(tiles.indices, kd.indices);
  }
}

TEST(KnnGrid, SameListsForAnyThreadCount) {
  const std::vector<Vec3> points = cube_surface(20000, 0.005, 31);
  set_thread_count(1);
  const Neighborhoods one = build_neighborhoods(points, {.k = 16});
  set_thread_count(2);
  const Neighborhoods two = build_neighborhoods(points, {.k = 16});
  set_thread_count(0);
  const Neighborhoods all = build_neighborhoods(points, {.k = 16});
  EXPECT_EQ(one.indices, two.indices);
  EXPECT_EQ(one.counts, two.counts);
  EXPECT_EQ(one.indices, all.indices);
  EXPECT_EQ(one.eps, all.eps);
}

TEST(KnnGrid, AutomaticEpsAndRowPermutationMatchTheTreePath) {
  std::vector<Vec3> points = cube_surface(6000, 0.004, 41);
  points.emplace_back(40.0, 40.0, 40.0);  // a point whose list the eps bound cuts to nothing
  const KdTree tree(points);
  const std::vector<Index> all = every_index(points.size());
  for (const int k : {2, 16}) {
    for (const double factor : {2.0, 0.7}) {
      NeighborParams params;
      params.k = k;
      params.eps_auto_factor = factor;
      const double eps = resolve_eps(points, tree, params);
      const Neighborhoods kd = build_neighborhoods_kd_tree(tree, all, k, eps);
      const Neighborhoods nb = build_neighborhoods(points, params);
      EXPECT_EQ(nb.eps, eps) << "the same automatic eps, bit for bit";
      EXPECT_EQ(nb.indices, kd.indices);
      EXPECT_EQ(nb.counts, kd.counts);
      EXPECT_EQ(nb.counts.back(), 0);
      // Rows permuted: point p's list in row row_of[p].
      std::vector<Index> row_of(points.size());
      for (std::size_t p = 0; p < points.size(); ++p)
        row_of[p] = static_cast<Index>((p * 7919 + 13) % points.size());
      const Neighborhoods permuted = build_neighborhoods(points, params, row_of);
      EXPECT_EQ(permuted.eps, eps);
      for (std::size_t p = 0; p < points.size(); p += 3) EXPECT_EQ(row(permuted, row_of[p]), row(kd, p));
    }
  }
}

TEST(KnnGrid, ClustersEmptyCellsAndAnisotropicBoxes) {
  // Tight clusters far apart: most cells of the grid empty, and cells with many more points
  // than k around them.
  std::vector<Vec3> clusters;
  for (int c = 0; c < 6; ++c) {
    const Vec3 centre(3.0 * c, -2.0 * (c % 2), 1.5 * (c % 3));
    for (const Vec3& p : test::random_box(300 + 50 * static_cast<std::size_t>(c), -0.01, 0.01, 60 + static_cast<std::uint64_t>(c)))
      clusters.push_back(centre + p * (1.0 + c));
  }
  for (const int k : {2, 16})
    for (const double eps : {kInf, 0.004, 0.05}) expect_grid_exact(clusters, k, eps, 7, "clusters");
  // Boxes far longer on one or two axes than on the others: a needle and a flat slab.
  std::vector<Vec3> needle = test::random_box(3000, 0.0, 1.0, 61);
  for (Vec3& p : needle) p = Vec3(p.x() * 1000.0, p.y() * 0.01, p.z() * 0.02);
  std::vector<Vec3> slab = test::random_box(3000, 0.0, 1.0, 62);
  for (Vec3& p : slab) p = Vec3(p.x() * 50.0, p.y() * 30.0, p.z() * 1e-4);
  for (const int k : {1, 16}) {
    expect_grid_exact(needle, k, kInf, 9, "needle");
    expect_grid_exact(needle, k, 0.5, 9, "needle, eps");
    expect_grid_exact(slab, k, kInf, 9, "slab");
    expect_grid_exact(slab, k, 0.6, 9, "slab, eps");
  }
}

TEST(KnnGrid, EpsCutsRowsShortAndTiesAtEps) {
  // Lattice spacing 1 with eps exactly at a neighbour distance and just below it: rows end
  // precisely at the bound (d^2 <= eps^2), and equal distances keep the smaller index first.
  const std::vector<Vec3> lattice = test::integer_grid(9, 7);
  for (const double eps : {0.999999, 1.0, std::sqrt(3.0), 1.5})
    expect_grid_exact(lattice, 16, eps, 3, "lattice cut");
  // Duplicated points (pairs and a stack) with an eps that cuts most rows before k.
  std::vector<Vec3> dup = test::random_box(2000, 0.0, 1.0, 63);
  for (std::size_t i = 0; i < 2000; i += 2) dup.push_back(dup[i]);
  for (int i = 0; i < 30; ++i) dup.push_back(dup[5]);
  for (const double eps : {0.01, 0.03, kInf}) expect_grid_exact(dup, 16, eps, 5, "duplicates cut");
  const CellGrid grid = build_cell_grid(dup, 16, 0.03);
  const Neighborhoods nb = grid_neighborhoods(grid, 16, 0.03);
  std::size_t short_rows = 0;
  for (const std::uint16_t c : nb.counts) short_rows += c < 16 ? 1 : 0;
  EXPECT_GT(short_rows, nb.size() / 4) << "eps must really cut rows here";
}

TEST(KnnGrid, RejectsBadInput) {
  const std::vector<Vec3> points = test::random_box(100, 0.0, 1.0, 2);
  EXPECT_THROW(build_cell_grid(points, 0, kInf), ParamError);
  EXPECT_THROW(build_cell_grid(points, 1025, kInf), ParamError);
  EXPECT_THROW(build_cell_grid(points, 8, 0.0), ParamError);
  EXPECT_THROW(build_cell_grid(points, 8, std::nan("")), ParamError);
  std::vector<Vec3> bad = points;
  bad[42].y() = std::nan("");
  try {
    build_cell_grid(bad, 8, kInf);
    FAIL() << "a NaN coordinate was accepted";
  } catch (const ParamError& e) {
    EXPECT_NE(std::string(e.what()).find("point 42 has a non-finite coordinate"), std::string::npos);
  }
  const CellGrid grid = build_cell_grid(points, 8, kInf);
  const std::vector<Index> outside = {3, 100};
  EXPECT_THROW(grid_neighborhoods(grid, outside, 8, kInf), ParamError);
  EXPECT_THROW(grid_neighborhoods(grid, 8, -1.0), ParamError);
  const std::vector<Index> short_rows(5, 0);
  EXPECT_THROW(grid_neighborhoods(grid, 8, kInf, short_rows), ParamError);
}

}  // namespace
}  // namespace pointfair
