#include "pointfair/neighbors/coarse_sample.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "pointfair/common/params_error.hpp"

namespace pointfair {

double CoarseCells::edge() const {
  return grid.scale > 0.0 ? std::ldexp(1.0, bits) / grid.scale : std::numeric_limits<double>::infinity();
}

CoarseCells coarse_cells(const MortonGrid& grid, double edge) {
  CoarseCells cells{grid, 21};
  if (!(edge > 0.0) || !std::isfinite(edge)) return cells;
  const double quanta = edge * grid.scale;
  cells.bits = 0;
  while (cells.bits < 21 && std::ldexp(1.0, cells.bits + 1) <= quanta) ++cells.bits;
  return cells;
}

std::vector<Index> coarse_sample(std::span<const Vec3> points, const CoarseCells& cells, int ratio) {
  require(ratio >= 1, "coarse sample ratio must be >= 1, got " + std::to_string(ratio));
  // In Morton order on the cells' grid, each cell's points are together (a cell is a block of
  // codes), ranked by code, then index.
  const std::vector<Index> order = spatial_order(points, cells.grid);
  std::vector<Index> sample;
  sample.reserve(order.size() / static_cast<std::size_t>(ratio) + 1);
  std::size_t rank = 0;
  std::uint64_t cell = 0;
  for (std::size_t s = 0; s < order.size(); ++s) {
    const std::uint64_t c = cells.cell_of(points[order[s]]);
    if (s == 0 || c != cell) rank = 0;
    cell = c;
    if (rank % static_cast<std::size_t>(ratio) == 0) sample.push_back(order[s]);
    ++rank;
  }
  std::sort(sample.begin(), sample.end());
  return sample;
}

}  // namespace pointfair
