#pragma once
// eps-k neighbourhoods N_k^eps(p) of Lange & Polthier (2005), Section 2.1: the k nearest
// other points of p that also lie within distance eps of p.
//
// Kept as a flat array with a fixed stride k plus a count per point (no nested vectors), in
// canonical order: by distance, ties by the smaller index. The per-point kernels read the
// list in that order, so their sums are the same whatever machine, thread or tile ran them.
//
// Differs from the paper: eps may be chosen automatically from the measured spacing.
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "pointfair/neighbors/neighbor_lists.hpp"
#include "pointfair/types.hpp"

namespace pointfair {

class KdTree;

struct NeighborParams {
  /// Neighbours per point, the point itself not counted. Range 1..1024; the flow needs >= 2.
  int k = 16;
  /// Radius bound in units of length. 0 picks it automatically (eps_auto_factor times the
  /// median distance to the k-th neighbour); +infinity means no bound (plain k-nearest).
  double eps = 0.0;
  /// Multiplier for the automatic eps. Large values reproduce plain k-nearest neighbourhoods.
  double eps_auto_factor = 2.0;

  void validate() const;
};

/// The radius bound params ask for: params.eps, or the automatic one measured on `points`.
double resolve_eps(std::span<const Vec3> points, const KdTree& tree, const NeighborParams& params);

/// Neighbourhoods of every point of `points` among `points`. Parallel; searched through a
/// cell grid (knn_grid.hpp), with the same lists as one k-d tree query per point.
Neighborhoods build_neighborhoods(std::span<const Vec3> points, const NeighborParams& params);

/// The same lists with the rows permuted: point p's list is row row_of[p] (`row_of` a
/// permutation of 0..n-1). Indices in the lists still refer to `points`.
Neighborhoods build_neighborhoods(std::span<const Vec3> points, const NeighborParams& params,
                                  std::span<const Index> row_of);

/// Neighbourhoods of the points `queries` (indices into `points`) among all of `points`, with
/// a resolved radius `eps` (no automatic choice here: tiles must share one global value).
/// Row r of the result belongs to queries[r]; indices refer to `points`. Searched through a
/// cell grid over tree.points(); the tree answers the queries the grid cannot settle.
Neighborhoods build_neighborhoods(const KdTree& tree, std::span<const Index> queries, int k,
                                  double eps);

/// The same without a tree at hand: one is built over `points` only if the grid leaves more
/// than a few queries unsettled (points far off a dense surface).
Neighborhoods build_neighborhoods(std::span<const Vec3> points, std::span<const Index> queries, int k,
                                  double eps);
/// The same rows through one k-d tree query per row and no grid: the reference path.
Neighborhoods build_neighborhoods_kd_tree(const KdTree& tree, std::span<const Index> queries,
                                          int k, double eps);

}  // namespace pointfair
