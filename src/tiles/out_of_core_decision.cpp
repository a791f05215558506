#include "pointfair/tiles/out_of_core_decision.hpp"

#include <algorithm>

#include "pointfair/io/point_file.hpp"
#include "pointfair/tiles/budget.hpp"
#include "pointfair/tiles/container.hpp"

namespace pointfair::tiles {

std::uint64_t in_core_bytes(std::uint64_t points, int k, bool compensated) {
  // Positions (input, current, next, before, and the plain update of a compensated step),
  // neighbour lists twice while reordering, the table's attribute columns.
  return points * ((compensated ? 5 : 4) * 24 + 8 * static_cast<std::uint64_t>(k) + 64);
}

std::uint64_t in_core_finish_bytes(std::uint64_t points, const QuadricProjectionParams& q) {
  // The output positions, the normals, the input kept for the placement
  // (SmoothParams::placement) and the copy in Morton order with the order and its inverse
  // (finish_with_quadrics), the pass's grid, and one block of lists (4 bytes an entry, a
  // count per row): the fits' k-long ones, or the normals' shorter ones in the same storage.
  // With fit sharing, the seeds' fits and every point's index into them, and a second grid
  // for the short lists.
  const std::uint64_t block = std::min<std::uint64_t>(points, kQuadricBlock);
  const std::uint64_t shared =
      q.share_stride > 1 ? 4 + (sizeof(QuadricFit) + 4) / static_cast<std::uint64_t>(q.share_stride) + 1 + 50 : 0;
  return points * (4 * 24 + 8 + 50 + shared) + block * (4 * static_cast<std::uint64_t>(q.k) + 2);
}

bool fits_in_core(std::uint64_t points, const SmoothParams& params, std::uint64_t budget) {
  // In core the quadric finish adds its normals and short lists and one block of its k-long
  // lists; out of core, tiles hold k-long lists for every point.
  const std::uint64_t in_core = in_core_bytes(points, flow_k_bound(params), params.shrink_compensation > 0.0) +
                                (params.finish ? in_core_finish_bytes(points, *params.finish) : 0);
  return in_core <= budget;
}

bool runs_out_of_core(const std::filesystem::path& input, const std::filesystem::path& output,
                      const SmoothParams& params, std::optional<std::uint64_t> memory_budget, bool resume) {
  if (is_container_path(input)) return true;
  const bool forced = is_container_path(output) || resume;
  if (!memory_budget && !forced) return false;
  // The header's count, or a counting pass over a text file: the cloud is not loaded (and an
  // input that cannot be read is refused before any work).
  const std::uint64_t points = io::count_points(input);
  return forced || !fits_in_core(points, params, *memory_budget);
}

}  // namespace pointfair::tiles
