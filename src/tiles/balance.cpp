#include "pointfair/tiles/balance.hpp"

#include <algorithm>

#include "pointfair/common/params_error.hpp"

namespace pointfair::tiles {

std::vector<std::size_t> balance_ranges(std::span<const std::uint64_t> costs, int parts) {
  require(parts >= 1, "the tiles are split into at least one part");
  const std::size_t n = costs.size(), p = static_cast<std::size_t>(parts);
  std::vector<std::uint64_t> prefix(n + 1, 0);
  for (std::size_t t = 0; t < n; ++t) prefix[t + 1] = prefix[t] + costs[t];
  const std::uint64_t total = prefix[n];
  std::vector<std::size_t> bounds(p + 1, 0);
  bounds[p] = n;
  for (std::size_t q = 1; q < p; ++q) {
    const long double target = static_cast<long double>(total) * static_cast<long double>(q) / static_cast<long double>(p);
    std::size_t i = static_cast<std::size_t>(
        std::lower_bound(prefix.begin(), prefix.end(), target, [](std::uint64_t a, long double b) {
          return static_cast<long double>(a) < b;
        }) - prefix.begin());
    // Nearest of i - 1 and i.
    if (i > 0 && target - static_cast<long double>(prefix[i - 1]) < static_cast<long double>(prefix[i]) - target) --i;
    bounds[q] = std::clamp(i, bounds[q - 1], n);
  }
  return bounds;
}

}  // namespace pointfair::tiles
