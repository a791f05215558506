#pragma once
// The k-th smallest of a few hundred doubles, as std::nth_element finds it, without most of
// its mispredicted comparisons: the kernels take the median of every neighbourhood's
// residuals, up to three times a fit, and the comparisons of the partitions were a large share
// of the finish. Internal: not installed.
#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>

namespace pointfair::detail {

/// The value std::nth_element(values, k) would put at position k (the k-th smallest, k from 0)
/// of the finite `values`; `scratch` (at least as long) is work space and `values` is only
/// read. Buckets by (value - min) / (max - min), a monotone map, so that every value of a
/// bucket is at most every value of the next: the k-th value is the r-th of the bucket that
/// holds rank k, found among its few values.
[[gnu::always_inline]] inline double select_kth(std::span<const double> values, std::size_t k,
                                                std::span<double> scratch) {
  const std::size_t n = values.size();
  assert(k < n && scratch.size() >= n);
  double lo = values[0], hi = values[0];
  for (std::size_t j = 1; j < n; ++j) {
    lo = std::min(lo, values[j]);
    hi = std::max(hi, values[j]);
  }
  constexpr std::size_t kMaxBuckets = 256;
  const std::size_t buckets = std::min(n, kMaxBuckets);
  if (!(hi > lo) || !std::isfinite(hi - lo) || buckets < 2) {
    if (!(hi > lo) && std::isfinite(lo)) return lo;  // all equal
    std::copy(values.begin(), values.end(), scratch.begin());
    std::nth_element(scratch.begin(), scratch.begin() + static_cast<std::ptrdiff_t>(k),
                     scratch.begin() + static_cast<std::ptrdiff_t>(n));
    return scratch[k];
  }
  const double scale = static_cast<double>(buckets) / (hi - lo);
  const auto bucket_of = [&](double v) {
    return std::min(buckets - 1, static_cast<std::size_t>((v - lo) * scale));
  };
  std::uint32_t counts[kMaxBuckets] = {};
  for (std::size_t j = 0; j < n; ++j) ++counts[bucket_of(values[j])];
  std::size_t bucket = 0, before = 0;
  while (before + counts[bucket] <= k) before += counts[bucket++];
  std::size_t m = 0;
  for (std::size_t j = 0; j < n; ++j)
    if (bucket_of(values[j]) == bucket) scratch[m++] = values[j];
  const std::size_t r = k - before;
  std::nth_element(scratch.begin(), scratch.begin() + static_cast<std::ptrdiff_t>(r),
                   scratch.begin() + static_cast<std::ptrdiff_t>(m));
  return scratch[r];
}

}  // namespace pointfair::detail
