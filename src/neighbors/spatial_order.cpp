#include "pointfair/neighbors/spatial_order.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"

namespace pointfair {
namespace {

// Spreads the low 21 bits of v so that there are two zero bits between consecutive bits.
std::uint64_t spread_bits(std::uint64_t v) {
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffffULL;
  v = (v | v << 16) & 0x1f0000ff0000ffULL;
  v = (v | v << 8) & 0x100f00f00f00f00fULL;
  v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
  v = (v | v << 2) & 0x1249249249249249ULL;
  return v;
}

}  // namespace

MortonGrid morton_grid(const Vec3& low, const Vec3& high) {
  const double extent = (high - low).maxCoeff();
  return {low, extent > 0 ? (static_cast<double>((1u << 21) - 1)) / extent : 0.0};
}

MortonGrid morton_grid(std::span<const Vec3> points) {
  if (points.empty()) return {};
  Vec3 low = points[0], high = points[0];
  for (const auto& p : points) {
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
  }
  return morton_grid(low, high);
}

std::uint64_t morton_code(const MortonGrid& grid, const Vec3& p) {
  const Vec3 q = (p - grid.low) * grid.scale;
  // NaN (a non-finite coordinate or extent) goes to cell 0: the order stays defined.
  auto axis = [](double v) { return static_cast<std::uint64_t>(v > 0.0 ? std::min(v, 2097151.0) : 0.0); };
  return spread_bits(axis(q.x())) | spread_bits(axis(q.y())) << 1 | spread_bits(axis(q.z())) << 2;
}

std::vector<Index> spatial_order(std::span<const Vec3> points) { return spatial_order(points, morton_grid(points)); }

std::vector<Index> spatial_order(std::span<const Vec3> points, const MortonGrid& grid) {
  const std::size_t n = points.size();
  std::vector<Index> order(n);
  if (n == 0) return order;
  std::vector<std::pair<std::uint64_t, Index>> keyed(n);
  parallel_for(n, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) keyed[i] = {morton_code(grid, points[i]), static_cast<Index>(i)};
  }, 8192);
  std::sort(keyed.begin(), keyed.end());
  for (std::size_t s = 0; s < n; ++s) order[s] = keyed[s].second;
  return order;
}

std::vector<Index> inverse_permutation(std::span<const Index> order) {
  std::vector<Index> inverse(order.size());
  for (std::size_t s = 0; s < order.size(); ++s) inverse[order[s]] = static_cast<Index>(s);
  return inverse;
}

Neighborhoods permute_neighborhoods(const Neighborhoods& nb, std::span<const Index> order,
                                    std::span<const Index> inverse) {
  Neighborhoods out;
  out.stride = nb.stride;
  out.eps = nb.eps;
  const auto stride = static_cast<std::size_t>(nb.stride);
  out.indices.assign(nb.indices.size(), 0);
  out.counts.resize(nb.counts.size());
  parallel_for(order.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t s = begin; s < end; ++s) {
      const std::size_t row = order[s];
      out.counts[s] = nb.counts[row];
      const Index* in = nb.indices.data() + row * stride;
      Index* dst = out.indices.data() + s * stride;
      for (std::size_t j = 0; j < nb.counts[row]; ++j) dst[j] = inverse[in[j]];
    }
  }, 8192);
  return out;
}

Neighborhoods build_reordered_neighborhoods(std::span<const Vec3> points, const NeighborParams& params,
                                            std::span<const Index> order,
                                            std::span<const Index> row_of) {
  params.validate();
  require(order.size() == points.size() && row_of.size() == points.size(),
          "build_reordered_neighborhoods: order and row_of must hold one entry per point");
  // Row s is point order[s]: its list goes to row row_of[order[s]] = s.
  Neighborhoods nb = build_neighborhoods(points, params, row_of);
  relabel_neighborhoods_in_place(nb, row_of);
  return nb;
}

void relabel_neighborhoods_in_place(Neighborhoods& nb, std::span<const Index> row_of) {
  const auto stride = static_cast<std::size_t>(nb.stride);
  parallel_for(nb.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t s = begin; s < end; ++s) {
      Index* row = nb.indices.data() + s * stride;
      for (std::size_t j = 0; j < nb.counts[s]; ++j) row[j] = row_of[row[j]];
    }
  }, 8192);
}

namespace {

// Applies the permutation "slot s takes the item from slot order[s]" in place, following each
// cycle once: save(s) keeps slot s aside, move(to, from) copies a slot, restore(s) puts the
// saved item into slot s.
template <class Save, class Move, class Restore>
void follow_cycles(std::size_t n, std::span<const Index> order, Save save, Move move, Restore restore) {
  std::vector<bool> done(n, false);
  for (std::size_t start = 0; start < n; ++start) {
    if (done[start]) continue;
    save(start);
    std::size_t s = start;
    while (true) {
      done[s] = true;
      const std::size_t from = order[s];
      if (from == start) {
        restore(s);
        break;
      }
      move(s, from);
      s = from;
    }
  }
}

}  // namespace

void permute_in_place(std::vector<Vec3>& values, std::span<const Index> order) {
  Vec3 saved;
  follow_cycles(values.size(), order, [&](std::size_t s) { saved = values[s]; },
                [&](std::size_t to, std::size_t from) { values[to] = values[from]; },
                [&](std::size_t s) { values[s] = saved; });
}

void permute_neighborhoods_in_place(Neighborhoods& nb, std::span<const Index> order,
                                    std::span<const Index> inverse) {
  const auto stride = static_cast<std::size_t>(nb.stride);
  parallel_for(nb.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t s = begin; s < end; ++s) {
      Index* row = nb.indices.data() + s * stride;
      for (std::size_t j = 0; j < nb.counts[s]; ++j) row[j] = inverse[row[j]];
    }
  }, 8192);
  std::vector<Index> saved_row(stride);
  std::uint16_t saved_count = 0;
  follow_cycles(
      nb.size(), order,
      [&](std::size_t s) {
        std::copy_n(nb.indices.data() + s * stride, stride, saved_row.data());
        saved_count = nb.counts[s];
      },
      [&](std::size_t to, std::size_t from) {
        std::copy_n(nb.indices.data() + from * stride, stride, nb.indices.data() + to * stride);
        nb.counts[to] = nb.counts[from];
      },
      [&](std::size_t s) {
        std::copy_n(saved_row.data(), stride, nb.indices.data() + s * stride);
        nb.counts[s] = saved_count;
      });
}

std::vector<Vec3> gather(std::span<const Vec3> in, std::span<const Index> order) {
  std::vector<Vec3> out(order.size());
  for (std::size_t s = 0; s < order.size(); ++s) out[s] = in[order[s]];
  return out;
}

std::vector<Vec3> scatter(std::span<const Vec3> in, std::span<const Index> order) {
  std::vector<Vec3> out(order.size());
  for (std::size_t s = 0; s < order.size(); ++s) out[order[s]] = in[s];
  return out;
}

}  // namespace pointfair
