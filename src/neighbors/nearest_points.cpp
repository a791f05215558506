#include "pointfair/neighbors/nearest_points.hpp"

#include <atomic>
#include <limits>
#include <memory>
#include <string>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/neighbors/kd_tree.hpp"
#include "pointfair/neighbors/neighborhoods.hpp"

namespace pointfair {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Row r from the grid's list of other points: the query inserted before the first point
// that is farther or at distance 0 with a larger index. -1 when every listed point is a
// duplicate of smaller index and the list is full: the row may lack some of them.
int row_from_others(std::span<const Vec3> points, Index self, std::span<const Index> others, int want,
                    Index* idx, double* d2) {
  const Vec3& q = points[self];
  int found = 0;
  bool placed = false;
  for (const Index j : others) {
    const Vec3& p = points[j];
    // nanoflann's L2 metric: (q - p) per axis, squares summed x, y, z.
    const double dx = q.x() - p.x(), dy = q.y() - p.y(), dz = q.z() - p.z();
    const double d = dx * dx + dy * dy + dz * dz;
    if (!placed && (d > 0.0 || j > self)) {
      idx[found] = self;
      d2[found++] = 0.0;
      placed = true;
    }
    idx[found] = j;
    d2[found++] = d;
  }
  if (!placed) {
    if (found > 0 && found == want - 1) return -1;
    idx[found] = self;
    d2[found++] = 0.0;
  }
  return found;
}

}  // namespace

NearestPoints nearest_points(std::span<const Vec3> points, std::span<const Index> queries, int want) {
  require(want >= 1, "nearest_points: want must be at least 1, got " + std::to_string(want));
  for (const Index q : queries) require(q < points.size(), "nearest_points: query index out of range");
  NearestPoints out;
  out.stride = want;
  const std::size_t stride = static_cast<std::size_t>(want);
  out.indices.assign(queries.size() * stride, 0);
  out.distances2.assign(queries.size() * stride, 0.0);
  out.counts.assign(queries.size(), 0);
  Neighborhoods others;
  if (want > 1 && points.size() > 1) others = build_neighborhoods(points, queries, want - 1, kInf);
  std::atomic<bool> unsettled{false};
  parallel_for(queries.size(), [&](std::size_t b, std::size_t e) {
    for (std::size_t r = b; r < e; ++r) {
      const std::span<const Index> list = others.size() > 0 ? others.of(r) : std::span<const Index>();
      out.counts[r] = row_from_others(points, queries[r], list, want, out.indices.data() + r * stride,
                                      out.distances2.data() + r * stride);
      if (out.counts[r] < 0) unsettled = true;
    }
  }, 256);
  if (unsettled) {
    const KdTree tree(points);
    parallel_for(queries.size(), [&](std::size_t b, std::size_t e) {
      for (std::size_t r = b; r < e; ++r)
        if (out.counts[r] < 0)
          out.counts[r] = tree.nearest(points[queries[r]], want, kInf, out.indices.data() + r * stride,
                                       out.distances2.data() + r * stride);
    }, 16);
  }
  return out;
}

}  // namespace pointfair
