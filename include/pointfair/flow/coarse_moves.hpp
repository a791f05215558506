#pragma once
// The coarse level's moves carried to every point (SmoothParams::coarse): each point moves by
// a Gaussian-weighted mean of the displacements of its nearest coarse points, the farthest of
// them at weight exp(-2).
#include <span>

#include "pointfair/neighbors/spatial_order.hpp"
#include "pointfair/types.hpp"

namespace pointfair {

/// Adds to every position the weighted mean of moved[j] - anchors[j] over its k nearest
/// anchors (k >= 1; all of them when fewer), nearest first, ties by the smaller anchor index,
/// weights exp(-2 d^2 / d_k^2) with d_k the distance to the farthest of them (1 when that is
/// 0). The positions are visited in the Morton order of `grid` (a grid over them): the result
/// does not depend on it. anchors and moved have one entry per coarse point. Parallel;
/// positions and anchors finite.
///
/// Returns the largest squared distance from a position to the farthest of its k anchors
/// (+infinity when there are fewer than k): every anchor nearer than that, or as near, took
/// part, so a tile holding every anchor within that distance of its points gets the whole
/// cloud's result (out of core).
double add_coarse_moves(std::span<Vec3> positions, std::span<const Vec3> anchors, std::span<const Vec3> moved, int k,
                      const MortonGrid& grid);

}  // namespace pointfair
