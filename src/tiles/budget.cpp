#include "pointfair/tiles/budget.hpp"

#include <algorithm>

namespace pointfair::tiles {

namespace {

// Bytes per tile point in the largest working set of a run, doubled for the halo: the tile
// and a halo about as large with their trees, and lists of k entries (4 bytes each) of the
// tile's points and of the halo points they name, which the quadric finish (k 200) holds
// for its fits and its normals (about 14 k bytes a point with both; the flow's neighbour
// building, 8 k).
std::uint64_t bytes_per_tile_point(int k) { return 2 * (200 + 14 * static_cast<std::uint64_t>(k)); }

}  // namespace

std::uint64_t lambda_sample_room(std::uint64_t budget) {
  return std::max(budget / 16, std::min(std::uint64_t{2} << 20, budget / 2));
}

std::uint64_t tile_points_for_budget(std::uint64_t budget, int k) {
  const std::uint64_t usable = budget - lambda_sample_room(budget);
  return std::max<std::uint64_t>(64, usable / bytes_per_tile_point(k));
}

std::uint64_t budget_to_name(std::uint64_t needed) {
  constexpr std::uint64_t mib = std::uint64_t{1} << 20;
  return (2 * needed + mib - 1) / mib * mib;
}

}  // namespace pointfair::tiles
