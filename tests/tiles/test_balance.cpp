// balance_ranges: contiguous parts of the tile order, of about equal cost.
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>

#include "pointfair/common/params_error.hpp"
#include "pointfair/tiles/balance.hpp"

using pointfair::tiles::balance_ranges;

namespace {

std::uint64_t part_cost(const std::vector<std::uint64_t>& costs, const std::vector<std::size_t>& b, std::size_t p) {
  return std::accumulate(costs.begin() + static_cast<std::ptrdiff_t>(b[p]),
                         costs.begin() + static_cast<std::ptrdiff_t>(b[p + 1]), std::uint64_t{0});
}

}  // namespace

TEST(BalanceRanges, EqualCostsSplitEvenly) {
  const std::vector<std::uint64_t> costs(12, 5);
  EXPECT_EQ(balance_ranges(costs, 1), (std::vector<std::size_t>{0, 12}));
  EXPECT_EQ(balance_ranges(costs, 2), (std::vector<std::size_t>{0, 6, 12}));
  EXPECT_EQ(balance_ranges(costs, 3), (std::vector<std::size_t>{0, 4, 8, 12}));
  EXPECT_EQ(balance_ranges(costs, 4), (std::vector<std::size_t>{0, 3, 6, 9, 12}));
}

TEST(BalanceRanges, HeavyTileGetsAPartOfItsOwn) {
  // One tile with most of the cost: the other part takes everything else.
  const std::vector<std::uint64_t> costs{1, 1, 100, 1, 1};
  const auto b = balance_ranges(costs, 2);
  ASSERT_EQ(b.size(), 3u);
  EXPECT_EQ(b.front(), 0u);
  EXPECT_EQ(b.back(), 5u);
  EXPECT_TRUE(b[1] == 2 || b[1] == 3);
}

TEST(BalanceRanges, MorePartsThanTilesLeavesEmptyParts) {
  const std::vector<std::uint64_t> costs{7, 7};
  const auto b = balance_ranges(costs, 4);
  ASSERT_EQ(b.size(), 5u);
  EXPECT_TRUE(std::is_sorted(b.begin(), b.end()));
  EXPECT_EQ(b.front(), 0u);
  EXPECT_EQ(b.back(), 2u);
  EXPECT_EQ(balance_ranges(std::vector<std::uint64_t>{}, 3), (std::vector<std::size_t>{0, 0, 0, 0}));
}

TEST(BalanceRanges, NoPartExceedsItsShareByMoreThanOneTile) {
  std::mt19937_64 rng(5);
  std::uniform_int_distribution<std::uint64_t> cost(0, 1000);
  for (int trial = 0; trial < 50; ++trial) {
    std::vector<std::uint64_t> costs(1 + static_cast<std::size_t>(trial) * 7);
    for (auto& c : costs) c = cost(rng);
    const std::uint64_t total = std::accumulate(costs.begin(), costs.end(), std::uint64_t{0});
    const std::uint64_t largest = *std::max_element(costs.begin(), costs.end());
    for (int parts = 1; parts <= 5; ++parts) {
      const auto b = balance_ranges(costs, parts);
      ASSERT_EQ(b.size(), static_cast<std::size_t>(parts) + 1);
      EXPECT_EQ(b.front(), 0u);
      EXPECT_EQ(b.back(), costs.size());
      EXPECT_TRUE(std::is_sorted(b.begin(), b.end()));
      for (std::size_t p = 0; p < static_cast<std::size_t>(parts); ++p)
        EXPECT_LE(part_cost(costs, b, p), total / static_cast<std::uint64_t>(parts) + 2 * largest);
    }
  }
}

TEST(BalanceRanges, RejectsZeroParts) {
  EXPECT_THROW(balance_ranges(std::vector<std::uint64_t>{1}, 0), pointfair::ParamError);
}
