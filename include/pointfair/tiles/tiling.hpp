#pragma once
// Spatial tiles: a partition of a cloud into boxes of bounded point count, the unit of
// out-of-core work. Rows of a tiled cloud are grouped by tile; inside a tile they follow the
// depth-first order of small kd cells (near in space, near in memory). Results never depend
// on the row order: neighbour lists are built over arrays sorted by original index (the tie
// rule of the canonical order) and each point's step depends only on its own list.
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "pointfair/types.hpp"

namespace pointfair::tiles {

struct TilingParams {
  /// Most points in a tile (kd splitting). Tiles hold between about half of it and it.
  std::uint64_t max_tile_points = 1u << 19;
  /// > 0: a regular grid of cubic cells of this edge length (length unit of the cloud)
  /// instead of kd splitting; every cell of the grid's bounding box is a tile, empty or not.
  /// The grid must have at most 2^22 cells.
  double cell_size = 0.0;

  void validate() const;
};

/// Bounds of a tile's points: min x, y, z then max x, y, z. An empty tile has min = +inf and
/// max = -inf, so it intersects nothing.
using Box = std::array<double, 6>;

struct Tiling {
  /// Row r of the tiled cloud is input point order[r].
  std::vector<std::uint64_t> order;
  /// Tile t holds rows [offsets[t], offsets[t + 1]).
  std::vector<std::uint64_t> offsets;
  /// Bounds of each tile's points.
  std::vector<Box> bounds;

  std::size_t tile_count() const { return bounds.size(); }
};

/// Tiles `points` (in memory). Kd splitting halves the longest side of a tile's point bounds
/// at the median (ties by index) until a tile holds at most max_tile_points; tiles follow
/// the depth-first order of the splits, so neighbouring rows are near in space.
/// Throws ParamError on bad parameters.
Tiling make_tiling(std::span<const Vec3> points, const TilingParams& params);

/// The bounds of `points`.
Box bounds_of(std::span<const Vec3> points);

/// True when box `a` grown by `margin` on every side intersects box `b` (closed boxes).
bool intersects(const Box& a, double margin, const Box& b);

}  // namespace pointfair::tiles
