#include "pointfair/eval/aabb_tree.hpp"

#include <algorithm>

namespace pointfair::eval {

namespace {
constexpr std::uint32_t kLeafSize = 4;
}

AabbTree::AabbTree(std::span<const Eigen::AlignedBox3d> boxes) {
  if (boxes.empty()) return;
  order_.resize(boxes.size());
  std::vector<Vec3> centres(boxes.size());
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    order_[i] = static_cast<Index>(i);
    centres[i] = boxes[i].center();
  }
  nodes_.reserve(2 * boxes.size() / kLeafSize + 2);
  nodes_.emplace_back();
  build(boxes, centres, 0, 0, static_cast<std::uint32_t>(boxes.size()));
}

// Fills node `id` for order_[begin, end): a leaf of at most kLeafSize primitives, or a median
// split on the longest axis of the centres. Balanced, so the depth is at most 32 and the
// fixed query stack (at most one pending sibling per level) is enough.
void AabbTree::build(std::span<const Eigen::AlignedBox3d> boxes, const std::vector<Vec3>& centres,
                     std::uint32_t id, std::uint32_t begin, std::uint32_t end) {
  Eigen::AlignedBox3d box, centre_box;
  for (std::uint32_t k = begin; k < end; ++k) {
    box.extend(boxes[order_[k]]);
    centre_box.extend(centres[order_[k]]);
  }
  nodes_[id].box = box;
  if (end - begin <= kLeafSize) {
    nodes_[id].first = begin;
    nodes_[id].count = end - begin;
    return;
  }
  Eigen::Index axis = 0;
  centre_box.diagonal().maxCoeff(&axis);
  const std::uint32_t mid = begin + (end - begin) / 2;
  std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                   [&](Index a, Index b) {
                     const double ca = centres[a][axis], cb = centres[b][axis];
                     return ca < cb || (ca == cb && a < b);
                   });
  const auto left = static_cast<std::uint32_t>(nodes_.size());
  nodes_.emplace_back();
  nodes_.emplace_back();
  nodes_[id].first = left;
  nodes_[id].count = 0;
  build(boxes, centres, left, begin, mid);
  build(boxes, centres, left + 1, mid, end);
}

}  // namespace pointfair::eval
