// RowMap (src/tiles/row_map.hpp): the temporal block's row -> local index lookup, against
// std::map.
#include <gtest/gtest.h>

#include <map>
#include <random>

#include "row_map.hpp"

namespace pointfair::tiles {
namespace {

TEST(RowMap, MatchesStdMapThroughGrowth) {
  std::mt19937_64 rng(5);
  // Rows clustered like a tile's rings (runs of near rows) and scattered far ones.
  std::uniform_int_distribution<std::uint64_t> far(0, std::uint64_t{1} << 40), near(0, 5000);
  RowMap map;
  map.reset(0);  // grows from the smallest table
  std::map<std::uint64_t, Index> truth;
  for (Index i = 0; i < 20000; ++i) {
    const std::uint64_t row = i % 3 == 0 ? far(rng) : 1000000 + near(rng);
    const bool added = map.insert(row, i);
    EXPECT_EQ(added, truth.emplace(row, i).second) << "row " << row;
  }
  for (const auto& [row, local] : truth) {
    const Index* found = map.find(row);
    ASSERT_NE(found, nullptr) << "row " << row;
    EXPECT_EQ(*found, local);
  }
  for (int i = 0; i < 1000; ++i) {
    const std::uint64_t row = far(rng) + (std::uint64_t{1} << 41);  // never inserted
    EXPECT_EQ(map.find(row), nullptr);
  }
  // set() changes the value of a present row only.
  const std::uint64_t some = truth.begin()->first;
  map.set(some, 7);
  EXPECT_EQ(*map.find(some), 7u);
  EXPECT_LE(map.bytes(), RowMap::kBytesPerRow * truth.size());
}

TEST(RowMap, ResetEmptiesIt) {
  RowMap map;
  EXPECT_EQ(map.find(42), nullptr);  // a new map is empty
  map.reset(4);
  EXPECT_TRUE(map.insert(42, 1));
  EXPECT_FALSE(map.insert(42, 2));
  EXPECT_EQ(*map.find(42), 1u);
  map.reset(4);
  EXPECT_EQ(map.find(42), nullptr);
  EXPECT_TRUE(map.insert(0, 3));  // row 0 is an ordinary key
  EXPECT_EQ(*map.find(0), 3u);
}

}  // namespace
}  // namespace pointfair::tiles
