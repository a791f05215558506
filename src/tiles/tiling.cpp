#include "pointfair/tiles/tiling.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>

#include "pointfair/common/params_error.hpp"

namespace pointfair::tiles {

void TilingParams::validate() const {
  require(max_tile_points >= 1, "max tile points must be >= 1");
  require(cell_size >= 0.0 && std::isfinite(cell_size),
          "tile cell size must be >= 0 (0 = kd tiles), got " + std::to_string(cell_size));
}

Box bounds_of(std::span<const Vec3> points) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  Box b{inf, inf, inf, -inf, -inf, -inf};
  for (const Vec3& p : points) {
    for (int c = 0; c < 3; ++c) {
      b[static_cast<std::size_t>(c)] = std::min(b[static_cast<std::size_t>(c)], p[c]);
      b[static_cast<std::size_t>(c) + 3] = std::max(b[static_cast<std::size_t>(c) + 3], p[c]);
    }
  }
  return b;
}

bool intersects(const Box& a, double margin, const Box& b) {
  for (std::size_t c = 0; c < 3; ++c) {
    if (b[c + 3] < a[c] - margin || b[c] > a[c + 3] + margin) return false;
  }
  return true;
}

namespace {

// Rows of a tile in the depth-first order of kd cells of at most this many points: points
// near in space are near in memory, which the per-step kernels need to run at full speed
// (the result does not depend on the row order).
constexpr std::size_t kLocalityLeaf = 32;

std::size_t split_axis(std::span<const Vec3> points, const std::vector<std::uint64_t>& order,
                       std::size_t begin, std::size_t end);

void locality_order(std::span<const Vec3> points, std::vector<std::uint64_t>& order, std::size_t begin,
                    std::size_t end) {
  if (end - begin <= kLocalityLeaf) {
    std::sort(order.begin() + static_cast<std::ptrdiff_t>(begin), order.begin() + static_cast<std::ptrdiff_t>(end));
    return;
  }
  const auto a = static_cast<Eigen::Index>(split_axis(points, order, begin, end));
  const std::size_t mid = begin + (end - begin) / 2;
  std::nth_element(order.begin() + static_cast<std::ptrdiff_t>(begin),
                   order.begin() + static_cast<std::ptrdiff_t>(mid),
                   order.begin() + static_cast<std::ptrdiff_t>(end),
                   [&](std::uint64_t i, std::uint64_t j) {
                     const double pi = points[i][a], pj = points[j][a];
                     return pi < pj || (pi == pj && i < j);
                   });
  locality_order(points, order, begin, mid);
  locality_order(points, order, mid, end);
}

void add_tile(std::span<const Vec3> points, std::vector<std::uint64_t>& order, std::size_t begin,
              std::size_t end, Tiling& out) {
  locality_order(points, order, begin, end);
  out.offsets.push_back(end);
  std::vector<Vec3> tile;
  tile.reserve(end - begin);
  for (std::size_t r = begin; r < end; ++r) tile.push_back(points[order[r]]);
  out.bounds.push_back(bounds_of(tile));
}

std::size_t split_axis(std::span<const Vec3> points, const std::vector<std::uint64_t>& order,
                       std::size_t begin, std::size_t end) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  Box box{inf, inf, inf, -inf, -inf, -inf};
  for (std::size_t r = begin; r < end; ++r) {
    const Vec3& p = points[order[r]];
    for (std::size_t c = 0; c < 3; ++c) {
      box[c] = std::min(box[c], p[static_cast<Eigen::Index>(c)]);
      box[c + 3] = std::max(box[c + 3], p[static_cast<Eigen::Index>(c)]);
    }
  }
  std::size_t axis = 0;
  for (std::size_t c = 1; c < 3; ++c)
    if (box[c + 3] - box[c] > box[axis + 3] - box[axis]) axis = c;
  return axis;
}

