#pragma once
// Exact k-nearest neighbour lists of many points at once through a uniform grid of cubic
// cells (a cell list): the fast path behind build_neighborhoods.
//
// The lists are the k-d tree's, bit for bit: for each query the k nearest other points with
// squared distance <= eps^2 (summed in the order x, y, z), ordered by squared distance, ties
// by the smaller index. The points are sorted by cell; the queries of one cell are searched
// together against the points of the 3 x 3 x 3 block of cells around it: squared distances in
// one loop the compiler vectorises, a threshold refined by vectorised counts, and the few
// candidates within it packed and sorted by rank (knn_select.hpp), the query itself included
// as in the tree (more than 64 within it, e.g. stacks of duplicates: a sorted insertion). A
// result is accepted when its (k+1)-th distance, or eps when fewer are found, is below the
// distance from the query to the block's boundary. Otherwise the query also searches the cells
// beyond the block that meet the box of that radius around it, which settles it exactly; a
// query that finds fewer than k + 1 points with no bound tries the 5 x 5 x 5 and 7 x 7 x 7
// blocks. The queries left (points far off a thickly noisy surface, blocks denser than their
// budget of points) are searched one at a time in blocks of up to 49 x 49 x 49 cells, and the
// few still left by the k-d tree (or a scan of every point when only a few such queries are
// left). Comparisons against the block's boundary keep margins far above the rounding of the
// cell coordinates, so a far offset (UTM-like coordinates) cannot make a list inexact.
//
// Cell size: 1.1 times the distance to the k-th nearest point at 16 evenly strided probe points
// (their median; on large clouds measured among every second or fourth point), or eps (slightly
// enlarged) when that is smaller. It only affects the speed, never the lists. Cell keys use 21
// bits per axis inside a window centred on the points' median; points outside the window are
// clamped into the border cells. The grid keeps only occupied cells (at most one per point),
// so a far outlier neither costs memory nor coarsens the cells of the rest of the cloud.
//
// Thread-safety: building and searching run parallel_for inside; a built grid is read-only
// and may be searched concurrently. The lists do not depend on the number of threads.
#include <cstdint>
#include <span>
#include <vector>

#include "pointfair/neighbors/neighbor_lists.hpp"
#include "pointfair/types.hpp"

namespace pointfair {

class KdTree;

/// Points sorted by cell. Read-only after build_cell_grid.
struct CellGrid {
  std::span<const Vec3> points;  ///< the caller's points (not copied; must outlive the grid)
  double cell = 0.0;             ///< cell edge length; +infinity: one cell holds every point
  double inverse_cell = 0.0;     ///< 1 / cell (0 for one cell)
  double origin[3] = {0.0, 0.0, 0.0};
  std::int64_t dims[3] = {1, 1, 1};  ///< cells per axis, at most 2^21 each
  std::vector<Index> order;          ///< sorted position -> point index (by cell, then index)
  std::vector<double> x, y, z;       ///< coordinates in sorted order
  std::vector<std::uint64_t> keys;   ///< occupied cells, ascending: (cz * dims[1] + cy) * dims[0] + cx
  std::vector<Index> starts;         ///< cell c holds sorted positions starts[c] .. starts[c+1]-1

  std::size_t size() const { return order.size(); }
};

/// Sorts `points` into a grid whose cell size suits searches for k neighbours within eps
/// (eps = +infinity: no bound). Throws ParamError for k outside 1..1024, eps <= 0 or NaN, a
/// non-finite coordinate, or 2^32-1 points or more.
CellGrid build_cell_grid(std::span<const Vec3> points, int k, double eps);

/// Row r: the k nearest other points of grid.points[queries[r]] within eps (ordered by
/// distance, ties by smaller index; counts < k where fewer qualify). `tree`, if given, is a
/// k-d tree over the same points and answers the queries the grid cannot settle; without it
/// the grid scans or builds a tree when needed.
Neighborhoods grid_neighborhoods(const CellGrid& grid, std::span<const Index> queries, int k,
                                 double eps, const KdTree* tree = nullptr);
/// The same rows into `out`, whose arrays' storage is reused (a caller that asks for block
/// after block of rows allocates them once).
void grid_neighborhoods(const CellGrid& grid, std::span<const Index> queries, int k, double eps,
                        Neighborhoods& out, const KdTree* tree = nullptr);

/// Every point's row: row p, or row row_of[p] when `row_of` (a permutation of 0..n-1) is given.
/// Indices in the lists refer to grid.points either way. If `last_d2` is given (one value per
/// row), it receives the squared distance of the last of the k + 1 nearest points within eps,
/// the point itself included: with eps = +infinity, the (k+1)-th nearest (resolve_eps's
/// measure), and the value to test before cutting a row at a smaller eps.
Neighborhoods grid_neighborhoods(const CellGrid& grid, int k, double eps,
                                 std::span<const Index> row_of = {},
                                 std::span<double> last_d2 = {});

}  // namespace pointfair
