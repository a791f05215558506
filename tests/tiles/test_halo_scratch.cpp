// The halo scratch of streamed steps: each tile's halo read back as the tiles holding its
// points wrote it, in both buffers independently; nothing left in the directory; clear errors.
#include "halo_scratch.hpp"

#include <algorithm>
#include <random>
#include <vector>

#include "pointfair/common/params_error.hpp"
#include "pointfair/io/point_table.hpp"
#include "tiles_test_util.hpp"

using namespace pointfair;
using namespace pointfair::tiles;

namespace {

class HaloScratchTest : public test::TempDirTest {};

// A point's value in buffer b: its row and the buffer, so a misplaced point shows.
Vec3 value_of(std::uint64_t row, int b) { return {static_cast<double>(row), b + 0.5, -static_cast<double>(row)}; }

TEST_F(HaloScratchTest, EachTileReadsItsHaloAsTheOwnersWroteIt) {
  // Tiles of 0 to 60 rows (some empty), each with a halo of random rows of other tiles.
  std::mt19937_64 rng(7);
  std::vector<std::uint64_t> offsets{0};
  for (int t = 0; t < 12; ++t) offsets.push_back(offsets.back() + (t == 4 ? 0 : rng() % 61));
  const std::size_t tiles = offsets.size() - 1;
  std::vector<std::vector<std::uint64_t>> halos(tiles);
  for (std::size_t t = 0; t < tiles; ++t) {
    if (t == 7) continue;  // a tile without halo
    for (std::uint64_t g = 0; g < offsets.back(); ++g)
      if ((g < offsets[t] || g >= offsets[t + 1]) && rng() % 3 == 0) halos[t].push_back(g);
  }
  HaloScratch scratch(dir_, "halos", halos, offsets, 0, tiles);
  EXPECT_TRUE(std::filesystem::is_empty(dir_)) << "the scratch file is unlinked";
  for (const int b : {0, 1}) {
    // The owners write in an order of their own.
    std::vector<std::size_t> order(tiles);
    for (std::size_t u = 0; u < tiles; ++u) order[u] = (u * 5) % tiles;
    for (const std::size_t u : order) {
      std::vector<Vec3> rows(offsets[u + 1] - offsets[u]);
      for (std::size_t r = 0; r < rows.size(); ++r) rows[r] = value_of(offsets[u] + r, b);
      scratch.write(b, u, rows.data());
    }
  }
  for (const int b : {1, 0}) {
    for (std::size_t t = 0; t < tiles; ++t) {
      std::vector<Vec3> got(halos[t].size(), Vec3::Constant(-1.0));
      scratch.read(b, t, got.data());
      for (std::size_t j = 0; j < got.size(); ++j) ASSERT_EQ(got[j], value_of(halos[t][j], b)) << t << " " << j;
    }
  }
  EXPECT_GT(scratch.bytes(), 0u);
}

TEST_F(HaloScratchTest, ARangeOfTilesAndLongRunsThroughTheStagingBuffer) {
  // Tiles [1, 3) of 4: halos name only rows of those, runs longer than the staging buffer.
  const std::vector<std::uint64_t> offsets{0, 5, 20005, 40005, 40010};
  std::vector<std::vector<std::uint64_t>> halos(4);
  for (std::uint64_t g = 20005; g < 40005; ++g) halos[1].push_back(g);
  for (std::uint64_t g = 5; g < 20005; g += 3) halos[2].push_back(g);
  HaloScratch scratch(dir_, "halos", halos, offsets, 1, 3);
  for (const std::size_t u : {std::size_t{1}, std::size_t{2}}) {
    std::vector<Vec3> rows(offsets[u + 1] - offsets[u]);
    for (std::size_t r = 0; r < rows.size(); ++r) rows[r] = value_of(offsets[u] + r, 1);
    scratch.write(1, u, rows.data());
  }
  for (const std::size_t t : {std::size_t{1}, std::size_t{2}}) {
    std::vector<Vec3> got(halos[t].size());
    scratch.read(1, t, got.data());
    for (std::size_t j = 0; j < got.size(); ++j) ASSERT_EQ(got[j], value_of(halos[t][j], 1));
  }
  EXPECT_EQ(scratch.buffer_bytes(), (halos[1].size() + halos[2].size()) * sizeof(Vec3));
}

#ifndef NDEBUG
// Halos out of order or range are the run's own bug: a debug assertion, not an error.
TEST_F(HaloScratchTest, BadHalosFailItsDebugAssertions) {
  const std::vector<std::uint64_t> offsets{0, 4, 8};
  const std::vector<std::vector<std::uint64_t>> descending{{6, 5}, {}}, outside{{9}, {}};
  EXPECT_DEATH(HaloScratch(dir_, "h", descending, offsets, 0, 2), "");
  EXPECT_DEATH(HaloScratch(dir_, "h", outside, offsets, 0, 2), "");
}
#endif

TEST_F(HaloScratchTest, NamesAMissingDirectory) {
  const std::vector<std::uint64_t> offsets{0, 4, 8};
  const std::vector<std::vector<std::uint64_t>> fine{{5}, {0}};
  try {
    HaloScratch(dir_ / "missing", "run.h5 (halo scratch)", fine, offsets, 0, 2);
    FAIL() << "no error";
  } catch (const io::IoError& e) {
    EXPECT_NE(std::string(e.what()).find("run.h5 (halo scratch): cannot create"), std::string::npos) << e.what();
  }
}

TEST_F(HaloScratchTest, AMappingShowsTheBytesWrittenAtAnyOffset) {
  // ScratchFile::map: ranges starting inside a page and spanning several, read in place; a
  // mapping outlives its file and moves; an empty one maps nothing.
  std::vector<unsigned char> bytes(3 * 4096 + 123);
  for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<unsigned char>((i * 7 + 3) % 251);
  ScratchFile::Mapping kept;
  {
    ScratchFile file(dir_, "lists");
    file.write(bytes.data(), bytes.size(), 0);
    for (const auto& [offset, length] : {std::pair<std::uint64_t, std::uint64_t>{0, 10}, {8, 4096}, {4095, 2}, {1000, 10000}}) {
      const ScratchFile::Mapping m = file.map(offset, length);
      ASSERT_EQ(m.size(), length);
      for (std::uint64_t i = 0; i < length; ++i) ASSERT_EQ(m.data()[i], bytes[offset + i]) << offset << " + " << i;
    }
    EXPECT_EQ(file.map(100, 0).size(), 0u);
    ScratchFile::Mapping moved = file.map(4104, 16);
    kept = std::move(moved);
    EXPECT_EQ(moved.data(), nullptr);
  }
  ASSERT_EQ(kept.size(), 16u);
  for (std::uint64_t i = 0; i < 16; ++i) EXPECT_EQ(kept.data()[i], bytes[4104 + i]);
  EXPECT_TRUE(std::filesystem::is_empty(dir_));
}

}  // namespace
