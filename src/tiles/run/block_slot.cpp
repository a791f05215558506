#include "block_slot.hpp"

#include <cassert>
#include <span>
#include <utility>

#include "pointfair/common/parallel.hpp"
#include "pointfair/flow/shrink_compensation.hpp"

namespace pointfair::tiles::detail {

void BlockSlot::compute(const FlowParams& flow, double lambda, double beta, double m, bool keep_moves) {
  const std::size_t rings = beta > 0.0 ? 2 : 1;
  const std::size_t d = views.size(), h = d / rings;
  assert((m == 0.0 && !keep_moves) || h == 1);  // a point's last move is known for one step
  const auto ids_of = [&](std::size_t l) {
    const std::size_t begin = l == 0 ? 0 : level_end[l - 1];
    return std::span<const Index>(ids.data() + begin, level_end[l] - begin);
  };
  const auto part = [&](std::vector<Vec3>& v, std::size_t l) {
    const std::size_t begin = l == 0 ? 0 : level_end[l - 1];
    return std::span<Vec3>(v.data() + begin, level_end[l] - begin);
  };
  if (beta > 0.0) updated.resize(cur.size());
  const std::size_t own = level_end[0];
  if (!order.empty() && !read_listed)
    parallel_for(own, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) cur[i] = by_row[order[i]];
    }, 8192);
  for (std::size_t j = 1; j <= h; ++j) {
    // The deepest level whose step-j positions are exact, and the deepest plain update.
    const std::size_t last = d - rings * j, reach = last + rings - 1;
    // An empty level (a tile without halo) is skipped: empty rows would mean "every point"
    // to the kernels.
    // The tile's own points (their degenerate count is the step's), then the rings: as one
    // range where their lists lie one after the other.
    std::vector<Vec3>& out = beta > 0.0 ? updated : next;
    degenerate[j - 1] = ids_of(0).empty() ? 0 : euler_step(cur, views[0], ids_of(0), flow, lambda, part(out, 0)).degenerate;
    if (m > 0.0 && beta == 0.0) add_momentum(cur, part(out, 0), ids_of(0), moves.momentum(m), part(out, 0));
    if (all.stride != 0 && reach >= 1) {
      const std::size_t b = level_end[0], e = level_end[reach];
      if (e > b)
        euler_step(cur, all.rows(b, e - b), std::span<const Index>(ids.data() + b, e - b), flow, lambda,
                   std::span<Vec3>(out.data() + b, e - b));
    } else {
      for (std::size_t l = 1; l <= reach; ++l)
        if (!ids_of(l).empty()) euler_step(cur, views[l], ids_of(l), flow, lambda, part(out, l));
    }
    if (beta > 0.0) {
      // The updates of every point a compensated row reads (levels 0 .. reach).
      to_updates(cur, std::span<Vec3>(updated.data(), level_end[reach]));
      for (std::size_t l = 0; l <= last; ++l)
        if (!ids_of(l).empty())
          compensate_updates(cur, std::span<const Vec3>(updated.data(), cur.size()), views[l], ids_of(l), beta,
                             l == 0 ? moves.momentum(m) : StepMomentum{}, part(next, l));
    }
    // Levels 0 .. last now hold step j in `next`; the later steps read no level beyond
    // `last` (they reach one level less each), so the buffers trade places.
    if (keep_moves) moves.keep(std::span<const Vec3>(cur).first(own), std::span<const Vec3>(next).first(own));
    std::swap(cur, next);
  }
  if (!order.empty() && !write_listed)
    parallel_for(own, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) by_row[order[i]] = cur[i];
    }, 8192);
}

}  // namespace pointfair::tiles::detail
