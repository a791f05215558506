#pragma once
// The momentum's last moves of one tile's points out of core (SmoothParams::momentum): the
// run file keeps every point's move p(n) - p(n-1) in row order, one buffer per step parity
// (Run::moves_buffer); a step reads its tile's rows before it computes, in the order of the
// tile's positions, and gives back the step's own moves to be written after it.
#include <cassert>
#include <cstdint>
#include <span>
#include <vector>

#include "pointfair/flow/shrink_compensation.hpp"
#include "pointfair/neighbors/spatial_order.hpp"
#include "pointfair/types.hpp"
#include "vector_bytes.hpp"

namespace pointfair::tiles::detail {

struct TileMoves {
  std::vector<Vec3> by_row;  // the tile's rows as the run file holds them
  std::vector<Vec3> listed;  // in the order of the tile's positions (point s: row order[s])

  // `by_row` into `listed` (order empty: the same order).
  void to_listed(std::span<const Index> order) { listed = order.empty() ? by_row : gather(by_row, order); }
  // `listed` into `by_row`.
  void to_rows(std::span<const Index> order) { by_row = order.empty() ? listed : scatter(listed, order); }
  // The step's moves, next[s] - current[s] for each of the tile's points, into `listed`
  // (which the step's momentum read before; sized by Run::read_moves, not here: the compute
  // runs beside the thread that measures every slot's vectors).
  void keep(std::span<const Vec3> current, std::span<const Vec3> next) {
    assert(listed.size() == next.size());
    last_moves(current, next, listed);
  }
  // A step's momentum m from these moves.
  StepMomentum momentum(double m) const { return StepMomentum{m, {}, m == 0.0 ? std::span<const Vec3>() : std::span<const Vec3>(listed)}; }
  std::uint64_t bytes() const { return detail::bytes(by_row) + detail::bytes(listed); }
};

}  // namespace pointfair::tiles::detail
