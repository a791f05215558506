#pragma once
// Shrinkage compensation of an Euler step (beyond the paper). Mean curvature flow moves
// every point of a curved surface toward its centre of curvature: a sphere shrinks while its
// noise is removed. A compensated step subtracts from each point's update the mean update of
// its neighbours,
//   u_i = p_i(n+1) - p_i(n)                       (the flow's own update, euler_step)
//   c_i = u_i - beta / |N_i| sum_{j in N_i} u_j
//   p_i(n+1) <- p_i(n) + c_i |u_i| / |c_i|   if |c_i| > |u_i|, else p_i(n) + c_i
// With beta = 1 this is one step of the bi-Laplacian flow built from the (an)isotropic
// Laplacian: the curvature of the clean surface moves neighbouring points alike and cancels,
// while the noise, whose updates change sign from point to point, is still removed. The
// length cap keeps the step stable: on the mode whose updates alternate between neighbours
// (eigenvalue 2 of the umbrella operator: two points, or two clusters) the uncapped step
// multiplies their distance by 1 - 2 tau (1 + beta), -3 at tau 1 and beta 1; capped,
// by 1 - 2 tau (-1 at tau 1: the mode is then not damped, but it needs neighbourhoods that
// split into two groups each seeing only the other, such as two points alone, which then swap
// sides at the same distance). Where neighbours move alike (the surface's curvature, the low
// frequencies that shrink it) |c_i| < |u_i| and the cap is inactive. The sums
// run over the neighbour list in its canonical order, so the result depends on nothing but
// the point's neighbourhood and is the same for any thread count or tiling.
#include <span>

#include "pointfair/neighbors/neighborhoods.hpp"
#include "pointfair/types.hpp"

namespace pointfair {

/// Row r of `neighborhoods` belongs to point rows[r] (rows empty: row r is point r).
/// `current` holds step-n positions and `updated` the euler_step output (step n+1 without
/// compensation) of every point that row r or its neighbours name; next[r] receives the
/// compensated position of point rows[r]. `next` must not alias `current` or `updated`.
/// beta in [0, 1]; 0 copies `updated` (bit for bit).
void compensate_shrinkage(std::span<const Vec3> current, std::span<const Vec3> updated,
                          NeighborhoodsView neighborhoods, std::span<const Index> rows,
                          double beta, std::span<Vec3> next);

/// updated[i] -= current[i] for i < updated.size() (parallel): euler_step's output turned into
/// the flow's own updates u_i, as compensate_shrinkage computes them.
void to_updates(std::span<const Vec3> current, std::span<Vec3> updated);

/// compensate_shrinkage from the updates (to_updates) rather than the updated positions: the
/// same bits, with one array read a neighbour instead of two (the neighbours' positions were
/// read only to subtract them).
void compensate_updates(std::span<const Vec3> current, std::span<const Vec3> updates,
                        NeighborhoodsView neighborhoods, std::span<const Index> rows, double beta,
                        std::span<Vec3> next);

/// The momentum of a step (SmoothParams::momentum): m, and the step-(n-1) positions of the
/// rows, previous[r] for next[r]. `previous` may be `next` itself (each row is read before it
/// is written), which is how the double-buffered steps hold them.
/// Or, where `previous` is empty, the rows' last moves themselves, moves[r] = p(n) - p(n-1)
/// as last_moves computed them (the same bits as current - previous): how the out-of-core
/// run keeps them.
struct StepMomentum {
  double m = 0.0;
  std::span<const Vec3> previous;
  std::span<const Vec3> moves;
};

/// compensate_updates with momentum: next[r] = (current[i] + c_r) + m (current[i] - previous[r]).
void compensate_updates(std::span<const Vec3> current, std::span<const Vec3> updates,
                        NeighborhoodsView neighborhoods, std::span<const Index> rows, double beta,
                        const StepMomentum& momentum, std::span<Vec3> next);

/// moves[i] = next[i] - current[i] for i < moves.size() (parallel): a step's moves, which
/// StepMomentum::moves reads on the step after.
void last_moves(std::span<const Vec3> current, std::span<const Vec3> next, std::span<Vec3> moves);

/// An uncompensated step with momentum: next[r] = updated[r] + m (current[i] - previous[r]),
/// with updated[r] the euler_step output of row r (point rows[r]; rows empty: row r is point r).
void add_momentum(std::span<const Vec3> current, std::span<const Vec3> updated, std::span<const Index> rows,
                  const StepMomentum& momentum, std::span<Vec3> next);

}  // namespace pointfair
