#include "pointfair/neighbors/coarse_sample.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "pointfair/common/parallel.hpp"
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
  const std::size_t n = points.size();
  std::vector<std::pair<std::uint64_t, Index>> keyed(n);
  parallel_for(n, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) keyed[i] = {morton_code(cells.grid, points[i]), static_cast<Index>(i)};
  }, 8192);
  // Sorted by (code, index), each cell's points are together (a cell is a block of codes).
  std::sort(keyed.begin(), keyed.end());
  const int shift = 3 * cells.bits;
  std::vector<Index> sample;
  sample.reserve(n / static_cast<std::size_t>(ratio) + 1);
  std::size_t rank = 0;
  for (std::size_t s = 0; s < n; ++s) {
    if (s == 0 || keyed[s].first >> shift != keyed[s - 1].first >> shift) rank = 0;
    if (rank % static_cast<std::size_t>(ratio) == 0) sample.push_back(keyed[s].second);
    ++rank;
  }
  std::sort(sample.begin(), sample.end());
  return sample;
}

}  // namespace pointfair
