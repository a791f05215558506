#include "pointfair/neighbors/neighborhoods.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/neighbors/kd_tree.hpp"
#include "pointfair/neighbors/knn_grid.hpp"
#include "common/huge_pages.hpp"

namespace pointfair {

void NeighborParams::validate() const {
  require(k >= 1 && k <= 1024, "k must be in 1..1024, got " + std::to_string(k));
  require(eps >= 0.0 && !std::isnan(eps), "eps must be >= 0 (0 = automatic), got " + std::to_string(eps));
  require(eps_auto_factor > 0.0 && std::isfinite(eps_auto_factor),
          "eps auto factor must be a positive number, got " + std::to_string(eps_auto_factor));
}

namespace {

// The automatic eps from each sample's distance to its want-th nearest point (itself included):
// eps_auto_factor times the median. kth(s) measures sample s = point s * stride.
template <class Kth>
double auto_eps(std::size_t n, const NeighborParams& params, Kth kth_of) {
  // Median distance to the k-th other point over an evenly strided sample of at most 65536
  // points: deterministic and cheap even for huge clouds.
  const std::size_t stride = std::max<std::size_t>(1, n / 65536);
  const std::size_t samples = (n + stride - 1) / stride;
  const int want = std::min<int>(params.k + 1, static_cast<int>(n));
  std::vector<double> kth = kth_of(stride, samples, want);
  auto mid = kth.begin() + static_cast<std::ptrdiff_t>(samples / 2);
  std::nth_element(kth.begin(), mid, kth.end());
  const double spacing = *mid;
  if (!(spacing > 0.0)) return std::numeric_limits<double>::infinity();  // all duplicates
  return params.eps_auto_factor * spacing;
}

}  // namespace

double resolve_eps(std::span<const Vec3> points, const KdTree& tree, const NeighborParams& params) {
  params.validate();
  if (params.eps > 0.0) return params.eps;
  if (points.size() < 2) return std::numeric_limits<double>::infinity();
  return auto_eps(points.size(), params, [&](std::size_t stride, std::size_t samples, int want) {
    std::vector<double> kth(samples, 0.0);
    parallel_for(samples, [&](std::size_t begin, std::size_t end) {
      std::vector<Index> idx(static_cast<std::size_t>(want));
      std::vector<double> d2(static_cast<std::size_t>(want));
      for (std::size_t s = begin; s < end; ++s) {
        const int found = tree.nearest(points[s * stride], want, std::numeric_limits<double>::infinity(),
                                       idx.data(), d2.data());
        kth[s] = found > 0 ? std::sqrt(d2[static_cast<std::size_t>(found - 1)]) : 0.0;
      }
    }, 256);
    return kth;
  });
}

namespace {

// Rows of `queries`, visited in the order `visit` (row numbers; empty: 0, 1, ...). The order
// only affects speed: each row is written by itself.
Neighborhoods build_rows(const KdTree& tree, std::span<const Index> queries,
                         std::span<const Index> visit, int k, double eps) {
  require(k >= 1 && k <= 1024, "k must be in 1..1024, got " + std::to_string(k));
  require(eps > 0.0, "eps must be positive");
  const auto points = tree.points();
  Neighborhoods result;
  result.stride = k;
  result.eps = eps;
  result.indices.assign(queries.size() * static_cast<std::size_t>(k), 0);
  result.counts.assign(queries.size(), 0);
  const double max_d2 = std::isinf(eps) ? eps : eps * eps;
  const int want = k + 1;  // the point itself is among its own nearest points
  parallel_for(queries.size(), [&](std::size_t begin, std::size_t end) {
    std::vector<Index> idx(static_cast<std::size_t>(want));
    std::vector<double> d2(static_cast<std::size_t>(want));
    // Consecutive queries are near each other (leaf or Morton order), so the previous query's
    // k-th distance, widened, is a good first search radius: it prunes the tree from the start.
    // If fewer than k + 1 points lie within it, the query is repeated with the full radius;
    // if k + 1 do, they are exactly the k + 1 nearest, so the lists do not change.
    double guess = max_d2;
    for (std::size_t v = begin; v < end; ++v) {
      const std::size_t r = visit.empty() ? v : visit[v];
      const Index self = queries[r];
      int found = 0;
      if (guess < max_d2) found = tree.nearest(points[self], want, guess, idx.data(), d2.data());
      if (found < want) found = tree.nearest(points[self], want, max_d2, idx.data(), d2.data());
      guess = found == want ? 2.0 * d2[static_cast<std::size_t>(want - 1)] : max_d2;
      Index* out = result.indices.data() + r * static_cast<std::size_t>(k);
      int count = 0;
      for (int j = 0; j < found && count < k; ++j) {
        if (idx[static_cast<std::size_t>(j)] == self) continue;
        out[count++] = idx[static_cast<std::size_t>(j)];
      }
      result.counts[r] = static_cast<std::uint16_t>(count);
    }
  }, 512);
  return result;
}

}  // namespace

Neighborhoods build_neighborhoods_kd_tree(const KdTree& tree, std::span<const Index> queries, int k,
                                          double eps) {
  return build_rows(tree, queries, {}, k, eps);
}

namespace {

// The rows of `queries` through a cell grid over `points`; `tree` (over the same points, or
// null) answers what the grid cannot settle.
Neighborhoods grid_rows(std::span<const Vec3> points, std::span<const Index> queries, int k, double eps,
                        const KdTree* tree) {
  require(k >= 1 && k <= 1024, "k must be in 1..1024, got " + std::to_string(k));
  require(eps > 0.0, "eps must be positive");
  const CellGrid grid = build_cell_grid(points, k, eps);
  return grid_neighborhoods(grid, queries, k, eps, tree);
}

}  // namespace

Neighborhoods build_neighborhoods(const KdTree& tree, std::span<const Index> queries, int k,
                                  double eps) {
  return grid_rows(tree.points(), queries, k, eps, &tree);
}

Neighborhoods build_neighborhoods(std::span<const Vec3> points, std::span<const Index> queries, int k,
                                  double eps) {
  return grid_rows(points, queries, k, eps, nullptr);
}

Neighborhoods build_neighborhoods(std::span<const Vec3> points, const NeighborParams& params) {
  return build_neighborhoods(points, params, {});
}

Neighborhoods build_neighborhoods(std::span<const Vec3> points, const NeighborParams& params,
                                  std::span<const Index> row_of) {
  params.validate();
  require(points.size() < std::numeric_limits<Index>::max(),
          "an in-core cloud holds fewer than 2^32-1 points; use tiles for more");
  require(row_of.empty() || row_of.size() == points.size(), "row_of must hold one row per point");
  constexpr double kInf = std::numeric_limits<double>::infinity();
  if (params.eps > 0.0) {
    const CellGrid grid = build_cell_grid(points, params.k, params.eps);
    return grid_neighborhoods(grid, params.k, params.eps, row_of);
  }
  // Automatic eps: every list without a bound first. The samples' distances to their
  // (k+1)-th nearest point (themselves included) come with the lists and give eps exactly as
  // resolve_eps measures it; then the rows reaching beyond eps are cut, since a list bounded
  // by eps is the prefix of the unbounded list within eps.
  const std::size_t n = points.size();
  const CellGrid grid = build_cell_grid(points, params.k, kInf);
  std::vector<double> last_d2;
  detail::assign_huge(last_d2, n, 0.0);
  Neighborhoods nb = grid_neighborhoods(grid, params.k, kInf, row_of, last_d2);
  const auto row = [&](std::size_t p) { return row_of.empty() ? p : static_cast<std::size_t>(row_of[p]); };
  nb.eps = n < 2 ? kInf : auto_eps(n, params, [&](std::size_t stride, std::size_t samples, int) {
    std::vector<double> kth(samples);
    for (std::size_t s = 0; s < samples; ++s) kth[s] = std::sqrt(last_d2[row(s * stride)]);
    return kth;
  });
  if (std::isinf(nb.eps)) return nb;
  const double max_d2 = nb.eps * nb.eps;
  const auto stride = static_cast<std::size_t>(nb.stride);
  parallel_for(n, [&](std::size_t begin, std::size_t end) {
    for (std::size_t p = begin; p < end; ++p) {
      const std::size_t r = row(p);
      if (!(last_d2[r] > max_d2)) continue;
      Index* slots = nb.indices.data() + r * stride;
      const std::size_t count = nb.counts[r];
      std::size_t keep = 0;
      for (; keep < count; ++keep) {
        // Summed as the k-d tree sums it: x, y, z.
        const Vec3& q = points[slots[keep]];
        const double dx = points[p].x() - q.x(), dy = points[p].y() - q.y(), dz = points[p].z() - q.z();
        if (!(dx * dx + dy * dy + dz * dz <= max_d2)) break;
      }
      std::fill(slots + keep, slots + count, Index{0});
      nb.counts[r] = static_cast<std::uint16_t>(keep);
    }
  }, 8192);
  return nb;
}

}  // namespace pointfair
