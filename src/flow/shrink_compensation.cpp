#include "pointfair/flow/shrink_compensation.hpp"

#include <cmath>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"

namespace pointfair {

void compensate_shrinkage(std::span<const Vec3> current, std::span<const Vec3> updated,
                          NeighborhoodsView neighborhoods, std::span<const Index> rows,
                          double beta, std::span<Vec3> next) {
  const std::size_t n = neighborhoods.size();
  require(beta >= 0.0 && beta <= 1.0, "shrink compensation must be in [0, 1]");
  require(current.size() == updated.size(), "compensate_shrinkage: current and updated differ in size");
  require(rows.empty() || rows.size() == n, "compensate_shrinkage: rows must match the neighbourhoods");
  require(!rows.empty() || current.size() == n, "compensate_shrinkage: one neighbourhood row per point");
  require(next.size() == n, "compensate_shrinkage: one output per neighbourhood row");
  parallel_for(n, [&](std::size_t begin, std::size_t end) {
    for (std::size_t r = begin; r < end; ++r) {
      const std::size_t i = rows.empty() ? r : rows[r];
      const std::span<const Index> nb = neighborhoods.of(r);
      Vec3 mean = Vec3::Zero();
      for (const Index j : nb) mean += updated[j] - current[j];
      if (!nb.empty()) mean /= static_cast<double>(nb.size());
      // Never farther than the flow's own update: a neighbourhood whose updates alternate in
      // sign (two points; a nearly bipartite pair of clusters) would otherwise be pushed
      // apart by up to (1 + beta) times the update, which grows without bound for
      // tau (1 + beta) > 1.
      const Vec3 own = updated[i] - current[i];
      Vec3 step = own - beta * mean;
      const double limit = own.squaredNorm(), length = step.squaredNorm();
      if (length > limit) step *= std::sqrt(limit / length);
      next[r] = current[i] + step;
    }
  }, 2048);
}

}  // namespace pointfair
