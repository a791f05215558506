#pragma once
// A bounding-volume hierarchy over axis-aligned boxes, for nearest-primitive queries against
// ground-truth meshes (triangles) and their sharp edges (segments). Built once; queries are
// read-only and may run concurrently.
#include <cstdint>
#include <limits>
#include <span>
#include <utility>
#include <vector>

#include "pointfair/types.hpp"

namespace pointfair::eval {

class AabbTree {
 public:
  AabbTree() = default;
  /// Builds the tree over `boxes` (one per primitive; primitive i has box boxes[i]).
  explicit AabbTree(std::span<const Eigen::AlignedBox3d> boxes);

  bool empty() const { return nodes_.empty(); }

  /// The primitive nearest to `p` and its squared distance, where `squared_distance(i)` is the
  /// exact squared distance from p to primitive i. Visits boxes nearest first and skips every
  /// box farther than the best primitive so far. Returns {UINT32_MAX, +inf} when empty.
  template <typename F>
  std::pair<Index, double> nearest(const Vec3& p, F&& squared_distance) const;

 private:
  struct Node {
    Eigen::AlignedBox3d box;
    // Leaf: primitives order_[first, first + count). Inner: children `first` and `first + 1`
    // when count == 0.
    std::uint32_t first = 0;
    std::uint32_t count = 0;
  };
  void build(std::span<const Eigen::AlignedBox3d> boxes, const std::vector<Vec3>& centres,
             std::uint32_t id, std::uint32_t begin, std::uint32_t end);
  static double box_distance2(const Eigen::AlignedBox3d& box, const Vec3& p) {
    return (p - p.cwiseMax(box.min()).cwiseMin(box.max())).squaredNorm();
  }

  std::vector<Node> nodes_;
  std::vector<Index> order_;
};

template <typename F>
std::pair<Index, double> AabbTree::nearest(const Vec3& p, F&& squared_distance) const {
  Index best = std::numeric_limits<Index>::max();
  double best_d2 = std::numeric_limits<double>::infinity();
  if (nodes_.empty()) return {best, best_d2};
  std::pair<double, std::uint32_t> stack[128];
  int top = 0;
  stack[top++] = {box_distance2(nodes_[0].box, p), 0};
  while (top > 0) {
    const auto [d2, id] = stack[--top];
    if (d2 >= best_d2) continue;
    const Node& node = nodes_[id];
    if (node.count > 0) {
      for (std::uint32_t k = node.first; k < node.first + node.count; ++k) {
        const double e2 = squared_distance(order_[k]);
        if (e2 < best_d2 || (e2 == best_d2 && order_[k] < best)) {
          best_d2 = e2;
          best = order_[k];
        }
      }
      continue;
    }
    const double a = box_distance2(nodes_[node.first].box, p);
    const double b = box_distance2(nodes_[node.first + 1].box, p);
    // Push the farther child first so the nearer one is visited next.
    if (a < b) {
      stack[top++] = {b, node.first + 1};
      stack[top++] = {a, node.first};
    } else {
      stack[top++] = {a, node.first};
      stack[top++] = {b, node.first + 1};
    }
  }
  return {best, best_d2};
}

}  // namespace pointfair::eval
