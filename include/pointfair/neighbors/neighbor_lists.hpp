#pragma once
// The neighbour lists as data: a flat array with a fixed stride k plus a count per point, in
// canonical order (by distance, ties by the smaller index), owned (Neighborhoods) or viewed
// (NeighborhoodsView). Every search fills them (neighborhoods.hpp, knn_grid.hpp) and every
// kernel reads them; the searches build on this header, not on each other.
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "pointfair/types.hpp"

namespace pointfair {

/// Fixed-stride neighbour lists. Slot j < counts[i] of point i holds indices[i*stride + j].
struct Neighborhoods {
  int stride = 0;
  std::vector<Index> indices;
  std::vector<std::uint16_t> counts;
  /// The radius bound that was used (length); +infinity if none.
  double eps = std::numeric_limits<double>::infinity();

  std::size_t size() const { return counts.size(); }
  std::span<const Index> of(std::size_t i) const {
    return {indices.data() + i * static_cast<std::size_t>(stride), counts[i]};
  }
};

/// The same lists, held elsewhere (a Neighborhoods, or a file mapped into memory): what the
/// step kernels read. Does not own its arrays, which must outlive it.
struct NeighborhoodsView {
  int stride = 0;
  std::span<const Index> indices;  ///< size() * stride entries
  std::span<const std::uint16_t> counts;
  double eps = std::numeric_limits<double>::infinity();

  NeighborhoodsView() = default;
  NeighborhoodsView(int stride_, std::span<const Index> indices_, std::span<const std::uint16_t> counts_, double eps_)
      : stride(stride_), indices(indices_), counts(counts_), eps(eps_) {}
  // Implicit: every kernel that takes a view takes a Neighborhoods.
  NeighborhoodsView(const Neighborhoods& n)  // NOLINT(google-explicit-constructor)
      : stride(n.stride), indices(n.indices), counts(n.counts), eps(n.eps) {}

  std::size_t size() const { return counts.size(); }
  std::span<const Index> of(std::size_t i) const {
    return {indices.data() + i * static_cast<std::size_t>(stride), counts[i]};
  }
  /// Rows [first, first + rows).
  NeighborhoodsView rows(std::size_t first, std::size_t rows) const {
    const std::size_t s = static_cast<std::size_t>(stride);
    return {stride, indices.subspan(first * s, rows * s), counts.subspan(first, rows), eps};
  }
};

}  // namespace pointfair
