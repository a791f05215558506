#include "pointfair/flow/coarse_moves.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "pointfair/common/parallel.hpp"
#include "pointfair/neighbors/kd_tree.hpp"

namespace pointfair {

double add_coarse_moves(std::span<Vec3> positions, std::span<const Vec3> anchors, std::span<const Vec3> moved, int k,
                      const MortonGrid& grid) {
  assert(anchors.size() == moved.size() && k >= 1);
  if (anchors.empty() || positions.empty()) return anchors.empty() ? std::numeric_limits<double>::infinity() : 0.0;
  // The tree over the anchors in Morton order, so that a query's search stays in a few pages;
  // the positions visited in the same order. Ties are put back in anchor index order below.
  const std::vector<Index> anchor_order = spatial_order(anchors, grid);
  std::vector<Vec3> sorted(anchors.size());
  for (std::size_t s = 0; s < anchors.size(); ++s) sorted[s] = anchors[anchor_order[s]];
  const KdTree tree(sorted);
  const std::vector<Index> visit = spatial_order(std::span<const Vec3>(positions.data(), positions.size()), grid);
  const int want = static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(k), anchors.size()));
  std::vector<double> reach(positions.size());
  parallel_for(positions.size(), [&](std::size_t begin, std::size_t end) {
    std::vector<Index> near;
    std::vector<double> d2;
    std::vector<std::pair<double, Index>> found_anchors;
    for (std::size_t s = begin; s < end; ++s) {
      Vec3& p = positions[visit[s]];
      // One more than wanted: when it ties with the last wanted one, the tree's tie order (by
      // Morton rank) may have chosen other anchors than the index order would; then every
      // anchor at that distance is fetched and the index order decides.
      int ask = want + 1;
      int found = 0;
      for (;;) {
        near.resize(static_cast<std::size_t>(ask));
        d2.resize(static_cast<std::size_t>(ask));
        found = tree.nearest(p, ask, std::numeric_limits<double>::infinity(), near.data(), d2.data());
        if (found < ask || d2[static_cast<std::size_t>(found - 1)] != d2[static_cast<std::size_t>(want - 1)]) break;
        ask *= 2;
      }
      reach[s] = found < ask ? std::numeric_limits<double>::infinity() : d2[static_cast<std::size_t>(found - 1)];
      found_anchors.resize(static_cast<std::size_t>(found));
      for (int j = 0; j < found; ++j)
        found_anchors[static_cast<std::size_t>(j)] = {d2[static_cast<std::size_t>(j)], anchor_order[near[static_cast<std::size_t>(j)]]};
      std::sort(found_anchors.begin(), found_anchors.end());
      found = std::min(found, want);
      const double last = found_anchors[static_cast<std::size_t>(found - 1)].first;
      const double reach2 = last > 0.0 ? last : 1.0;
      Vec3 move = Vec3::Zero();
      double weights = 0.0;
      for (int j = 0; j < found; ++j) {
        const auto [dist2, a] = found_anchors[static_cast<std::size_t>(j)];
        const double w = std::exp(-2.0 * dist2 / reach2);
        move += w * (moved[a] - anchors[a]);
        weights += w;
      }
      p += move / weights;
    }
  }, 1024);
  return *std::max_element(reach.begin(), reach.end());
}

}  // namespace pointfair