void split(std::span<const Vec3> points, std::vector<std::uint64_t>& order, std::size_t begin,
           std::size_t end, std::uint64_t max_points, Tiling& out) {
  if (end - begin <= max_points) {
    add_tile(points, order, begin, end, out);
    return;
  }
  Box box;
  {
    constexpr double inf = std::numeric_limits<double>::infinity();
    box = {inf, inf, inf, -inf, -inf, -inf};
    for (std::size_t r = begin; r < end; ++r) {
      const Vec3& p = points[order[r]];
      for (std::size_t c = 0; c < 3; ++c) {
        box[c] = std::min(box[c], p[static_cast<Eigen::Index>(c)]);
        box[c + 3] = std::max(box[c + 3], p[static_cast<Eigen::Index>(c)]);
      }
    }
  }
  std::size_t axis = 0;
  for (std::size_t c = 1; c < 3; ++c)
    if (box[c + 3] - box[c] > box[axis + 3] - box[axis]) axis = c;
  const auto a = static_cast<Eigen::Index>(axis);
  const std::size_t mid = begin + (end - begin) / 2;
  std::nth_element(order.begin() + static_cast<std::ptrdiff_t>(begin),
                   order.begin() + static_cast<std::ptrdiff_t>(mid),
                   order.begin() + static_cast<std::ptrdiff_t>(end),
                   [&](std::uint64_t i, std::uint64_t j) {
                     const double pi = points[i][a], pj = points[j][a];
                     return pi < pj || (pi == pj && i < j);
                   });
  split(points, order, begin, mid, max_points, out);
  split(points, order, mid, end, max_points, out);
}

}  // namespace

Tiling make_tiling(std::span<const Vec3> points, const TilingParams& params) {
  params.validate();
  Tiling t;
  t.order.resize(points.size());
  std::iota(t.order.begin(), t.order.end(), std::uint64_t{0});
  t.offsets.push_back(0);
  if (params.cell_size <= 0.0) {
    if (points.empty()) {
      t.offsets.push_back(0);
      t.bounds.push_back(bounds_of({}));
      return t;
    }
    split(points, t.order, 0, points.size(), params.max_tile_points, t);
    return t;
  }
  // A regular grid: cells in x-fastest order over the bounding box.
  const Box all = bounds_of(points);
  std::array<std::uint64_t, 3> dims{1, 1, 1};
  if (!points.empty()) {
    for (std::size_t c = 0; c < 3; ++c) {
      const double cells = std::floor((all[c + 3] - all[c]) / params.cell_size) + 1.0;
      require(cells <= double(1u << 22), "tile grid too fine: increase the cell size");
      dims[c] = static_cast<std::uint64_t>(cells);
    }
  }
  const std::uint64_t cells = dims[0] * dims[1] * dims[2];
  require(cells <= (1u << 22), "tile grid has " + std::to_string(cells) +
                                   " cells (at most 4194304): increase the cell size");
  std::vector<std::uint64_t> cell_of(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    std::uint64_t cell = 0, scale = 1;
    for (std::size_t c = 0; c < 3; ++c) {
      const double f = std::floor((points[i][static_cast<Eigen::Index>(c)] - all[c]) / params.cell_size);
      const auto g = std::min<std::uint64_t>(dims[c] - 1, static_cast<std::uint64_t>(std::max(0.0, f)));
      cell += g * scale;
      scale *= dims[c];
    }
    cell_of[i] = cell;
  }
  std::stable_sort(t.order.begin(), t.order.end(),
                   [&](std::uint64_t i, std::uint64_t j) { return cell_of[i] < cell_of[j]; });
  std::size_t r = 0;
  for (std::uint64_t cell = 0; cell < cells; ++cell) {
    const std::size_t begin = r;
    while (r < t.order.size() && cell_of[t.order[r]] == cell) ++r;
    add_tile(points, t.order, begin, r, t);
  }
  return t;
}

}  // namespace pointfair::tiles
