#include "pointfair/tiles/budget.hpp"

#include <algorithm>

#include "pointfair/finish/quadric_projection.hpp"
#include "pointfair/neighbors/neighborhood_size.hpp"
#include "pointfair/smooth.hpp"

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

int flow_k_bound(const SmoothParams& params) { return params.neighbors.k == 0 ? kAutoKMax : params.neighbors.k; }

std::uint64_t run_tile_points(std::uint64_t budget, const SmoothParams& params) {
  const int flow_k = flow_k_bound(params);
  return tile_points_for_budget(budget, params.finish ? std::max(flow_k, params.finish->k) : flow_k);
}

std::uint64_t import_tile_points(std::uint64_t budget) {
  return tile_points_for_budget(budget, std::max(kAutoKMax, QuadricProjectionParams{}.k));
}

std::uint64_t budget_to_name(std::uint64_t needed) {
  constexpr std::uint64_t mib = std::uint64_t{1} << 20;
  return (2 * needed + mib - 1) / mib * mib;
}

}  // namespace pointfair::tiles
