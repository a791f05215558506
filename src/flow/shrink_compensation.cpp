#include "pointfair/flow/shrink_compensation.hpp"

#include <cmath>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"

namespace pointfair {

namespace {

// A momentum's rows: one previous position or one last move each.
void require_momentum_rows(const StepMomentum& momentum, std::size_t n) {
  require(momentum.m >= 0.0 && momentum.m < 1.0, "momentum must be in [0, 1)");
  require(momentum.m == 0.0 || (momentum.previous.empty() ? momentum.moves.size() : momentum.previous.size()) == n,
          "momentum: one previous position (or last move) per row");
}

// Row r's last move p(n) - p(n-1), p its current position.
inline Vec3 last_move(const StepMomentum& momentum, std::size_t r, const Vec3& p) {
  return momentum.previous.empty() ? momentum.moves[r] : Vec3(p - momentum.previous[r]);
}

// The compensated step of every row, with update(j) the flow's own update of point j.
template <class Update>
void compensate_rows(std::span<const Vec3> current, const Update& update, std::size_t size,
                     NeighborhoodsView neighborhoods, std::span<const Index> rows, double beta,
                     const StepMomentum& momentum, std::span<Vec3> next) {
  const std::size_t n = neighborhoods.size();
  require(beta >= 0.0 && beta <= 1.0, "shrink compensation must be in [0, 1]");
  require(current.size() == size, "compensate_shrinkage: current and updated differ in size");
  require(rows.empty() || rows.size() == n, "compensate_shrinkage: rows must match the neighbourhoods");
  require(!rows.empty() || current.size() == n, "compensate_shrinkage: one neighbourhood row per point");
  require(next.size() == n, "compensate_shrinkage: one output per neighbourhood row");
  const double m = momentum.m;
  require_momentum_rows(momentum, n);
  parallel_for(n, [&](std::size_t begin, std::size_t end) {
    for (std::size_t r = begin; r < end; ++r) {
      const std::size_t i = rows.empty() ? r : rows[r];
      const std::span<const Index> nb = neighborhoods.of(r);
      Vec3 mean = Vec3::Zero();
      for (const Index j : nb) mean += update(j);
      if (!nb.empty()) mean /= static_cast<double>(nb.size());
      // Never farther than the flow's own update: a neighbourhood whose updates alternate in
      // sign (two points; a nearly bipartite pair of clusters) would otherwise be pushed
      // apart by up to (1 + beta) times the update, which grows without bound for
      // tau (1 + beta) > 1.
      const Vec3 own = update(i);
      Vec3 step = own - beta * mean;
      const double limit = own.squaredNorm(), length = step.squaredNorm();
      if (length > limit) step *= std::sqrt(limit / length);
      next[r] = m == 0.0 ? Vec3(current[i] + step) : Vec3((current[i] + step) + m * last_move(momentum, r, current[i]));
    }
  }, 2048);
}

}  // namespace

void compensate_shrinkage(std::span<const Vec3> current, std::span<const Vec3> updated,
                          NeighborhoodsView neighborhoods, std::span<const Index> rows,
                          double beta, std::span<Vec3> next) {
  compensate_rows(
      current, [&](std::size_t j) -> Vec3 { return updated[j] - current[j]; }, updated.size(), neighborhoods, rows,
      beta, StepMomentum{}, next);
}

void to_updates(std::span<const Vec3> current, std::span<Vec3> updated) {
  require(updated.size() <= current.size(), "to_updates: more updated positions than current ones");
  parallel_for(updated.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) updated[i] -= current[i];
  }, 16384);
}

void compensate_updates(std::span<const Vec3> current, std::span<const Vec3> updates,
                        NeighborhoodsView neighborhoods, std::span<const Index> rows, double beta,
                        std::span<Vec3> next) {
  compensate_updates(current, updates, neighborhoods, rows, beta, StepMomentum{}, next);
}

void compensate_updates(std::span<const Vec3> current, std::span<const Vec3> updates,
                        NeighborhoodsView neighborhoods, std::span<const Index> rows, double beta,
                        const StepMomentum& momentum, std::span<Vec3> next) {
  compensate_rows(
      current, [&](std::size_t j) -> const Vec3& { return updates[j]; }, updates.size(), neighborhoods, rows, beta,
      momentum, next);
}

void add_momentum(std::span<const Vec3> current, std::span<const Vec3> updated, std::span<const Index> rows,
                  const StepMomentum& momentum, std::span<Vec3> next) {
  const std::size_t n = next.size();
  const double m = momentum.m;
  require_momentum_rows(momentum, n);
  require(updated.size() == n, "add_momentum: one updated position per row");
  require(rows.empty() || rows.size() == n, "add_momentum: rows must match the output");
  require(!rows.empty() || current.size() == n, "add_momentum: one current position per row");
  parallel_for(n, [&](std::size_t begin, std::size_t end) {
    for (std::size_t r = begin; r < end; ++r) {
      const Vec3& p = current[rows.empty() ? r : rows[r]];
      next[r] = m == 0.0 ? updated[r] : Vec3(updated[r] + m * last_move(momentum, r, p));
    }
  }, 16384);
}

void last_moves(std::span<const Vec3> current, std::span<const Vec3> next, std::span<Vec3> moves) {
  require(next.size() >= moves.size() && current.size() >= moves.size(), "last_moves: one position each per move");
  parallel_for(moves.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) moves[i] = next[i] - current[i];
  }, 16384);
}

}  // namespace pointfair
