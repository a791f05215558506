#pragma once
// The coarse level's sample (SmoothParams::coarse): every ratio-th point in Morton order within
// each cell of a grid a few sample spacings wide. As even as every ratio-th point of the whole
// cloud's Morton order (a sample drawn by a hash of the index was not: the 1M-point fandisk at
// 0.5% noise, RMS 0.658 against 0.604, docs/coarse-level.md), but a tile holding the cells
// around it ranks them alone: the sample of the points of a cell depends on those points only.
#include <cstdint>
#include <span>
#include <vector>

#include "pointfair/neighbors/spatial_order.hpp"
#include "pointfair/types.hpp"

namespace pointfair {

/// The cells of a coarse sample: aligned blocks of the Morton grid, 2^bits quanta on a side,
/// so that a point's cell is its Morton code shifted right by 3 bits.
struct CoarseCells {
  MortonGrid grid;
  int bits = 0;  ///< 0..21
  std::uint64_t cell_of(const Vec3& p) const { return morton_code(grid, p) >> (3 * bits); }
  /// The edge of a cell (length units); infinite when the grid has no extent.
  double edge() const;
};

/// Cells of `grid` whose edge is the largest power of two quanta at most `edge` (at least one
/// quantum); one cell for the whole grid when `edge` is not positive and finite.
CoarseCells coarse_cells(const MortonGrid& grid, double edge);

/// The points of rank 0, ratio, 2 ratio, ... (ratio >= 1) within their cell, the points of a
/// cell ranked by Morton code, then index: their indices, ascending. Every cell of m points
/// gives ceil(m / ratio).
std::vector<Index> coarse_sample(std::span<const Vec3> points, const CoarseCells& cells, int ratio);

}  // namespace pointfair
