#include "pointfair/flow/coarse_moves.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <vector>

#include "pointfair/common/parallel.hpp"
#include "pointfair/neighbors/kd_tree.hpp"

namespace pointfair {

double add_coarse_moves(std::span<Vec3> positions, std::span<const Vec3> anchors, std::span<const Vec3> moved, int k,
                        const MortonGrid& grid) {
  assert(anchors.size() == moved.size() && k >= 1);
  if (anchors.empty() || positions.empty()) return anchors.empty() ? std::numeric_limits<double>::infinity() : 0.0;
  // The tree's results are canonical (nearest first, ties by the smaller anchor index); the
  // positions are visited in Morton order, so that neighbouring queries read the same
  // branches of it.
  const KdTree tree(anchors);
  const std::vector<Index> visit = spatial_order(std::span<const Vec3>(positions.data(), positions.size()), grid);
  const int want = static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(k), anchors.size()));
  std::vector<double> reach(positions.size());
  parallel_for(positions.size(), [&](std::size_t begin, std::size_t end) {
    std::vector<Index> near(static_cast<std::size_t>(want));
    std::vector<double> d2(static_cast<std::size_t>(want));
    for (std::size_t s = begin; s < end; ++s) {
      Vec3& p = positions[visit[s]];
      const int found = tree.nearest(p, want, std::numeric_limits<double>::infinity(), near.data(), d2.data());
      const double last = d2[static_cast<std::size_t>(found - 1)];
      // Every anchor nearer than `last`, or as near, took part (or, with fewer found than
      // wanted, every anchor there is).
      reach[s] = found < k ? std::numeric_limits<double>::infinity() : last;
      const double reach2 = last > 0.0 ? last : 1.0;
      Vec3 move = Vec3::Zero();
      double weights = 0.0;
      for (int j = 0; j < found; ++j) {
        const Index a = near[static_cast<std::size_t>(j)];
        const double w = std::exp(-2.0 * d2[static_cast<std::size_t>(j)] / reach2);
        move += w * (moved[a] - anchors[a]);
        weights += w;
      }
      p += move / weights;
    }
  }, 1024);
  return *std::max_element(reach.begin(), reach.end());
}

}  // namespace pointfair
