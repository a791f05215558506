#pragma once
// A k-d tree over a position array (a facade over nanoflann; the array is not copied).
//
// Results are canonical: the k nearest points ordered by squared distance, ties broken by
// the smaller index. Two trees over the same positions (or over any superset holding the
// same points with the same indices) therefore return the same lists, which the tiled and
// distributed runs rely on.
//
// Thread-safety: queries on one tree may run concurrently; building may not.
#include <memory>
#include <span>

#include "pointfair/types.hpp"

namespace pointfair {

class KdTree {
 public:
  /// Builds the tree over `points`, which must outlive the tree and stay unchanged. Throws
  /// ParamError "k-d tree: point i has a non-finite coordinate (x, y, z)" for NaN or infinite
  /// coordinates: every neighbourhood (and so smooth(), curvature and attributes) is built
  /// through a tree, so a NaN never enters the method.
  explicit KdTree(std::span<const Vec3> points);
  ~KdTree();
  KdTree(const KdTree&) = delete;
  KdTree& operator=(const KdTree&) = delete;
  KdTree(KdTree&&) noexcept;
  KdTree& operator=(KdTree&&) noexcept;

  /// Finds up to `k` nearest points to `query` (the query point itself included if it is in
  /// the array) with squared distance <= `max_distance2`. Writes indices and squared
  /// distances, nearest first, ties by index; returns how many were found.
  int nearest(const Vec3& query, int k, double max_distance2, Index* indices,
              double* distances2) const;

  std::span<const Vec3> points() const;

  /// The points' indices in the tree's leaf order (a permutation of 0..n-1): neighbouring
  /// entries are near in space, so visiting queries in this order keeps caches warm.
  std::span<const Index> leaf_order() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pointfair
