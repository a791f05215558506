#pragma once
// The `want` nearest points of query points, each query itself included, as KdTree::nearest
// gives them (no radius bound): what the automatic eps and k measure on their samples.
// Searched through the cell grid (knn_grid.hpp) rather than one k-d tree query each.
#include <span>
#include <vector>

#include "pointfair/types.hpp"

namespace pointfair {

/// Row r belongs to queries[r]: counts[r] points (want, or all of them in a smaller cloud)
/// from element r * stride, nearest first, ties by the smaller index, with their squared
/// distances summed as the k-d tree sums them.
struct NearestPoints {
  int stride = 0;
  std::vector<Index> indices;
  std::vector<double> distances2;
  std::vector<int> counts;

  std::span<const Index> indices_of(std::size_t r) const {
    return {indices.data() + r * static_cast<std::size_t>(stride), static_cast<std::size_t>(counts[r])};
  }
  std::span<const double> distances2_of(std::size_t r) const {
    return {distances2.data() + r * static_cast<std::size_t>(stride), static_cast<std::size_t>(counts[r])};
  }
};

/// The same as KdTree(points).nearest(points[q], want, +infinity) for every q of `queries`,
/// bit for bit. The grid finds each query's want - 1 nearest other points and the query is
/// put back in canonical order; a query with want - 1 exact duplicates of smaller index (the
/// grid may have left out more of them) is answered by a k-d tree. want >= 1. Parallel.
NearestPoints nearest_points(std::span<const Vec3> points, std::span<const Index> queries, int want);

}  // namespace pointfair
